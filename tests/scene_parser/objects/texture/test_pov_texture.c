/* The texture part of the POV-Ray scene language: texture / pigment / finish / interior /
 * material parsing, identifiers, #default, layered textures, the finish -> core material
 * mapping (every row of the table in scene_parser/README.md), patterns resolved to core
 * textures, image_map from a PNG, the vbnl_bsdf extension and exact error texts. The object
 * part is replaced by a small statement hook: `object_test { <modifiers> }`. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pov_internal.h"
#include "pov_texture.h"
#include "scene_internal.h"
#include "vbnl/vbnl.h"

typedef struct harness {
    vbnl_context *ctx;
    pov_ctx c;
    uint32_t mats[64];
    int emissive[64];
    int nmats;
    vbnl_result result;
} harness;

static int hook_statement(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, void *user)
{
    harness *h = user;
    if (strcmp(tok->text, "object_test") != 0)
        return 0;
    vbnl_sdl_next(p);
    if (vbnl_sdl_expect(p, '{', "after 'object_test'") != VBNL_OK)
        return -1;
    pov_appearance *app = NULL;
    for (;;) {
        const vbnl_sdl_token *t = vbnl_sdl_peek(p);
        if (t->kind == VBNL_SDL_TOK_PUNCT && t->op == '}') {
            vbnl_sdl_next(p);
            break;
        }
        if (!strcmp(t->text, "obj_scale")) { /* stands for an object transform after the texture */
            vbnl_sdl_next(p);
            double f;
            if (vbnl_sdl_parse_float(p, &f) != VBNL_OK) {
                pov_appearance_free(app);
                return -1;
            }
            double m[16] = {f, 0, 0, 0, 0, f, 0, 0, 0, 0, f, 0, 0, 0, 0, 1};
            pov_appearance_transform(app, m);
            continue;
        }
        if (!pov_appearance_is_modifier(t)) {
            vbnl_sdl_error(p, &t->loc, "object_test: '%s' is not a modifier", t->text);
            pov_appearance_free(app);
            return -1;
        }
        if (pov_appearance_parse_modifier(&h->c, &app) != VBNL_OK) {
            pov_appearance_free(app);
            return -1;
        }
    }
    double id[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    vbnl_error err = {0};
    pov_appearance *use = app ? app : pov_appearance_default(&h->c);
    vbnl_result r = pov_appearance_material(&h->c, use, id, &h->mats[h->nmats], &err);
    h->emissive[h->nmats] = pov_appearance_is_emissive(use);
    if (use != app)
        pov_appearance_free(use);
    pov_appearance_free(app);
    if (r != VBNL_OK) {
        vbnl_sdl_error(p, NULL, "%s", err.message);
        return -1;
    }
    h->nmats++;
    return 1;
}

static int hook_rvalue(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_value *out, void *user)
{
    (void)p;
    harness *h = user;
    return pov_appearance_rvalue(&h->c, tok, out);
}

static int hook_default(vbnl_sdl_parser *p, void *user)
{
    (void)p;
    harness *h = user;
    return pov_appearance_default_block(&h->c);
}

static harness *run(const char *text)
{
    harness *h = calloc(1, sizeof(*h));
    assert_non_null(h);
    vbnl_context_desc cd;
    vbnl_context_desc_init(&cd);
    cd.threads = 1;
    assert_int_equal(vbnl_context_create(&cd, &h->ctx, NULL), VBNL_OK);
    assert_int_equal(vbnl_scene_create(h->ctx, &h->c.scene, NULL), VBNL_OK);
    assert_int_equal(vbnl_sdl_parser_create(&h->c.parser, NULL), VBNL_OK);
    assert_int_equal(pov_texture_state_create(&h->c, NULL), VBNL_OK);
    vbnl_sdl_hooks hooks = {h, hook_statement, hook_rvalue, hook_default};
    vbnl_sdl_set_hooks(h->c.parser, &hooks);
    vbnl_error err = {0};
    h->result = vbnl_sdl_parse_text(h->c.parser, "test.pov", text, strlen(text), &err);
    return h;
}

static void done(harness *h)
{
    pov_texture_state_destroy(&h->c);
    vbnl_sdl_parser_destroy(h->c.parser);
    vbnl_scene_destroy(h->c.scene);
    vbnl_context_destroy(h->ctx);
    free(h);
}

static harness *run_ok(const char *text)
{
    harness *h = run(text);
    if (h->result != VBNL_OK) {
        for (size_t i = 0; i < vbnl_sdl_diag_count(h->c.parser); i++)
            fprintf(stderr, "%s", vbnl_sdl_diag_get(h->c.parser, i)->text);
        fail_msg("parse failed");
    }
    return h;
}

static const vbnl_material_desc *mat(harness *h, int i)
{
    assert_true(i < h->nmats);
    const vbnl_material_desc *d = pov_texture_material_desc(&h->c, h->mats[i]);
    assert_non_null(d);
    return d;
}

static void expect3(const float *v, double a, double b, double c, double tol)
{
    if (fabs(v[0] - a) > tol || fabs(v[1] - b) > tol || fabs(v[2] - c) > tol)
        fail_msg("(%g %g %g), expected (%g %g %g)", v[0], v[1], v[2], a, b, c);
}

static const char *warning_text(harness *h, const char *contains)
{
    for (size_t i = 0; i < vbnl_sdl_diag_count(h->c.parser); i++) {
        const vbnl_sdl_diag *d = vbnl_sdl_diag_get(h->c.parser, i);
        if (d->severity == VBNL_SDL_WARNING && strstr(d->text, contains))
            return d->text;
    }
    return NULL;
}

static void expect_error(const char *text, const char *expected)
{
    harness *h = run(text);
    assert_int_equal(h->result, VBNL_ERR_PARSE);
    const char *got = NULL;
    for (size_t i = 0; i < vbnl_sdl_diag_count(h->c.parser); i++)
        if (vbnl_sdl_diag_get(h->c.parser, i)->severity == VBNL_SDL_ERROR)
            got = vbnl_sdl_diag_get(h->c.parser, i)->text;
    assert_non_null(got);
    assert_string_equal(got, expected);
    done(h);
}

/* ---- tests --------------------------------------------------------------------------------- */

static void test_declared_texture(void **state)
{
    (void)state;
    harness *h = run_ok("#declare T = texture { pigment { rgb <1,0,0> } finish { diffuse 0.5 } }\n"
                        "object_test { texture { T } }\n"
                        "object_test { pigment { rgb <0.2, 0.4, 1> } }\n" /* POV-Ray's default diffuse 0.6 */
                        "object_test { texture { T finish { diffuse 1 } } }\n"
                        "object_test { texture { T } }\n");
    assert_int_equal(h->nmats, 4);
    const vbnl_material_desc *d = mat(h, 0);
    assert_int_equal(d->type, VBNL_MATERIAL_LAMBERT);
    expect3(d->base_color, 0.5, 0, 0, 1e-6);
    assert_int_equal(d->base_texture, 0);
    expect3(mat(h, 1)->base_color, 0.12, 0.24, 0.6, 1e-6);
    expect3(mat(h, 2)->base_color, 1, 0, 0, 1e-6);
    /* the same content is one core material */
    assert_int_equal(h->mats[3], h->mats[0]);
    assert_int_equal(pov_texture_material_count(&h->c), 3);
    done(h);
}

static void test_identifiers_and_default(void **state)
{
    (void)state;
    harness *h = run_ok("#declare P = pigment { color rgb <0.5, 0.5, 0.25> }\n"
                        "#declare F = finish { diffuse 0.8 ambient 0.3 }\n"
                        "#declare M = material { texture { pigment { P } finish { F } } interior { ior 1.33 } }\n"
                        "object_test { pigment { P } finish { F } }\n"
                        "object_test { material { M } }\n"
                        "object_test { }\n" /* POV-Ray's default texture: black pigment */
                        "#default { finish { diffuse 0.9 } pigment { rgb 1 } }\n"
                        "object_test { }\n"
                        "object_test { pigment { rgb <1, 0.5, 0> } }\n");
    expect3(mat(h, 0)->base_color, 0.4, 0.4, 0.2, 1e-6);
    assert_int_equal(h->mats[1], h->mats[0]); /* the interior does not change an opaque material */
    expect3(mat(h, 2)->base_color, 0, 0, 0, 0);
    expect3(mat(h, 3)->base_color, 0.9, 0.9, 0.9, 1e-6);
    expect3(mat(h, 4)->base_color, 0.9, 0.45, 0, 1e-6);
    done(h);
}

/* One row of the finish table each. */
static void test_finish_mapping(void **state)
{
    (void)state;
    harness *h = run_ok(
        /* 0 diffuse d x pigment c -> Lambert d c; ambient ignored */
        "object_test { pigment { rgb <1, 0.5, 0.25> } finish { diffuse 0.8 ambient 1 } }\n"
        /* 1 emission e -> radiance e c */
        "object_test { pigment { rgb <1, 0.5, 0> } finish { emission 2 diffuse 0 } }\n"
        /* 2 reflection only -> mirror tinted by the reflection colour */
        "object_test { pigment { rgb 0 } finish { diffuse 0 reflection rgb <0.9, 0.8, 0.7> } }\n"
        /* 3 reflection + diffuse -> smooth plastic */
        "object_test { pigment { rgb <0, 0, 1> } finish { reflection 0.2 } }\n"
        /* 4 specular / roughness -> GGX plastic, alpha = sqrt(2 / (1/roughness + 2)) */
        "object_test { pigment { rgb 1 } finish { specular 0.5 roughness 0.01 diffuse 0.7 } }\n"
        /* 5 phong / phong_size -> GGX plastic, alpha = sqrt(2 / (4 phong_size + 2)) */
        "object_test { pigment { rgb 1 } finish { phong 1 phong_size 40 } }\n"
        /* 6 metallic -> conductor, F0 = pigment */
        "object_test { pigment { rgb <0.9, 0.6, 0.2> } finish { reflection { 0.8 metallic } } }\n"
        /* 7 filter + ior -> dielectric tinted by the filtered colour */
        "object_test { pigment { rgbf <0.5, 1, 1, 1> } interior { ior 1.33 } }\n"
        /* 8 transmit -> untinted glass */
        "object_test { pigment { rgbt <0.5, 0.2, 0.2, 1> } interior { ior 1.5 } }\n"
        /* 9 metallic with specular highlights -> rough conductor */
        "object_test { pigment { rgb <0.9, 0.6, 0.2> } finish { specular 0.8 roughness 0.02 metallic } }\n");
    const vbnl_material_desc *d = mat(h, 0);
    assert_int_equal(d->type, VBNL_MATERIAL_LAMBERT);
    expect3(d->base_color, 0.8, 0.4, 0.2, 1e-6);
    expect3(d->emission, 0, 0, 0, 0);
    d = mat(h, 1);
    expect3(d->emission, 2, 1, 0, 1e-6);
    expect3(d->base_color, 0, 0, 0, 0);
    assert_true(h->emissive[1] && !h->emissive[0]);
    d = mat(h, 2);
    assert_int_equal(d->type, VBNL_MATERIAL_MIRROR);
    expect3(d->base_color, 0.9, 0.8, 0.7, 1e-6);
    d = mat(h, 3);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    expect3(d->base_color, 0, 0, 0.6, 1e-6);
    assert_true(d->alpha == 0.001f);
    d = mat(h, 4);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    expect3(d->base_color, 0.7, 0.7, 0.7, 1e-6);
    assert_float_equal(d->alpha, sqrt(2.0 / 102.0), 1e-6);
    d = mat(h, 5);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    assert_float_equal(d->alpha, sqrt(2.0 / 162.0), 1e-6);
    d = mat(h, 6);
    assert_int_equal(d->type, VBNL_MATERIAL_CONDUCTOR);
    expect3(d->base_color, 0.9, 0.6, 0.2, 1e-6);
    assert_int_equal(d->conductor_use_ior, 0);
    assert_true(d->alpha == 0.001f);
    d = mat(h, 7);
    assert_int_equal(d->type, VBNL_MATERIAL_DIELECTRIC);
    assert_float_equal(d->ior, 1.33, 1e-6);
    expect3(d->base_color, 0.5, 1, 1, 1e-6);
    d = mat(h, 8);
    assert_int_equal(d->type, VBNL_MATERIAL_DIELECTRIC);
    expect3(d->base_color, 1, 1, 1, 1e-6);
    d = mat(h, 9);
    assert_int_equal(d->type, VBNL_MATERIAL_CONDUCTOR);
    assert_float_equal(d->alpha, sqrt(2.0 / 52.0), 1e-6);
    done(h);
}

static void test_energy_clamp(void **state)
{
    (void)state;
    harness *h = run_ok("object_test { pigment { rgb <2, 0.5, 1> } finish { diffuse 0.8 } }\n"
                        "object_test { pigment { rgb <2, 0.5, 1> } finish { diffuse 0.8 } }\n");
    expect3(mat(h, 0)->base_color, 1, 0.4, 0.8, 1e-6);
    const char *w = warning_text(h, "clamped");
    assert_non_null(w);
    assert_non_null(strstr(w, "test.pov:1:15: warning: albedo 1.6 exceeds"));
    /* the second object shares the material and does not warn again */
    assert_int_equal(h->mats[1], h->mats[0]);
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 1);
    done(h);
}

static void test_patterns(void **state)
{
    (void)state;
    harness *h = run_ok(
        "#declare P_Blue = pigment { rgb <0, 0, 1> }\n"
        "object_test { pigment { checker color rgb <1, 0, 0> color rgb <0, 0, 1> scale 0.5 } finish { diffuse 1 } }\n"
        "object_test { pigment { gradient y color_map { [0 rgb 0] [0.5 rgb <1, 0, 0>] [1 rgb 1] } frequency 2 } }\n"
        "object_test { pigment { brick color rgb 0.5, color rgb <0.6, 0.1, 0.1> brick_size <4, 1, 2> mortar 0.2 } }\n"
        "#declare CM = color_map { [0 rgb <1, 0, 0>] [1 rgb <0, 0, 1>] }\n"
        "object_test { pigment { bozo color_map { CM } } }\n"
        "object_test { pigment { checker srgb 1, srgb <0, 0, 0> } }\n"
        /* POV-Ray's default map of bozo, averaged over [0, 1]: 0.4 white + 0.2 each of green, blue, red */
        "object_test { pigment { bozo } finish { diffuse 1 } }\n"
        /* block patterns: the mean of their colours */
        "object_test { pigment { hexagon rgb <1, 0, 0>, rgb <0, 1, 0>, rgb <0, 0, 1> } finish { diffuse 1 } }\n"
        /* [v, colour] with a comma, as biscuit.pov writes it */
        "object_test { pigment { gradient z color_map { [0.00, rgb <1, 0, 0>] [1.0, rgb <0, 0, 1>] } } }\n"
        /* texture patterns: the first texture of the list / map, with a warning */
        "#declare TA = texture { pigment { rgb <0.5, 0.25, 0> } finish { diffuse 1 } }\n"
        "object_test { texture { checker texture { TA }, texture { pigment { rgb 1 } } scale 0.4 } }\n"
        "object_test { texture { gradient y texture_map { [0 pigment { rgb <0, 0.5, 0> } finish { diffuse 1 }] [1 TA] } } }\n"
        /* pigment lists */
        "object_test { pigment { checker pigment { rgb <1, 0, 0> } pigment { P_Blue } } }\n"
        /* checker without colours: POV-Ray's blue and green */
        "object_test { pigment { checker } }\n");
    const vbnl_texture_desc *t = pov_texture_texture_desc(&h->c, h->mats[0]);
    assert_non_null(t);
    assert_int_equal(t->kind, VBNL_TEXTURE_CHECKER);
    assert_int_equal(t->color_map_count, 2);
    expect3(t->color_map[0].color, 1, 0, 0, 0);
    expect3(t->color_map[1].color, 0, 0, 1, 0);
    assert_float_equal(t->pattern_from_world[0], 2.0, 1e-6); /* scale 0.5: pattern = 2 x world */
    assert_int_equal(mat(h, 0)->base_texture, 1);
    expect3(mat(h, 0)->base_color, 1, 1, 1, 0);
    /* the core texture gives the colours at points of each cell */
    const vbnl_texture *ct = &h->c.scene->textures[0];
    vec3 a = vbnl_texture_eval(ct, v3(0.25f, 0.25f, 0.25f), (vec2){0, 0});
    vec3 b = vbnl_texture_eval(ct, v3(0.75f, 0.25f, 0.25f), (vec2){0, 0});
    assert_true(a.x == 1.0f && a.z == 0.0f && b.x == 0.0f && b.z == 1.0f);

    t = pov_texture_texture_desc(&h->c, h->mats[1]);
    assert_int_equal(t->kind, VBNL_TEXTURE_GRADIENT);
    expect3(t->gradient, 0, 1, 0, 0);
    assert_int_equal(t->color_map_count, 3);
    assert_float_equal(t->frequency, 2.0, 0);
    expect3(mat(h, 1)->base_color, 0.6, 0.6, 0.6, 1e-6); /* diffuse scales the texture */
    vec3 g = vbnl_texture_eval(&h->c.scene->textures[1], v3(0, 0.25f, 0), (vec2){0, 0});
    assert_float_equal(g.x, 1.0, 1e-5); /* value 0.25 * 2 = 0.5: the red entry */
    assert_float_equal(g.y, 0.0, 1e-5);

    t = pov_texture_texture_desc(&h->c, h->mats[2]);
    assert_int_equal(t->kind, VBNL_TEXTURE_BRICK);
    expect3(t->brick_size, 4, 1, 2, 0);
    assert_float_equal(t->mortar, 0.2, 1e-6);
    expect3(t->color_map[0].color, 0.5, 0.5, 0.5, 1e-6);
    expect3(t->color_map[1].color, 0.6, 0.1, 0.1, 1e-6);

    /* unsupported pattern: the colour map's average, with a warning naming file:line */
    assert_null(pov_texture_texture_desc(&h->c, h->mats[3]));
    expect3(mat(h, 3)->base_color, 0.3, 0, 0.3, 1e-6);
    const char *w = warning_text(h, "pattern 'bozo' is not supported");
    assert_non_null(w);
    assert_non_null(strstr(w, "test.pov:6:25: warning:"));
    /* checker with srgb colours */
    t = pov_texture_texture_desc(&h->c, h->mats[4]);
    expect3(t->color_map[0].color, 1, 1, 1, 1e-6);
    expect3(t->color_map[1].color, 0, 0, 0, 0);
    expect3(mat(h, 5)->base_color, 0.6, 0.6, 0.6, 1e-6);
    expect3(mat(h, 6)->base_color, 1.0 / 3, 1.0 / 3, 1.0 / 3, 1e-6);
    t = pov_texture_texture_desc(&h->c, h->mats[7]);
    expect3(t->color_map[0].color, 1, 0, 0, 0);
    expect3(t->color_map[1].color, 0, 0, 1, 0);
    expect3(mat(h, 8)->base_color, 0.5, 0.25, 0, 1e-6);
    expect3(mat(h, 9)->base_color, 0, 0.5, 0, 1e-6);
    assert_non_null(warning_text(h, "texture pattern 'checker' is not supported: its first texture is used"));
    t = pov_texture_texture_desc(&h->c, h->mats[10]);
    expect3(t->color_map[0].color, 1, 0, 0, 0);
    expect3(t->color_map[1].color, 0, 0, 1, 0);
    t = pov_texture_texture_desc(&h->c, h->mats[11]);
    expect3(t->color_map[0].color, 0, 0, 1, 0);
    expect3(t->color_map[1].color, 0, 1, 0, 0);
    done(h);
}

/* Pattern transforms compose with the object's later transforms. */
static void test_transforms(void **state)
{
    (void)state;
    harness *h = run_ok("#declare P = pigment { checker rgb 1, rgb 0 translate <1, 0, 0> }\n");
    const vbnl_sdl_value *v = vbnl_sdl_lookup(h->c.parser, "P");
    assert_non_null(v);
    assert_int_equal(v->kind, VBNL_SDL_OBJECT);
    assert_string_equal(v->u.obj.type->name, "pigment");
    done(h);
    h = run_ok("object_test { pigment { checker rgb 1, rgb 0 rotate <0, 0, 90> translate <1, 0, 0> } }\n");
    const vbnl_texture_desc *t = pov_texture_texture_desc(&h->c, h->mats[0]);
    /* pattern_from_world = inverse(translate * rotate_z(90)): world (1, 2, 0) -> pattern (2, 0, 0) */
    const float *m = t->pattern_from_world;
    float px = m[0] * 1 + m[1] * 2 + m[2] * 0 + m[3], py = m[4] * 1 + m[5] * 2 + m[6] * 0 + m[7];
    assert_float_equal(px, 2.0, 1e-5);
    assert_float_equal(py, 0.0, 1e-5);
    done(h);
    /* pov_appearance_transform: an object transform after the texture scales the pattern too */
    h = run_ok("object_test { pigment { checker rgb 1, rgb 0 scale 0.5 } obj_scale 4 }\n");
    t = pov_texture_texture_desc(&h->c, h->mats[0]);
    assert_float_equal(t->pattern_from_world[0], 0.5, 1e-6);
    assert_float_equal(t->pattern_from_world[5], 0.5, 1e-6);
    done(h);
}

static void write_png(const char *path)
{
    /* 2 x 1 sRGB image: red, then mid grey (128) */
    const unsigned char px[6] = {255, 0, 0, 128, 128, 128};
    png_image img;
    memset(&img, 0, sizeof(img));
    img.version = PNG_IMAGE_VERSION;
    img.width = 2;
    img.height = 1;
    img.format = PNG_FORMAT_RGB;
    assert_true(png_image_write_to_file(&img, path, 0, px, 0, NULL));
}

static void test_image_map(void **state)
{
    (void)state;
    char dir[] = "/tmp/vbnl_pov_texture_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char png[256], text[1024];
    snprintf(png, sizeof(png), "%s/tex.png", dir);
    write_png(png);
    /* the scene ("test.pov", in the working folder) names the image beside it */
    char cwd[4096];
    assert_non_null(getcwd(cwd, sizeof(cwd)));
    assert_int_equal(chdir(dir), 0);
    snprintf(text, sizeof(text),
             "object_test { pigment { image_map { png \"tex.png\" map_type 1 interpolate 2 once } } finish { diffuse 1 } }\n"
             "object_test { pigment { image_map { \"tex.png\" } scale 2 } }\n"
             "object_test { texture { uv_mapping pigment { image_map { png \"tex.png\" } } } }\n");
    harness *h = run_ok(text);
    const vbnl_texture_desc *t = pov_texture_texture_desc(&h->c, h->mats[0]);
    assert_int_equal(t->kind, VBNL_TEXTURE_IMAGE);
    assert_int_equal(t->width, 2);
    assert_int_equal(t->height, 1);
    assert_int_equal(t->projection, VBNL_PROJECTION_SPHERICAL);
    assert_int_equal(t->wrap, VBNL_WRAP_CLAMP);
    assert_int_equal(t->interpolate, 1);
    const vbnl_texture *ct = &h->c.scene->textures[0];
    assert_float_equal(ct->texels[0], 1.0, 1e-6);
    assert_float_equal(ct->texels[1], 0.0, 1e-6);
    assert_float_equal(ct->texels[3], 0.2158605, 1e-5); /* sRGB 128 linearised */
    t = pov_texture_texture_desc(&h->c, h->mats[1]);
    assert_int_equal(t->projection, VBNL_PROJECTION_PLANAR);
    assert_int_equal(t->wrap, VBNL_WRAP_REPEAT);
    assert_int_equal(t->interpolate, 0);
    assert_float_equal(t->pattern_from_world[0], 0.5, 1e-6);
    /* planar, scale 2: world x in [0, 1) is the red texel, [1, 2) the grey one */
    vec3 c0 = vbnl_texture_eval(&h->c.scene->textures[1], v3(0.5f, 0.5f, 0), (vec2){0, 0});
    vec3 c1 = vbnl_texture_eval(&h->c.scene->textures[1], v3(1.5f, 0.5f, 0), (vec2){0, 0});
    assert_true(c0.x == 1.0f && c0.y == 0.0f && fabsf(c1.y - 0.2158605f) < 1e-5f);
    assert_int_equal(pov_texture_texture_desc(&h->c, h->mats[2])->projection, VBNL_PROJECTION_UV);
    assert_int_equal(h->c.tex ? 1 : 0, 1);
    done(h);
    /* a missing file */
    snprintf(text, sizeof(text), "object_test { pigment { image_map { png \"none.png\" } } }\n");
    h = run(text);
    assert_int_equal(h->result, VBNL_ERR_PARSE);
    done(h);
    assert_int_equal(chdir(cwd), 0);
    unlink(png);
    rmdir(dir);
}

static void test_layers_and_ext(void **state)
{
    (void)state;
    harness *h = run_ok("object_test { texture { pigment { rgb 1 } } texture { pigment { rgb <0, 1, 0> } finish { diffuse 1 } } }\n"
                        "#ifdef (vbnl_version) #end\n"
                        "object_test { texture { vbnl_bsdf { conductor eta <0.2, 0.9, 1.1> k <3.9, 2.4, 2.2> alpha 0.1 } } }\n"
                        "object_test { pigment { rgb <0.3, 0.2, 0.1> } vbnl_bsdf { plastic alpha 0.25 ior 1.4 } }\n"
                        "object_test { material { texture { vbnl_bsdf { lambert color rgb <0.1, 0.2, 0.3> emission <1, 2, 3> two_sided } } } }\n"
                        "object_test { pigment { rgb 1 } normal { bumps 0.5 scale 0.1 } }\n");
    expect3(mat(h, 0)->base_color, 0, 1, 0, 0);
    const char *w = warning_text(h, "layered textures");
    assert_non_null(w);
    assert_non_null(strstr(w, "test.pov:1:45: warning:"));
    const vbnl_material_desc *d = mat(h, 1);
    assert_int_equal(d->type, VBNL_MATERIAL_CONDUCTOR);
    assert_int_equal(d->conductor_use_ior, 1);
    expect3(d->eta, 0.2, 0.9, 1.1, 1e-6);
    expect3(d->k, 3.9, 2.4, 2.2, 1e-6);
    assert_float_equal(d->alpha, 0.1, 1e-7);
    d = mat(h, 2);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    expect3(d->base_color, 0.3, 0.2, 0.1, 1e-6); /* the pigment, exactly */
    assert_float_equal(d->ior, 1.4, 1e-6);
    d = mat(h, 3);
    expect3(d->base_color, 0.1, 0.2, 0.3, 1e-6);
    expect3(d->emission, 1, 2, 3, 0);
    assert_int_equal(d->two_sided, 1);
    assert_non_null(warning_text(h, "'normal' (bump perturbation) is not rendered"));
    done(h);
}

/* Declarations warn where they are used: an unused declared texture is silent, a used one warns
 * once with the place of use; layered declared textures keep the top opaque layer. */
static void test_deferred_warnings(void **state)
{
    (void)state;
    harness *h = run_ok("#declare Unused = texture { pigment { marble color_map { [0 rgb 0] [1 rgb 1] } turbulence 1 } }\n"
                        "#declare Layered = texture { pigment { rgb <1, 0, 0> } }\n"
                        "  texture { pigment { bozo color_map { [0 rgbt <0, 0, 1, 0.8>] [1 rgbt <0, 0, 1, 1>] } } }\n");
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 0);
    done(h);

    h = run_ok("#declare Layered = texture { pigment { rgb <1, 0, 0> } }\n"
               "  texture { pigment { bozo color_map { [0 rgbt <0, 0, 1, 0.8>] [1 rgbt <0, 0, 1, 1>] } } }\n"
               "#declare Over = texture { pigment { rgb <1, 0, 0> } } texture { pigment { rgb <0, 1, 0> } }\n"
               "object_test { texture { Layered } }\n"
               "object_test { texture { Layered } }\n"
               "object_test { texture { Over } }\n");
    assert_int_equal(h->nmats, 3);
    expect3(mat(h, 0)->base_color, 0.6, 0, 0, 1e-6); /* diffuse 0.6 x red: the transparent top layer is not rendered */
    expect3(mat(h, 2)->base_color, 0, 0.6, 0, 1e-6); /* an opaque top layer is */
    const char *w = warning_text(h, "layered textures are rendered as one layer");
    assert_non_null(w);
    assert_non_null(strstr(w, "test.pov:2:3: warning:"));
    assert_non_null(strstr(w, "reported where it is used: test.pov:4:25"));
    w = warning_text(h, "pattern 'bozo' is not supported");
    assert_non_null(w);
    assert_non_null(strstr(w, "reported where it is used: test.pov:4:25"));
    /* once per declaration, not per use: bozo and the layering note for Layered, the note for Over */
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 3);
    done(h);

    /* a declaration built from another one carries its warnings to where it is used */
    h = run_ok("#declare P = pigment { wood color_map { [0 rgb 0.2] [1 rgb 0.8] } }\n"
               "#declare T = texture { pigment { P } }\n"
               "#declare U = T\n"
               "object_test { texture { U } }\n");
    w = warning_text(h, "pattern 'wood' is not supported");
    assert_non_null(w);
    assert_non_null(strstr(w, "test.pov:1:24: warning:"));
    assert_non_null(strstr(w, "reported where it is used: test.pov:4:25"));
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 1);
    done(h);

    FILE *probe = fopen("/usr/share/povray-3.7/include/textures.inc", "r");
    if (probe) {
        fclose(probe);
        h = run_ok("#include \"colors.inc\"\n#include \"textures.inc\"\n#include \"stones.inc\"\n"
                   "#include \"woods.inc\"\n#include \"metals.inc\"\n");
        print_message("# textures, stones, woods, metals.inc included, nothing used: %zu warnings\n",
                      vbnl_sdl_warning_count(h->c.parser));
        assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 0);
        done(h);
    }
}

static void test_errors(void **state)
{
    (void)state;
    expect_error("object_test { finish { diffuse 0.5 bogus 1 } }\n",
                 "test.pov:1:36: error: unexpected 'bogus' in finish\n"
                 "object_test { finish { diffuse 0.5 bogus 1 } }\n"
                 "                                   ^\n");
    expect_error("#declare P = pigment { image_map { jpeg \"a.jpg\" } }\n",
                 "test.pov:1:36: error: image_map: only png images are supported (found 'jpeg')\n"
                 "#declare P = pigment { image_map { jpeg \"a.jpg\" } }\n"
                 "                                   ^\n");
    expect_error("object_test { pigment { gradient x color_map { [0.5 rgb 1] [0.2 rgb 0 } } }\n",
                 "test.pov:1:71: error: expected ']' to end a color_map entry, found '}'\n"
                 "object_test { pigment { gradient x color_map { [0.5 rgb 1] [0.2 rgb 0 } } }\n"
                 "                                                                      ^\n");
    expect_error("object_test { texture { vbnl_bsdf { velvet } } }\n",
                 "test.pov:1:37: error: vbnl_bsdf must start with lambert, conductor, plastic, mirror or dielectric (found 'velvet')\n"
                 "object_test { texture { vbnl_bsdf { velvet } } }\n"
                 "                                    ^\n");
    expect_error("object_test { interior { ior 0.5 } }\n",
                 "test.pov:1:26: error: ior must lie in [1, 10) (got 0.5)\n"
                 "object_test { interior { ior 0.5 } }\n"
                 "                         ^\n");
    expect_error("object_test { pigment { gradient <0, 0, 0> } }\n",
                 "test.pov:1:25: error: gradient needs a non-zero vector\n"
                 "object_test { pigment { gradient <0, 0, 0> } }\n"
                 "                        ^\n");
    expect_error("#declare T = texture { pigment { rgb 1 } wobble }\n",
                 "test.pov:1:42: error: unexpected 'wobble' in texture\n"
                 "#declare T = texture { pigment { rgb 1 } wobble }\n"
                 "                                         ^\n");
    expect_error("object_test { finish { roughness 0 } }\n",
                 "test.pov:1:24: error: roughness must be > 0\n"
                 "object_test { finish { roughness 0 } }\n"
                 "                       ^\n");
}

/* POV-Ray's standard texture includes parse with the texture part, and a few of their textures
 * map onto the expected core materials. Skipped when the includes are not installed (Debian's
 * povray-includes; CI installs it), as the corpus test is. */
static void test_standard_includes(void **state)
{
    (void)state;
    FILE *probe = fopen("/usr/share/povray-3.7/include/textures.inc", "r");
    if (!probe) {
        print_message("# POV-Ray includes not installed (apt-get install povray-includes)\n");
        skip();
    }
    fclose(probe);
    harness *h = run_ok("#include \"colors.inc\"\n#include \"textures.inc\"\n#include \"finish.inc\"\n"
                        "#include \"metals.inc\"\n#include \"golds.inc\"\n#include \"glass.inc\"\n"
                        "#include \"woods.inc\"\n#include \"stones.inc\"\n"
                        "object_test { texture { T_Gold_1A } }\n"
                        "object_test { texture { pigment { Red } finish { Shiny } } }\n"
                        "object_test { texture { T_Glass1 } interior { ior 1.5 } }\n"
                        "object_test { texture { T_Wood1 } }\n"
                        "object_test { texture { T_Stone1 } }\n"
                        "object_test { material { M_Glass } }\n");
    size_t warnings = vbnl_sdl_warning_count(h->c.parser);
    print_message("# standard includes: %d objects, %zu warnings, %u core materials\n", h->nmats, warnings,
                  pov_texture_material_count(&h->c));
    if (getenv("VBNL_TEST_VERBOSE"))
        for (size_t i = 0; i < vbnl_sdl_diag_count(h->c.parser); i++)
            print_message("# %s\n", vbnl_sdl_diag_get(h->c.parser, i)->message);
    assert_int_equal(h->nmats, 6);
    assert_int_equal(mat(h, 0)->type, VBNL_MATERIAL_CONDUCTOR); /* metallic gold */
    assert_int_equal(mat(h, 1)->type, VBNL_MATERIAL_PLASTIC);   /* Shiny: specular + roughness */
    expect3(mat(h, 1)->base_color, 0.6, 0, 0, 1e-6);
    assert_int_equal(mat(h, 2)->type, VBNL_MATERIAL_DIELECTRIC);
    assert_int_equal(mat(h, 5)->type, VBNL_MATERIAL_DIELECTRIC);
    done(h);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_declared_texture),
        cmocka_unit_test(test_identifiers_and_default),
        cmocka_unit_test(test_finish_mapping),
        cmocka_unit_test(test_energy_clamp),
        cmocka_unit_test(test_patterns),
        cmocka_unit_test(test_transforms),
        cmocka_unit_test(test_image_map),
        cmocka_unit_test(test_layers_and_ext),
        cmocka_unit_test(test_deferred_warnings),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_standard_includes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
