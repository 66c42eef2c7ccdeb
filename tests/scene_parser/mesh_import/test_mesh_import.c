/* Mesh import through assimp: counts, the MTL material mapping, errors. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "scene_internal.h"
#include "vbnl/mesh_import.h"
#include "vbnl/vbnl.h"

static char g_dir[512];

/* A McGuire box of examples/mcguire (written by tools/gen_mcguire_boxes.py). */
static const char *mcguire_scene(const char *name, char *buf, size_t n)
{
    const char *src = getenv("VBNL_SOURCE_DIR");
    snprintf(buf, n, "%s/examples/mcguire/%s", src ? src : ".", name);
    return buf;
}

/* A context of one worker thread (the caller destroys it). */
static vbnl_context *one_thread_context(void)
{
    vbnl_context *ctx = NULL;
    vbnl_context_desc d;
    vbnl_context_desc_init(&d);
    d.threads = 1;
    assert_int_equal(vbnl_context_create(&d, &ctx, NULL), VBNL_OK);
    return ctx;
}

static vbnl_scene *import(vbnl_context *ctx, const char *path, vbnl_mesh_import_stats *st, vbnl_result expect)
{
    vbnl_scene *s = NULL;
    assert_int_equal(vbnl_scene_create(ctx, &s, NULL), VBNL_OK);
    vbnl_error err = {0};
    vbnl_result r = vbnl_mesh_import(s, path, NULL, st, &err);
    if (r != expect)
        fail_msg("import of %s: %s (%s)", path, vbnl_result_name(r), err.message);
    return s;
}

static void test_phong_to_alpha(void **state)
{
    (void)state;
    assert_float_equal(vbnl_phong_exponent_to_alpha(0.0f), 1.0f, 1e-6f);
    assert_float_equal(vbnl_phong_exponent_to_alpha(10.0f), sqrtf(2.0f / 12.0f), 1e-6f);
    assert_float_equal(vbnl_phong_exponent_to_alpha(32.0f), sqrtf(2.0f / 34.0f), 1e-6f);
    assert_float_equal(vbnl_phong_exponent_to_alpha(1e9f), 0.001f, 1e-6f);
    assert_float_equal(vbnl_phong_exponent_to_alpha(-5.0f), 1.0f, 1e-6f);
}

static void test_cornell_original(void **state)
{
    (void)state;
    vbnl_context *ctx = one_thread_context();
    char path[1024];
    vbnl_mesh_import_stats st;
    vbnl_scene *s = import(ctx, mcguire_scene("CornellBox-Original.obj", path, sizeof(path)), &st, VBNL_OK);
    assert_int_equal(st.triangles, 36); /* 18 quads */
    assert_int_equal(st.materials, 9);  /* 8 in the MTL + assimp's default */
    assert_int_equal(st.emissive_materials, 1);
    /* every imported material is Lambertian; the light emits 17 12 4 */
    int lights = 0;
    for (uint32_t i = 0; i < s->material_count; ++i) {
        assert_int_equal(s->materials[i].desc.type, VBNL_MATERIAL_LAMBERT);
        if (s->materials[i].emissive) {
            assert_float_equal(s->materials[i].desc.emission[0], 17.0f, 1e-6f);
            assert_float_equal(s->materials[i].desc.emission[2], 4.0f, 1e-6f);
            ++lights;
        }
    }
    assert_int_equal(lights, 1);
    float pos[3] = {0, 1, 3.5f}, t[3] = {0, 1, 0}, up[3] = {0, 1, 0};
    vbnl_camera_desc cam;
    vbnl_camera_look_at(&cam, pos, t, up, 40, 1, NULL);
    vbnl_scene_set_camera(s, &cam, NULL);
    assert_int_equal(vbnl_scene_commit(s, NULL), VBNL_OK);
    /* the light quad faces down: a point below it receives light */
    assert_int_equal(s->light_count, 2);
    assert_true(s->lights[0].n.y < -0.99f);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

static const vbnl_material_desc *find_type(const vbnl_scene *s, vbnl_material_type type)
{
    for (uint32_t i = 0; i < s->material_count; ++i)
        if (s->materials[i].desc.type == type)
            return &s->materials[i].desc;
    return NULL;
}

static void test_material_mapping(void **state)
{
    (void)state;
    vbnl_context *ctx = one_thread_context();
    char path[1024];
    /* Mirror: tallBox has Ks 0.95, Ns 1000, illum 5 -> perfect mirror tinted 0.95 */
    vbnl_scene *s = import(ctx, mcguire_scene("CornellBox-Mirror.obj", path, sizeof(path)), NULL, VBNL_OK);
    const vbnl_material_desc *m = find_type(s, VBNL_MATERIAL_MIRROR);
    assert_non_null(m);
    assert_float_equal(m->base_color[0], 0.95f, 1e-6f);
    vbnl_scene_destroy(s);
    /* Glossy floor: Kd + Ks with Ns 32 -> plastic with alpha sqrt(2/34), ior Ni 1.5 */
    s = import(ctx, mcguire_scene("CornellBox-Glossy-Floor.obj", path, sizeof(path)), NULL, VBNL_OK);
    m = find_type(s, VBNL_MATERIAL_PLASTIC);
    assert_non_null(m);
    assert_float_equal(m->alpha, sqrtf(2.0f / 34.0f), 1e-5f);
    assert_float_equal(m->ior, 1.5f, 1e-6f);
    vbnl_scene_destroy(s);
    /* a hand-written MTL exercising the remaining rules */
    char obj[600], mtl[600];
    snprintf(obj, sizeof(obj), "%s/m.obj", g_dir);
    snprintf(mtl, sizeof(mtl), "%s/m.mtl", g_dir);
    FILE *f = fopen(mtl, "w");
    fputs("newmtl metal\nKd 0 0 0\nKs 0.9 0.6 0.3\nNs 100\nillum 2\n"
          "newmtl glass\nKd 0 0 0\nKs 1 1 1\nNi 1.33\nillum 7\n", f);
    fclose(f);
    f = fopen(obj, "w");
    fputs("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl metal\nf 1 2 3\nusemtl glass\nf 2 4 3\n", f);
    fclose(f);
    s = import(ctx, obj, NULL, VBNL_OK);
    m = find_type(s, VBNL_MATERIAL_CONDUCTOR);
    assert_non_null(m);
    assert_float_equal(m->base_color[1], 0.6f, 1e-6f);
    assert_float_equal(m->alpha, sqrtf(2.0f / 102.0f), 1e-5f);
    m = find_type(s, VBNL_MATERIAL_DIELECTRIC);
    assert_non_null(m);
    assert_float_equal(m->ior, 1.33f, 1e-5f);
    vbnl_scene_destroy(s);
    unlink(obj);
    unlink(mtl);
    vbnl_context_destroy(ctx);
}

static void test_errors(void **state)
{
    (void)state;
    vbnl_context *ctx = one_thread_context();
    vbnl_scene *s;
    vbnl_scene_create(ctx, &s, NULL);
    vbnl_error err = {0};
    assert_int_equal(vbnl_mesh_import(s, "/nonexistent/x.obj", NULL, NULL, &err), VBNL_ERR_IO);
    assert_non_null(strstr(err.message, "/nonexistent/x.obj"));
    char bad[600];
    snprintf(bad, sizeof(bad), "%s/bad.obj", g_dir);
    FILE *f = fopen(bad, "w");
    fputs("this is not a mesh\n", f);
    fclose(f);
    vbnl_result r = vbnl_mesh_import(s, bad, NULL, NULL, &err);
    assert_true(r == VBNL_ERR_IO || r == VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, bad));
    unlink(bad);
    assert_int_equal(vbnl_mesh_import(NULL, bad, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_int_equal(vbnl_mesh_import(s, NULL, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* Mesh files are untrusted: bad indices are errors, headers cannot ask for unbounded memory, and a
 * mesh file reads nothing outside its folder. */
static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void test_untrusted(void **state)
{
    (void)state;
    vbnl_context *ctx = one_thread_context();
    vbnl_scene *s;
    vbnl_scene_create(ctx, &s, NULL);
    vbnl_error err = {0};
    char p[700], sub[600];
    static const char head[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                               "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                               "end_header\n0 0 0\n1 0 0\n0 1 0\n";
    char text[512];
    snprintf(p, sizeof(p), "%s/index.ply", g_dir);
    snprintf(text, sizeof(text), "%s3 0 1 7\n", head);
    write_file(p, text);
    assert_int_not_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_OK);
    assert_non_null(strstr(err.message, "out of range"));
    snprintf(p, sizeof(p), "%s/huge.ply", g_dir);
    write_file(p, "ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\n"
                  "property float z\nend_header\n0 0 0\n");
    assert_int_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "declares 1000000000 elements"));
    /* a malformed header line (fuzzer-found: assimp's PLY reader loops on it) */
    snprintf(p, sizeof(p), "%s/loop.ply", g_dir);
    write_file(p, "ply\nformat ascii 1.0\nelement vertex 3\npropernd_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1\"2\n");
    assert_int_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "no PLY header line (line 4)"));
    unlink(p);
    /* a face claiming more indices than it gives (read on, it would swallow the lines after it) */
    snprintf(p, sizeof(p), "%s/lying.ply", g_dir);
    snprintf(text, sizeof(text), "%s255 0 1 2\n", head);
    write_file(p, text);
    assert_int_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "face 0 (line 13) declares a list of 255 numbers but gives 3"));
    snprintf(text, sizeof(text), "%s3 0 1 2 2\n", head);
    write_file(p, text);
    assert_int_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "face 0 (line 13) has more numbers than its properties take"));
    snprintf(text, sizeof(text), "%s", head);
    write_file(p, text);
    assert_int_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "it ends before face 0 of its 1"));
    /* binary: the same face, its list running past the end of the file; then exactly right */
    static const char bhead[] = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                                "property float y\nproperty float z\nelement face 1\n"
                                "property list uchar int vertex_indices\nend_header\n";
    unsigned char body[36 + 13];
    float verts[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    int32_t tri[3] = {0, 1, 2};
    memcpy(body, verts, 36);
    body[36] = 255;
    memcpy(body + 37, tri, 12);
    for (int claim = 255; claim >= 3; claim -= 252) {
        body[36] = (unsigned char)claim;
        FILE *bf = fopen(p, "wb");
        assert_non_null(bf);
        fwrite(bhead, 1, sizeof(bhead) - 1, bf);
        fwrite(body, 1, sizeof(body), bf);
        fclose(bf);
        vbnl_result br = vbnl_mesh_import(s, p, NULL, NULL, &err);
        if (claim == 255) {
            assert_int_equal(br, VBNL_ERR_INVALID_ARGUMENT);
            assert_non_null(strstr(err.message, "it ends inside face 0 of its 1"));
        } else {
            assert_int_equal(br, VBNL_OK);
        }
    }
    unlink(p);
    snprintf(p, sizeof(p), "%s/secret.mtl", g_dir);
    write_file(p, "newmtl a\nKd 1 0 0\n");
    snprintf(sub, sizeof(sub), "%s/sub", g_dir);
    assert_int_equal(mkdir(sub, 0700), 0);
    snprintf(p, sizeof(p), "%s/up.obj", sub);
    write_file(p, "mtllib ../secret.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
    assert_int_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_ERR_INVALID_ARGUMENT);
    assert_non_null(strstr(err.message, "outside its folder"));
    unlink(p);
    snprintf(p, sizeof(p), "%s/secret.mtl", g_dir);
    unlink(p);
    snprintf(p, sizeof(p), "%s/index.ply", g_dir);
    unlink(p);
    snprintf(p, sizeof(p), "%s/huge.ply", g_dir);
    unlink(p);
    rmdir(sub);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

/* An OBJ file cut short says so, naming the file, instead of assimp's words for what it then
 * lacks ("Mesh contains no faces", "mNumMeshes is 0", "all meshes are orphaned"). */
static void expect_truncated(vbnl_scene *s, const char *name, const char *text, const char *reason)
{
    char p[700];
    snprintf(p, sizeof(p), "%s/%s", g_dir, name);
    write_file(p, text);
    vbnl_error err = {0};
    vbnl_result r = vbnl_mesh_import(s, p, NULL, NULL, &err);
    if (r != VBNL_ERR_INVALID_ARGUMENT)
        fail_msg("%s: %s (%s)", name, vbnl_result_name(r), err.message);
    char want[900];
    snprintf(want, sizeof(want), "cannot import '%s': %s", p, reason);
    if (strncmp(err.message, want, strlen(want)) != 0)
        fail_msg("got \"%s\", want \"%s...\"", err.message, want);
    unlink(p);
}

static void test_truncated_obj(void **state)
{
    (void)state;
    vbnl_context *ctx = one_thread_context();
    vbnl_scene *s;
    vbnl_scene_create(ctx, &s, NULL);
    static const char *const no_faces = "no faces in it: truncated or empty OBJ?";
    /* cut in the vertices, before any object, in an object, and an empty file */
    expect_truncated(s, "cut1.obj", "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 0", no_faces);
    expect_truncated(s, "cut2.obj", "g a\nv 0 0 0\nv 1 0 0\n", no_faces);
    expect_truncated(s, "cut3.obj", "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\n", no_faces);
    expect_truncated(s, "empty.OBJ", "", no_faces);
    /* cut inside a face statement: the last line lacks its newline */
    expect_truncated(s, "cut4.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2",
                     "its last line (line 5) ends without a newline: truncated OBJ?");
    /* a whole OBJ with a bad face keeps assimp's words */
    char p[700];
    snprintf(p, sizeof(p), "%s/line.obj", g_dir);
    write_file(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n");
    vbnl_error err = {0};
    assert_int_not_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_OK);
    assert_null(strstr(err.message, "truncated"));
    unlink(p);
    /* whole files with faces import */
    snprintf(p, sizeof(p), "%s/whole.obj", g_dir);
    write_file(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_int_equal(vbnl_mesh_import(s, p, NULL, NULL, &err), VBNL_OK);
    unlink(p);
    vbnl_scene_destroy(s);
    vbnl_context_destroy(ctx);
}

int main(void)
{
    snprintf(g_dir, sizeof(g_dir), "/tmp/vbnl-mesh-XXXXXX");
    if (!mkdtemp(g_dir))
        return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_phong_to_alpha),
        cmocka_unit_test(test_cornell_original),
        cmocka_unit_test(test_material_mapping),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_untrusted),
        cmocka_unit_test(test_truncated_obj),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    rmdir(g_dir);
    return rc;
}
