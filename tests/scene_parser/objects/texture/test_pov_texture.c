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
    int committed;
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

static int hook_function_block(vbnl_sdl_parser *p, const vbnl_sdl_token *tok, vbnl_sdl_fn_block *out, void *user)
{
    (void)p;
    return pov_function_block(&((harness *)user)->c, tok, out);
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
    vbnl_sdl_set_function_block_hook(h->c.parser, hook_function_block, h);
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

/* ---- the core's resolution at synthetic hits ------------------------------------------------- */

/* Commits the scene's texture nodes once (the hidden leaf copies the resolution uses). */
static void commit_textures(harness *h)
{
    if (h->committed)
        return;
    vbnl_error err = {0};
    assert_int_equal(vbi_texture_commit(h->c.scene, &err), VBNL_OK);
    h->committed = 1;
}

/* The BSDF object i has at p with normal n, for the hit seed `seed`. */
static vbi_bsdf bsdf_at_n(harness *h, int i, double x, double y, double z, vec3 n, uint32_t seed)
{
    commit_textures(h);
    assert_true(i < h->nmats);
    vbi_hit hit;
    memset(&hit, 0, sizeof(hit));
    hit.p = v3((float)x, (float)y, (float)z);
    hit.ng = hit.ns = n;
    hit.uv = (vec2){(float)x, (float)y};
    hit.material = h->mats[i];
    hit.prim = seed;
    vbi_bsdf storage;
    return *vbi_surface_bsdf(h->c.scene, &hit, &storage);
}

/* The BSDF object i has at p (normal +z, uv (x, y)), for the hit seed `seed`. */
static vbi_bsdf bsdf_at(harness *h, int i, double x, double y, double z, uint32_t seed)
{
    return bsdf_at_n(h, i, x, y, z, v3(0, 0, 1), seed);
}

/* Its colour; the mean over n hit seeds where the material is chosen per hit. */
static vec3 color_at(harness *h, int i, double x, double y, double z, int n)
{
    vec3 sum = v3s(0);
    for (int k = 0; k < n; ++k)
        sum = v3_add(sum, bsdf_at(h, i, x, y, z, (uint32_t)k).color);
    return v3_scale(sum, 1.0f / (float)n);
}

static void expect_color(vec3 c, double a, double b, double d, double tol)
{
    const float v[3] = {c.x, c.y, c.z};
    expect3(v, a, b, d, tol);
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
    /* a texture declared after #default starts from the #default's finish (POV-Ray 3.7: the
     * declared texture renders with diffuse 1, not its built-in 0.6) */
    h = run_ok("#default { finish { diffuse 1 } }\n"
               "#declare T = texture { pigment { rgb 0.7 } }\n"
               "#declare P = pigment { rgb 0.5 }\n"
               "object_test { texture { T } }\n"
               "object_test { pigment { P } }\n"
               "object_test { texture { T finish { diffuse 0.3 } } }\n");
    expect3(mat(h, 0)->base_color, 0.7, 0.7, 0.7, 1e-6);
    expect3(mat(h, 1)->base_color, 0.5, 0.5, 0.5, 1e-6);
    expect3(mat(h, 2)->base_color, 0.21, 0.21, 0.21, 1e-6);
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
    assert_int_equal(mat(h, 1)->type, VBNL_MATERIAL_LAMBERT); /* the interior does not change an opaque material */
    expect3(mat(h, 1)->base_color, 0.4, 0.4, 0.2, 1e-6);
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
        /* 3 reflection + diffuse -> a smooth coat reflecting 0.2 at every angle over the diffuse base */
        "object_test { pigment { rgb <0, 0, 1> } finish { reflection 0.2 } }\n"
        /* 4 specular / roughness -> GGX plastic, alpha = sqrt(2 / (1/roughness + 2)) */
        "object_test { pigment { rgb 1 } finish { specular 0.5 roughness 0.01 diffuse 0.7 } }\n"
        /* 5 phong / phong_size -> GGX plastic, alpha = sqrt(2 / (4 phong_size + 2)) */
        "object_test { pigment { rgb 1 } finish { phong 1 phong_size 40 } }\n"
        /* 6 reflection { metallic } -> the coat tinted by the pigment, over the (default) diffuse */
        "object_test { pigment { rgb <0.9, 0.6, 0.2> } finish { reflection { 0.8 metallic } } }\n"
        /* 7 filter + ior -> dielectric tinted by the filtered colour */
        "object_test { pigment { rgbf <0.5, 1, 1, 1> } interior { ior 1.33 } }\n"
        /* 8 transmit -> untinted glass */
        "object_test { pigment { rgbt <0.5, 0.2, 0.2, 1> } interior { ior 1.5 } }\n"
        /* 9 metallic with specular highlights -> rough conductor */
        "object_test { pigment { rgb <0.9, 0.6, 0.2> } finish { specular 0.8 roughness 0.02 metallic } }\n"
        /* 10 reflection { fresnel } alone -> the coat's Fresnel reflection of the interior's ior over black */
        "object_test { pigment { rgb 1 } finish { diffuse 0 reflection { 0, 1 fresnel } } interior { ior 1.33 } }\n");
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
    assert_int_equal(d->coat_curve, VBNL_COAT_SCHLICK);
    expect3(d->coat_min, 0.2, 0.2, 0.2, 1e-6);
    expect3(d->coat_max, 0.2, 0.2, 0.2, 1e-6);
    expect3(d->base_color, 0, 0, 1, 1e-6);
    assert_float_equal(d->base_scale, 0.6, 1e-6);
    assert_int_equal(d->coat_conserve, 0);
    assert_true(d->alpha == 0.001f);
    d = mat(h, 4);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    expect3(d->base_color, 0.7, 0.7, 0.7, 1e-6);
    assert_float_equal(d->alpha, sqrt(2.0 / 102.0), 1e-6);
    d = mat(h, 5);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    assert_float_equal(d->alpha, sqrt(2.0 / 162.0), 1e-6);
    d = mat(h, 6);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    assert_int_equal(d->coat_curve, VBNL_COAT_SCHLICK);
    expect3(d->base_color, 0.9, 0.6, 0.2, 1e-6);
    expect3(d->coat_max, 0.8, 0.8, 0.8, 1e-6);
    assert_float_equal(d->coat_metallic, 1.0, 0);
    assert_true(d->alpha == 0.001f);
    /* 0.6 x 0.9 + 0.8 > 1: noted (the core's diffuse gives way where the sum exceeds 1) */
    assert_non_null(warning_text(h, "diffuse plus reflection reflect up to 1.34"));
    /* what the pigment lets through refracts into the interior, tinted by f c + t */
    vbi_bsdf g = bsdf_at(h, 7, 0, 0, 0, 0);
    assert_int_equal(g.type, VBNL_MATERIAL_DIELECTRIC);
    assert_float_equal(g.ior, 1.33, 1e-6);
    expect_color(g.color, 0.5, 1, 1, 1e-6);
    g = bsdf_at(h, 8, 0, 0, 0, 0);
    assert_int_equal(g.type, VBNL_MATERIAL_DIELECTRIC);
    expect_color(g.color, 1, 1, 1, 1e-6);
    d = mat(h, 9);
    assert_int_equal(d->type, VBNL_MATERIAL_CONDUCTOR);
    assert_float_equal(d->alpha, sqrt(2.0 / 52.0), 1e-6);
    d = mat(h, 10);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    assert_int_equal(d->coat_curve, VBNL_COAT_FRESNEL);
    expect3(d->coat_min, 0, 0, 0, 0);
    expect3(d->coat_max, 1, 1, 1, 0);
    assert_float_equal(d->base_scale, 0, 0);
    assert_float_equal(d->ior, 1.33, 1e-6);
    assert_null(warning_text(h, "fresnel"));
    done(h);
}

/* POV-Ray's variable reflection (reference "Reflection"): min, max, falloff, fresnel, exponent. */
static void test_variable_reflection(void **state)
{
    (void)state;
    harness *h = run_ok(
        /* 0 min 0, max 1, falloff 2 over a black diffuse */
        "object_test { pigment { rgb 1 } finish { diffuse 0 reflection { 0, 1 falloff 2 } } }\n"
        /* 1 reflection 0.3 keeps its amount beside diffuse 0.6 (sum 0.9: no note) */
        "object_test { pigment { rgb <0.5, 1, 0.25> } finish { diffuse 0.6 reflection 0.3 } }\n"
        /* 2 colours per channel, phong roughness for the coat */
        "object_test { pigment { rgb 0.2 } finish { diffuse 0.5 phong 1 phong_size 40\n"
        "    reflection { rgb <0.01, 0.02, 0.03>, rgb <0.9, 0.8, 0.7> falloff 5 } } }\n"
        /* 3 fresnel with one colour: between 0 and it */
        "object_test { pigment { rgb 0.5 } finish { diffuse 0.4 reflection { 0.8 fresnel on } } interior { ior 1.5 } }\n"
        /* 4 exponent 1 is the identity: no warning; exponent 2 warns */
        "object_test { pigment { rgb 0.5 } finish { reflection { 0.5 exponent 1 } } }\n"
        "object_test { pigment { rgb 0.5 } finish { diffuse 0.1 reflection { 0.5 exponent 2 } } }\n");
    const vbnl_material_desc *d = mat(h, 0);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    assert_int_equal(d->coat_curve, VBNL_COAT_SCHLICK);
    expect3(d->coat_min, 0, 0, 0, 0);
    expect3(d->coat_max, 1, 1, 1, 0);
    assert_float_equal(d->coat_falloff, 2.0, 0);
    assert_float_equal(d->base_scale, 0.0, 0);
    d = mat(h, 1);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    expect3(d->coat_min, 0.3, 0.3, 0.3, 1e-6);
    expect3(d->coat_max, 0.3, 0.3, 0.3, 1e-6);
    assert_float_equal(d->base_scale, 0.6, 1e-6);
    expect3(d->base_color, 0.5, 1, 0.25, 1e-6);
    /* the core's BSDF reflects 30% head-on (POV-Ray's reflection 0.3), not a dielectric's 4% */
    vbi_bsdf g;
    vbi_bsdf_from_material(&g, d);
    vbi_bsdf_sample_rec rec;
    double spec = 0.0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
        vec2 u = {((float)i + 0.5f) / (float)n, 0.37f};
        if (vbi_bsdf_sample(&g, v3(0, 0, 1), u, &rec) && (rec.lobe & VBI_LOBE_GLOSSY))
            spec += rec.weight.x / n;
    }
    assert_float_equal(spec, 0.3, 0.01);
    d = mat(h, 2);
    expect3(d->coat_min, 0.01, 0.02, 0.03, 1e-6);
    expect3(d->coat_max, 0.9, 0.8, 0.7, 1e-6);
    assert_float_equal(d->coat_falloff, 5.0, 0);
    assert_float_equal(d->alpha, sqrt(2.0 / 162.0), 1e-6);
    d = mat(h, 3);
    assert_int_equal(d->coat_curve, VBNL_COAT_FRESNEL);
    expect3(d->coat_min, 0, 0, 0, 0);
    expect3(d->coat_max, 0.8, 0.8, 0.8, 1e-6);
    assert_float_equal(d->ior, 1.5, 1e-6);
    d = mat(h, 4);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC); /* diffuse 0.6 by default */
    assert_null(warning_text(h, "falloff"));
    const char *w = warning_text(h, "exponent");
    assert_non_null(w);
    assert_non_null(strstr(w, "test.pov:7:"));
    assert_non_null(strstr(w, "'exponent' 2 is ignored"));
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 1);
    done(h);
    /* a transparent pigment: what it lets through meets a dielectric reflecting the same curve
     * (POV-Ray's reflection with conserve_energy), with or without an interior ior */
    h = run_ok("object_test { pigment { rgbt <0, 1, 0, 1> } finish { diffuse 0 reflection { 0, 1 falloff 2 } "
               "conserve_energy } interior { ior 1.3 } }\n"
               "object_test { pigment { rgbt <0, 1, 0, 1> } finish { diffuse 0 reflection { 0.2, 0.6 fresnel } } }\n");
    vbi_bsdf gl = bsdf_at(h, 0, 0, 0, 0, 0);
    assert_int_equal(gl.type, VBNL_MATERIAL_DIELECTRIC);
    assert_int_equal(gl.coat_curve, VBNL_COAT_SCHLICK);
    assert_float_equal(gl.coat_max.x, 1.0, 0);
    assert_float_equal(gl.coat_falloff, 2.0, 0);
    assert_float_equal(gl.ior, 1.3, 1e-6);
    gl = bsdf_at(h, 1, 0, 0, 0, 0);
    assert_int_equal(gl.type, VBNL_MATERIAL_DIELECTRIC);
    assert_int_equal(gl.coat_curve, VBNL_COAT_FRESNEL);
    assert_float_equal(gl.coat_min.x, 0.2, 1e-6);
    assert_float_equal(gl.ior, 1.0, 0);
    done(h);
    /* errors name the offending value */
    h = run("object_test { pigment { rgb 1 } finish { reflection { 0.5 falloff -1 } } }\n");
    assert_int_not_equal(h->result, VBNL_OK);
    done(h);
    h = run("object_test { pigment { rgb 1 } finish { reflection { 0.1, 0.5, 0.7 } } }\n");
    assert_int_not_equal(h->result, VBNL_OK);
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
        /* 0 */ "object_test { pigment { checker color rgb <1, 0, 0> color rgb <0, 0, 1> scale 0.5 } finish { diffuse 1 } }\n"
        /* 1 */ "object_test { pigment { gradient y color_map { [0 rgb 0] [0.5 rgb <1, 0, 0>] [1 rgb 1] } frequency 2 } }\n"
        /* 2 */ "object_test { pigment { brick color rgb 0.5, color rgb <0.6, 0.1, 0.1> brick_size <4, 1, 2> mortar 0.2 } finish { diffuse 1 } }\n"
        "#declare CM = color_map { [0 rgb <1, 0, 0>] [1 rgb <0, 0, 1>] }\n"
        /* 3 */ "object_test { pigment { bozo color_map { CM } } finish { diffuse 1 } }\n"
        /* 4 */ "object_test { pigment { checker srgb 1, srgb <0, 0, 0> } finish { diffuse 1 } }\n"
        /* 5 block patterns take lists */
        "object_test { pigment { hexagon rgb <1, 0, 0>, rgb <0, 1, 0>, rgb <0, 0, 1> } finish { diffuse 1 } }\n"
        /* 6 [v, colour] with a comma, as biscuit.pov writes it */
        "object_test { pigment { gradient z color_map { [0.00, rgb <1, 0, 0>] [1.0, rgb <0, 0, 1>] } } finish { diffuse 1 } }\n"
        /* 7, 8 texture patterns: a list, a map */
        "#declare TA = texture { pigment { rgb <0.5, 0.25, 0> } finish { diffuse 1 } }\n"
        "object_test { texture { checker texture { TA }, texture { pigment { rgb 1 } } scale 0.4 } }\n"
        "object_test { texture { gradient y texture_map { [0 pigment { rgb <0, 0.5, 0> } finish { diffuse 1 }] [1 TA] } } }\n"
        /* 9 pigment lists */
        "object_test { pigment { checker pigment { rgb <1, 0, 0> } pigment { P_Blue } } finish { diffuse 1 } }\n"
        /* 10 checker without colours: POV-Ray's blue and green */
        "object_test { pigment { checker } finish { diffuse 1 } }\n"
        /* 11 a pigment_map with a sub-pigment that is itself patterned */
        "object_test { pigment { gradient x pigment_map { [0 checker rgb 1, rgb 0 scale 0.1] [1 P_Blue] } } finish { diffuse 1 } }\n"
        /* 12 wave type and turbulence reach the core */
        "object_test { pigment { gradient x triangle_wave color_map { [0 rgb 0] [1 rgb 1] } } finish { diffuse 1 } }\n"
        /* 13 two colours without a comma (POV-Ray ends a colour at the next rgb keyword), srgb decoded */
        "object_test { pigment { checker rgb <1, 0, 0> srgb <0, 0.5, 1> } finish { diffuse 1 } }\n");
    assert_int_equal(h->nmats, 14);
    /* checker scale 0.5: the cell of (0.25, 0.25, 0.25) is the first colour, one step in x the second */
    expect_color(color_at(h, 0, 0.25, 0.25, 0.25, 1), 1, 0, 0, 0);
    expect_color(color_at(h, 0, 0.75, 0.25, 0.25, 1), 0, 0, 1, 0);
    assert_int_equal(mat(h, 0)->type, VBNL_MATERIAL_LAMBERT);
    /* gradient y, frequency 2: y 0.25 is value 0.5, the red entry; POV-Ray's diffuse 0.6 */
    expect_color(color_at(h, 1, 0, 0.25, 0, 1), 0.6, 0, 0, 1e-5);
    expect_color(color_at(h, 1, 0, 0.125, 0, 1), 0.3, 0, 0, 1e-5);
    /* brick (POV-Ray 3.7: mortar at x in [-0.2, 0) for this size) */
    expect_color(color_at(h, 2, -0.1, 0.5, 1, 1), 0.5, 0.5, 0.5, 1e-6);
    expect_color(color_at(h, 2, 2, 0.5, 1, 1), 0.6, 0.1, 0.1, 1e-6);
    /* bozo over CM: a point of the red-blue segment, varying */
    vec3 b0 = color_at(h, 3, 0.3, 0.7, 0.1, 1), b1 = color_at(h, 3, 2.3, -1.7, 0.9, 1);
    assert_float_equal(b0.x + b0.z, 1.0, 1e-5);
    assert_float_equal(b1.x + b1.z, 1.0, 1e-5);
    assert_true(fabsf(b0.x - b1.x) > 1e-3);
    expect_color(color_at(h, 4, 0.5, 0.5, 0.5, 1), 1, 1, 1, 1e-6);
    expect_color(color_at(h, 4, 1.5, 0.5, 0.5, 1), 0, 0, 0, 0);
    /* hexagon (POV-Ray: 0 at the origin, 2 at (1, 0, 0)) */
    expect_color(color_at(h, 5, 0, 0, 0, 1), 1, 0, 0, 0);
    expect_color(color_at(h, 5, 1, 0, 0, 1), 0, 0, 1, 0);
    expect_color(color_at(h, 6, 0, 0, 0.25, 1), 0.75, 0, 0.25, 1e-6);
    /* texture list: TA in the first cell, the default finish's 0.6 white in the next */
    expect_color(color_at(h, 7, 0.2, 0.2, 0.2, 1), 0.5, 0.25, 0, 1e-6);
    expect_color(color_at(h, 7, 0.6, 0.2, 0.2, 1), 0.6, 0.6, 0.6, 1e-6);
    /* texture map: y 0.25 holds 3/4 of the green texture and 1/4 of TA, chosen per hit */
    expect_color(color_at(h, 8, 0, 0.25, 0, 4000), 0.125, 0.4375, 0, 0.02);
    expect_color(color_at(h, 9, 0.5, 0.5, 0.5, 1), 1, 0, 0, 0);
    expect_color(color_at(h, 9, 1.5, 0.5, 0.5, 1), 0, 0, 1, 0);
    expect_color(color_at(h, 10, 0.5, 0.5, 0.5, 1), 0, 0, 1, 0);
    expect_color(color_at(h, 10, 1.5, 0.5, 0.5, 1), 0, 1, 0, 0);
    /* x 0.25: 3/4 of the checker (white at this cell) and 1/4 blue, blended per point */
    expect_color(color_at(h, 11, 0.25, 0.05, 0.05, 1), 0.75, 0.75, 1, 1e-5);
    expect_color(color_at(h, 11, 0.35, 0.05, 0.05, 1), 0, 0, 0.35, 1e-5);
    /* triangle wave: 0.75 -> 0.5 */
    expect_color(color_at(h, 12, 0.75, 0, 0, 1), 0.5, 0.5, 0.5, 1e-5);
    expect_color(color_at(h, 13, 0.5, 0.5, 0.5, 1), 1, 0, 0, 0);
    expect_color(color_at(h, 13, 1.5, 0.5, 0.5, 1), 0, 0.214041, 1, 1e-5);
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 0);
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
    /* pattern point = rotate_z(-90)(p - (1, 0, 0)): (1.5, 0.25) -> (0.25, -0.5), an odd cell
     * (without the rotation or without the translation the cell is even) */
    h = run_ok("object_test { pigment { checker rgb 1, rgb 0 rotate <0, 0, 90> translate <1, 0, 0> } finish { diffuse 1 } }\n");
    expect_color(color_at(h, 0, 1.5, 0.25, 0.5, 1), 0, 0, 0, 0);
    expect_color(color_at(h, 0, 1.5, 0.25, 1.5, 1), 1, 1, 1, 0);
    done(h);
    /* pov_appearance_transform: an object transform after the texture scales the pattern too */
    h = run_ok("object_test { pigment { checker rgb 1, rgb 0 scale 0.5 } finish { diffuse 1 } obj_scale 4 }\n"
               "object_test { pigment { checker rgb 1, rgb 0 scale 0.5 } finish { diffuse 1 } }\n");
    expect_color(color_at(h, 0, 1.5, 0.5, 0.5, 1), 1, 1, 1, 0);
    expect_color(color_at(h, 1, 1.5, 0.5, 0.5, 1), 0, 0, 0, 0);
    done(h);
    /* warps: repeat mirrors the second copy, turbulence moves the pattern */
    h = run_ok("object_test { pigment { gradient x color_map { [0 rgb 0] [1 rgb 1] } warp { repeat x * 1 flip x } } finish { diffuse 1 } }\n"
               "object_test { pigment { gradient x color_map { [0 rgb 0] [1 rgb 1] } warp { turbulence 0.5 } } finish { diffuse 1 } }\n");
    expect_color(color_at(h, 0, 0.25, 0, 0, 1), 0.25, 0.25, 0.25, 1e-5);
    expect_color(color_at(h, 0, 1.25, 0, 0, 1), 0.75, 0.75, 0.75, 1e-5);
    assert_true(fabsf(color_at(h, 1, 0.25, 0.3, 0.7, 1).x - 0.25f) > 1e-3);
    done(h);
    /* planar [VECTOR, FLOAT] with the vector a keyword (advanced/wallstucco.pov writes planar z, 0):
     * z, 0 is the default */
    h = run_ok("object_test { pigment { gradient y color_map { [0 rgb 0] [1 rgb 1] } warp { planar } } finish { diffuse 1 } }\n"
               "object_test { pigment { gradient y color_map { [0 rgb 0] [1 rgb 1] } warp { planar z, 0 } } finish { diffuse 1 } }\n");
    for (int k = 0; k < 3; ++k) {
        double q[3][3] = {{0.3, 0.6, 0.2}, {-1.2, 0.45, 2.5}, {0.7, -0.2, -0.9}};
        vec3 a = color_at(h, 0, q[k][0], q[k][1], q[k][2], 1), b = color_at(h, 1, q[k][0], q[k][1], q[k][2], 1);
        assert_float_equal(a.x, b.x, 1e-6);
    }
    done(h);
    /* an array element in a pigment: a colour (arrays.inc's Rand_Array_Item over colours) or a pigment */
    h = run_ok("#declare Cols = array[2] { rgb <1, 0, 0>, rgb <0, 0, 1> }\n"
               "#declare Pigs = array[2] { pigment { rgb <1, 0, 0> }, pigment { rgb <0, 1, 0> } }\n"
               "object_test { pigment { Cols[1] } finish { diffuse 1 } }\n"
               "object_test { pigment { Pigs[1] } finish { diffuse 1 } }\n");
    expect_color(color_at(h, 0, 0, 0, 0, 1), 0, 0, 1, 0);
    expect_color(color_at(h, 1, 0, 0, 0, 1), 0, 1, 0, 0);
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

/* The same 2 x 1 image as a binary PPM and an uncompressed TGA (written byte by byte). */
static void write_ppm_tga(const char *ppm, const char *tga)
{
    FILE *f = fopen(ppm, "wb");
    assert_non_null(f);
    const unsigned char px[6] = {255, 0, 0, 128, 128, 128};
    fprintf(f, "P6\n2 1\n255\n");
    assert_int_equal(fwrite(px, 1, 6, f), 6);
    fclose(f);
    f = fopen(tga, "wb");
    assert_non_null(f);
    /* type 2 (true colour), 2 x 1, 24 bits, top-left origin; pixels stored B G R */
    const unsigned char hdr[18] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 1, 0, 24, 0x20};
    const unsigned char bgr[6] = {0, 0, 255, 128, 128, 128};
    assert_int_equal(fwrite(hdr, 1, 18, f), 18);
    assert_int_equal(fwrite(bgr, 1, 6, f), 6);
    fclose(f);
}

static void test_image_map(void **state)
{
    (void)state;
    char dir[] = "/tmp/vbnl_pov_texture_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char png[256], ppm[256], tga[256], bad[256], text[2048];
    snprintf(png, sizeof(png), "%s/tex.png", dir);
    snprintf(ppm, sizeof(ppm), "%s/tex.ppm", dir);
    snprintf(tga, sizeof(tga), "%s/tex.tga", dir);
    snprintf(bad, sizeof(bad), "%s/bad.jpg", dir);
    write_png(png);
    write_ppm_tga(ppm, tga);
    FILE *f = fopen(bad, "wb");
    assert_non_null(f);
    fputs("not a jpeg", f);
    fclose(f);
    /* the scene ("test.pov", in the working folder) names the images beside it */
    char cwd[4096];
    assert_non_null(getcwd(cwd, sizeof(cwd)));
    assert_int_equal(chdir(dir), 0);
    snprintf(text, sizeof(text),
             "object_test { pigment { image_map { png \"tex.png\" } scale 2 } finish { diffuse 1 } }\n"
             "object_test { pigment { image_map { ppm \"tex.ppm\" } scale 2 } finish { diffuse 1 } }\n"
             "object_test { pigment { image_map { tga \"tex.tga\" } scale 2 } finish { diffuse 1 } }\n"
             "object_test { pigment { image_map { \"tex.png\" gamma 1 } scale 2 } finish { diffuse 1 } }\n"
             "object_test { texture { uv_mapping pigment { image_map { png \"tex.png\" } } finish { diffuse 1 } } }\n"
             "object_test { pigment { image_map { png \"tex.png\" once } } finish { diffuse 1 } }\n"
             "object_test { pigment { image_pattern { png \"tex.png\" } color_map { [0 rgb 0] [1 rgb 1] } } finish { diffuse 1 } }\n"
             "object_test { pigment { image_map { png \"tex.png\" filter 1, 1 } scale 2 } finish { diffuse 1 } }\n");
    harness *h = run_ok(text);
    const double grey = 0.2158605; /* sRGB 128 linearised */
    /* planar, scale 2: world x in [0, 1) is the red texel, [1, 2) the grey one; every format alike */
    for (int i = 0; i < 3; ++i) {
        expect_color(color_at(h, i, 0.5, 0.5, 0, 1), 1, 0, 0, 1e-6);
        expect_color(color_at(h, i, 1.5, 0.5, 0, 1), grey, grey, grey, 1e-5);
        expect_color(color_at(h, i, 2.5, 0.5, 0, 1), 1, 0, 0, 1e-6); /* repeated */
    }
    expect_color(color_at(h, 3, 1.5, 0.5, 0, 1), 128 / 255.0, 128 / 255.0, 128 / 255.0, 1e-5);
    /* uv_mapping reads (u, v) (here the hit's x, y) */
    expect_color(color_at(h, 4, 0.75, 0.5, 7, 1), grey, grey, grey, 1e-5);
    /* once: clear outside the unit square, the light passes */
    assert_true(bsdf_at(h, 5, 1.5, 0.5, 0, 0).type != VBNL_MATERIAL_LAMBERT);
    /* image_pattern: the texel's grey value (POV-Ray reads it without gamma) through the map */
    expect_color(color_at(h, 6, 0.75, 0.5, 0, 1), 128 / 255.0, 128 / 255.0, 128 / 255.0, 1e-5);
    /* filter 1 on palette entry 1 is ignored for true-colour images (POV-Ray's `filter all`
     * applies to every texel instead) */
    expect_color(color_at(h, 7, 0.5, 0.5, 0, 1), 1, 0, 0, 1e-6);
    done(h);
    /* bump_map from a 4 x 4 grey image, against POV-Ray 3.7.0 (the normals measured as in
     * test_bumps_against_povray, with lights on both sides of the plane's normal) */
    /* the file POV-Ray read: 8-bit grey, no gamma chunk, texel (x, y) = (60 x + 17 y) mod 256 */
    static const unsigned char bump_png[85] = {
        0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00,
        0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x04, 0x08, 0x00, 0x00, 0x00, 0x00, 0x8c, 0x9a, 0xc1, 0xa2, 0x00,
        0x00, 0x00, 0x1c, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0x60, 0xb0, 0xa9, 0xd8, 0xc2, 0x20, 0xe8,
        0xdb, 0x79, 0x94, 0x41, 0x29, 0x6e, 0xd6, 0x35, 0x06, 0xe3, 0xfc, 0xd5, 0xcf, 0x01, 0x3c, 0xf0, 0x07,
        0x39, 0x61, 0x5d, 0x62, 0xca, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
    f = fopen("bump.png", "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bump_png, 1, sizeof(bump_png), f), sizeof(bump_png));
    fclose(f);
    h = run_ok("object_test { pigment { rgb 1 } normal { bump_map { png \"bump.png\" bump_size 2 } rotate x*90 } }\n"
               "object_test { pigment { rgb 1 } normal { bump_map { png \"bump.png\" bump_size 1 interpolate 2 } rotate x*90 } }\n"
               "object_test { pigment { rgb 1 } normal { bump_map { png \"bump.png\" once use_color } rotate x*90 scale 0.5 } }\n");
    static const double bump_ref[3][2][3] = {
        {{-0.425789, 0.897337, 0.116123}, {0.271722, 0.577432, -0.769885}},
        {{-0.111199, 0.976776, 0.183145}, {0.086289, 0.908980, -0.407824}},
        {{-0.115809, 0.992752, 0.032124}, {0.000005, 1.000000, 0.000005}},
    };
    const double bump_pts[2][3] = {{0.31, 0, 0.47}, {0.8, 0, 0.2}};
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 2; ++k) {
            vbi_bsdf b = bsdf_at_n(h, i, bump_pts[k][0], bump_pts[k][1], bump_pts[k][2], v3(0, 1, 0), 0);
            const float got[3] = {b.bumped ? b.ns.x : 0.0f, b.bumped ? b.ns.y : 1.0f, b.bumped ? b.ns.z : 0.0f};
            for (int c = 0; c < 3; ++c)
                if (fabs(got[c] - bump_ref[i][k][c]) > 1e-4)
                    fail_msg("bump_map %d at point %d: (%.6f %.6f %.6f), POV-Ray (%.6f %.6f %.6f)", i, k, got[0], got[1],
                             got[2], bump_ref[i][k][0], bump_ref[i][k][1], bump_ref[i][k][2]);
        }
    done(h);
    unlink("bump.png");
    /* material_map from a palette PNG: the palette index picks the texture (POV-Ray 3.7.0 shows
     * the first texture at x 0.25 and the second at x 0.75 of this 2 x 1 image) */
    static const unsigned char pal_png[86] = {
        0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
        0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x08, 0x03, 0x00, 0x00, 0x00, 0xc3, 0xfc, 0x8f, 0xb8, 0x00, 0x00, 0x00,
        0x06, 0x50, 0x4c, 0x54, 0x45, 0xc8, 0x1e, 0x1e, 0x1e, 0x1e, 0xc8, 0x60, 0x8c, 0xd7, 0x7e, 0x00, 0x00, 0x00,
        0x0b, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0x60, 0x60, 0x04, 0x00, 0x00, 0x04, 0x00, 0x02, 0xbf, 0x7a,
        0x3f, 0x4a, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
    f = fopen("pal.png", "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(pal_png, 1, sizeof(pal_png), f), sizeof(pal_png));
    fclose(f);
    h = run_ok("object_test { texture { material_map { png \"pal.png\" texture { pigment { rgb <1, 0, 0> } finish { diffuse 1 } }\n"
               "                                      texture { pigment { rgb <0, 0, 1> } finish { diffuse 1 } } } } }\n");
    expect_color(color_at(h, 0, 0.25, 0.5, 0, 1), 1, 0, 0, 0);
    expect_color(color_at(h, 0, 0.75, 0.5, 0, 1), 0, 0, 1, 0);
    done(h);
    unlink("pal.png");
    /* a missing file, a file that is no image */
    h = run("object_test { pigment { image_map { png \"none.png\" } } }\n");
    assert_int_equal(h->result, VBNL_ERR_PARSE);
    done(h);
    h = run("object_test { pigment { image_map { jpeg \"bad.jpg\" } } }\n");
    assert_int_equal(h->result, VBNL_ERR_PARSE);
    done(h);
    assert_int_equal(chdir(cwd), 0);
    unlink(png);
    unlink(ppm);
    unlink(tga);
    unlink(bad);
    rmdir(dir);
}

/* Maps of textures, layers, average, tiles, material_map: the colour the core's choice gives
 * on average. */
static void test_texture_blends(void **state)
{
    (void)state;
    harness *h = run_ok(
        /* 0 layered: an opaque bottom, a half-transmitting red top: 0.5 red + 0.5 bottom */
        "object_test { texture { pigment { rgb <0, 1, 0> } finish { diffuse 1 } }\n"
        "              texture { pigment { rgbt <1, 0, 0, 0.5> } finish { diffuse 1 } } }\n"
        /* 1 a filtering top layer: 0.5 of its yellow, and f c + t = (0.5, 0.5, 0) of the white
         * bottom */
        "object_test { texture { pigment { rgb 1 } finish { diffuse 1 } }\n"
        "              texture { pigment { rgbf <1, 1, 0, 0.5> } finish { diffuse 1 } } }\n"
        /* 2 average of two textures, weights 1 and 3 */
        "object_test { texture { average texture_map { [1 pigment { rgb <1, 0, 0> } finish { diffuse 1 }]\n"
        "                                                [3 pigment { rgb <0, 0, 1> } finish { diffuse 1 }] } } }\n"
        /* 3 tiles: a checker whose first texture is on the odd cells (POV-Ray's parstxtr.cpp
         * keeps the order of its older tiles) */
        "object_test { texture { tiles { texture { pigment { rgb <1, 0, 0> } finish { diffuse 1 } }\n"
        "                        tile2 texture { pigment { rgb <0, 1, 0> } finish { diffuse 1 } } } } }\n"
        /* 4 transmit without an interior: what passes goes on unchanged */
        "object_test { pigment { rgbt <1, 1, 1, 1> } }\n");
    expect_color(color_at(h, 0, 0.3, 0.3, 0.3, 4000), 0.5, 0.5, 0, 0.03);
    expect_color(color_at(h, 1, 0.3, 0.3, 0.3, 4000), 1, 1, 0, 0.03);
    expect_color(color_at(h, 2, 0.3, 0.3, 0.3, 4000), 0.25, 0, 0.75, 0.03);
    expect_color(color_at(h, 3, 0.5, 0.5, 0.5, 1), 0, 1, 0, 0);
    expect_color(color_at(h, 3, 1.5, 0.5, 0.5, 1), 1, 0, 0, 0);
    vbi_bsdf pass = bsdf_at(h, 4, 0.3, 0.3, 0.3, 0);
    assert_int_equal(pass.type, VBNL_MATERIAL_DIELECTRIC);
    assert_float_equal(pass.ior, 1.0, 0);
    expect_color(pass.color, 1, 1, 1, 1e-6);
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 0);
    done(h);
}

/* normal { }: the perturbed shading normal reaches the BSDF. */
static void test_bumps(void **state)
{
    (void)state;
    harness *h = run_ok("object_test { pigment { rgb 1 } normal { gradient x 1 } }\n"
                        "object_test { pigment { rgb 1 } normal { bumps 0 } }\n"
                        "object_test { pigment { rgb 1 } normal { bumps 0.5 scale 0.1 } }\n");
    /* gradient x, amount 1 (POV-Ray's normal.cpp): n + sum_i -5 amount v(p + 0.02 d_i) d_i over
     * the four unit directions d_i of a tetrahedron (sum_i d_i d_i^T = 4/3 I), so a slope of 1
     * along x adds -5 * 0.02 * 4/3 = -0.1333 to n_x before normalising */
    vbi_bsdf b = bsdf_at(h, 0, 0.5, 0.5, 0, 0);
    assert_true(b.bumped);
    const double nx = -0.02 * 5 * 4.0 / 3.0, len = sqrt(1 + nx * nx);
    assert_float_equal(b.ns.x, nx / len, 1e-5);
    assert_float_equal(b.ns.y, 0, 1e-5);
    assert_float_equal(b.ns.z, 1 / len, 1e-5);
    assert_float_equal(b.ns.x * b.ns.x + b.ns.y * b.ns.y + b.ns.z * b.ns.z, 1.0, 1e-5);
    b = bsdf_at(h, 1, 0.5, 0.5, 0, 0);
    assert_true(!b.bumped || fabsf(b.ns.z - 1.0f) < 1e-5f);
    b = bsdf_at(h, 2, 0.5, 0.5, 0, 0);
    assert_true(b.bumped && b.ns.z < 0.9999f && b.ns.z > 0.0f);
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 0);
    done(h);
}

/* Pattern and pigment functions and vturbulence: values POV-Ray 3.7.0 prints for the same
 * script (#debug with str(..., 0, 9)). */
/* Perturbed normals against POV-Ray 3.7.0: a plane y = 0 (normal +y) rendered with ambient 0,
 * diffuse 1 and one distant light along (1, 1, 0), (0, 1, 0) or (0, 1, 1), one 16-bit linear
 * pixel at each point: n . l gives the three components of POV-Ray's perturbed normal there. */
static void test_bumps_against_povray(void **state)
{
    (void)state;
    static const struct {
        const char *normal;
        double n[2][3]; /* at (0.31, 0, 0.47) and (1.23, 0, -0.77) */
    } ref[] = {
        {"gradient x 1", {{-0.132167, 0.991226, 0.000007}, {-0.132167, 0.991226, 0.000007}}},
        {"gradient x 1 scale 2", {{-0.132167, 0.991226, 0.000007}, {-0.132167, 0.991226, 0.000007}}},
        {"gradient x 1 scale 2 no_bump_scale", {{-0.066523, 0.997787, 0.000006}, {-0.066523, 0.997787, 0.000006}}},
        {"bumps 0.5", {{-0.043491, 0.999054, -0.002210}, {-0.136154, 0.984207, 0.113133}}},
        {"dents 0.8", {{-0.006011, 0.999985, -0.000314}, {-0.012076, 0.999878, 0.010022}}},
        {"ripples 0.6", {{0.008562, 0.993332, 0.114992}, {-0.049864, 0.998672, -0.013114}}},
        {"waves 0.6", {{0.011645, 0.890120, 0.455579}, {0.199637, 0.959701, -0.197815}}},
        {"wrinkles 0.7", {{0.200473, 0.967971, 0.151142}, {0.220739, 0.929686, 0.294886}}},
        {"quilted 0.8", {{-0.260722, 0.964538, -0.041172}, {-0.361981, 0.859022, -0.361981}}},
        {"granite 0.5", {{0.047465, 0.991028, -0.124934}, {0.191254, 0.981506, 0.007677}}},
        {"marble 0.5 slope_map { [0 <0, 1>] [0.5 <1, 0>] [1 <0, -1>] }",
         {{0.218255, 0.975891, -0.000000}, {-0.062087, 0.998077, -0.000003}}},
        {"bumps 0.5 rotate <20, 30, 40> scale <1, 2, 0.5>", {{0.188974, 0.795743, -0.575416}, {-0.482799, 0.645487, -0.591840}}},
        {"agate 0.5 turbulence 0.3", {{0.044375, 0.993103, -0.108580}, {-0.163220, 0.977890, -0.130656}}},
    };
    const double pts[2][3] = {{0.31, 0, 0.47}, {1.23, 0, -0.77}};
    const int n = (int)(sizeof(ref) / sizeof(ref[0]));
    char text[8192];
    size_t o = 0;
    for (int i = 0; i < n; ++i)
        o += (size_t)snprintf(text + o, sizeof(text) - o, "object_test { pigment { rgb 1 } normal { %s } }\n", ref[i].normal);
    harness *h = run_ok(text);
    double worst = 0;
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 2; ++k) {
            vbi_bsdf b = bsdf_at_n(h, i, pts[k][0], pts[k][1], pts[k][2], v3(0, 1, 0), 0);
            assert_true(b.bumped);
            const float got[3] = {b.ns.x, b.ns.y, b.ns.z};
            for (int c = 0; c < 3; ++c)
                worst = fmax(worst, fabs(got[c] - ref[i].n[k][c]));
            if (fabs(got[0] - ref[i].n[k][0]) > 1e-4 || fabs(got[1] - ref[i].n[k][1]) > 1e-4 ||
                fabs(got[2] - ref[i].n[k][2]) > 1e-4)
                fail_msg("normal { %s } at point %d: (%.6f %.6f %.6f), POV-Ray (%.6f %.6f %.6f)", ref[i].normal, k,
                         got[0], got[1], got[2], ref[i].n[k][0], ref[i].n[k][1], ref[i].n[k][2]);
        }
    print_message("# %d normals at 2 points: largest difference from POV-Ray %.2g\n", n, worst);
    done(h);
}

static void test_functions(void **state)
{
    (void)state;
    harness *h = run_ok("#declare F = function { pattern { bozo scale 0.5 } }\n"
                        "#declare G = function { pigment { gradient x color_map { [0 rgb <1,0,0>] [1 rgb <0,0,1>] } } }\n"
                        "#declare H = function { F(x, y, z) * 2 + G(x, y, z).blue }\n"
                        "#declare V = vturbulence(2, 0.5, 6, <0.3, 0.7, 1.1>);\n"
                        "#declare C = G(0.25, 0, 0);\n"
                        "#declare FV = F(0.3, 0.7, 1.1);\n"
                        "#declare HV = H(0.25, 0, 0);\n"
                        "object_test { pigment { function { F(x, y, z) } color_map { [0 rgb 0] [1 rgb 1] } } finish { diffuse 1 } }\n");
    const vbnl_sdl_value *v = vbnl_sdl_lookup(h->c.parser, "FV");
    assert_non_null(v);
    assert_float_equal(v->v[0], 0.496352071, 1e-9);
    v = vbnl_sdl_lookup(h->c.parser, "HV");
    assert_float_equal(v->v[0], 1.052319417, 1e-9);
    v = vbnl_sdl_lookup(h->c.parser, "V");
    assert_int_equal(v->kind, VBNL_SDL_VECTOR);
    assert_float_equal(v->v[0], 0.344564480, 1e-9);
    assert_float_equal(v->v[1], -0.261186792, 1e-9);
    assert_float_equal(v->v[2], -0.078804351, 1e-9);
    v = vbnl_sdl_lookup(h->c.parser, "C");
    assert_int_equal(v->kind, VBNL_SDL_COLOR);
    assert_float_equal(v->v[0], 0.75, 1e-6);
    assert_float_equal(v->v[2], 0.25, 1e-6);
    /* a pattern function inside a pigment, evaluated while rendering (a detached copy) */
    expect_color(color_at(h, 0, 0.3, 0.7, 1.1, 1), 0.496352071, 0.496352071, 0.496352071, 1e-6);
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 0);
    done(h);
}

/* tiling 1..24 render; the Penrose tilings and pavement are not implemented and say so. */
static void test_tilings(void **state)
{
    (void)state;
    harness *h = run_ok("object_test { pigment { tiling 3 color_map { [0 rgb 0] [1 rgb 1] } } finish { diffuse 1 } }\n"
                        "object_test { pigment { tiling 26 } }\n"
                        "object_test { pigment { pavement number_of_sides 4 number_of_tiles 2 } }\n");
    /* POV-Ray 3.7.0's tiling 3 at (0.5875, 0, 2.5625) (the render of tests/core/test_patterns.c) */
    vec3 c = color_at(h, 0, 0.5875, 0, 2.5625, 1);
    expect_color(c, 0.938384, 0.938384, 0.938384, 1e-5);
    assert_non_null(warning_text(h, "tiling 26 (a Penrose tiling) is not supported"));
    assert_non_null(warning_text(h, "pattern 'pavement' is not supported"));
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 2);
    done(h);
}

static void test_layers_and_ext(void **state)
{
    (void)state;
    harness *h = run_ok("#ifdef (vbnl_version) #end\n"
                        "object_test { texture { vbnl_bsdf { conductor eta <0.2, 0.9, 1.1> k <3.9, 2.4, 2.2> alpha 0.1 } } }\n"
                        "object_test { pigment { rgb <0.3, 0.2, 0.1> } vbnl_bsdf { plastic alpha 0.25 ior 1.4 } }\n"
                        "object_test { material { texture { vbnl_bsdf { lambert color rgb <0.1, 0.2, 0.3> emission <1, 2, 3> two_sided } } } }\n");
    const vbnl_material_desc *d = mat(h, 0);
    assert_int_equal(d->type, VBNL_MATERIAL_CONDUCTOR);
    assert_int_equal(d->conductor_use_ior, 1);
    expect3(d->eta, 0.2, 0.9, 1.1, 1e-6);
    expect3(d->k, 3.9, 2.4, 2.2, 1e-6);
    assert_float_equal(d->alpha, 0.1, 1e-7);
    d = mat(h, 1);
    assert_int_equal(d->type, VBNL_MATERIAL_PLASTIC);
    expect3(d->base_color, 0.3, 0.2, 0.1, 1e-6); /* the pigment, exactly */
    assert_float_equal(d->ior, 1.4, 1e-6);
    d = mat(h, 2);
    expect3(d->base_color, 0.1, 0.2, 0.3, 1e-6);
    expect3(d->emission, 1, 2, 3, 0);
    assert_int_equal(d->two_sided, 1);
    done(h);
}

/* Declarations warn where they are used: an unused declared texture is silent, a used one warns
 * once with the place of use. */
static void test_deferred_warnings(void **state)
{
    (void)state;
    harness *h = run_ok("#declare Unused = texture { pigment { object { sphere { 0, 1 } } color rgb 0, color rgb 1 } }\n"
                        "#declare U2 = texture { pigment { marble color_map { [0 rgb 0] [1 rgb 1] } turbulence 1 } }\n");
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 0);
    done(h);

    h = run_ok("#declare T = texture { pigment { object { sphere { 0, 1 } } color rgb 0, color rgb 1 } }\n"
               "object_test { texture { T } }\n"
               "object_test { texture { T } }\n");
    assert_int_equal(h->nmats, 2);
    const char *w = warning_text(h, "pattern 'object' is not supported");
    assert_non_null(w);
    assert_non_null(strstr(w, "test.pov:1:34: warning:"));
    assert_non_null(strstr(w, "reported where it is used: test.pov:2:25"));
    /* once per declaration, not per use */
    assert_int_equal(vbnl_sdl_warning_count(h->c.parser), 1);
    done(h);

    /* a declaration built from another one carries its warnings to where it is used */
    h = run_ok("#declare P = pigment { object { sphere { 0, 1 } } color rgb 0, color rgb 1 }\n"
               "#declare T = texture { pigment { P } }\n"
               "#declare U = T\n"
               "object_test { texture { U } }\n");
    w = warning_text(h, "pattern 'object' is not supported");
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
    /* T_Glass1 and M_Glass (rgbf <1, 1, 1, 0.7>) let 0.7 of the light into the glass (ior 1.5)
     * and reflect the rest with their finish */
    for (int obj = 2; obj <= 5; obj += 3) {
        int glass = 0, n = 2000;
        for (int k = 0; k < n; ++k) {
            vbi_bsdf b = bsdf_at(h, obj, 0.1, 0.2, 0.3, (uint32_t)k);
            if (b.type == VBNL_MATERIAL_DIELECTRIC) {
                assert_float_equal(b.ior, 1.5, 1e-6);
                glass++;
            }
        }
        assert_true(fabs((double)glass / n - 0.7) < 0.04);
    }
    done(h);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_declared_texture),
        cmocka_unit_test(test_identifiers_and_default),
        cmocka_unit_test(test_finish_mapping),
        cmocka_unit_test(test_variable_reflection),
        cmocka_unit_test(test_energy_clamp),
        cmocka_unit_test(test_patterns),
        cmocka_unit_test(test_transforms),
        cmocka_unit_test(test_image_map),
        cmocka_unit_test(test_texture_blends),
        cmocka_unit_test(test_bumps),
        cmocka_unit_test(test_bumps_against_povray),
        cmocka_unit_test(test_functions),
        cmocka_unit_test(test_tilings),
        cmocka_unit_test(test_layers_and_ext),
        cmocka_unit_test(test_deferred_warnings),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_standard_includes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
