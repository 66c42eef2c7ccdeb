/* vbnl: libFuzzer target for the scene parser (language and object layers).
 *
 * The input is a scene text loaded with vbnl_pov_load_text: #include is disabled, the limits are
 * small so that every input finishes quickly, and the core scene is built but not committed.
 * tools/fuzz.sh builds it (the parser's and the core's sources with -fsanitize=fuzzer,address,
 * undefined, linked with Embree and assimp) and runs it, seeded with the examples and includes.
 * Crashes become regression inputs in tests/scene_parser/language/regressions/ (test_sdl_regressions). */
#include <stddef.h>
#include <stdint.h>

#include "vbnl/pov_scene.h"
#include "vbnl/render.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static vbnl_context *ctx;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!ctx) {
        vbnl_context_desc cd;
        vbnl_context_desc_init(&cd);
        cd.threads = 1;
        if (vbnl_context_create(&cd, &ctx, NULL) != VBNL_OK)
            return 0;
    }
    vbnl_sdl_limits l;
    vbnl_sdl_limits_default(&l);
    l.max_loop_iterations = 2000;
    l.max_tokens = 50000;
    l.max_memory = (size_t)64 << 20;
    l.max_macro_depth = 64;
    l.max_nesting = 200;
    l.stack_bytes = (size_t)16 << 20;
    vbnl_pov_options o;
    vbnl_pov_options_init(&o);
    o.limits = &l;
    o.includes_disabled = 1;
    o.no_commit = 1;
    vbnl_pov_scene *s = NULL;
    vbnl_pov_load_text(ctx, "fuzz.pov", (const char *)data, size, &o, &s, NULL);
    vbnl_pov_scene_destroy(s);
    return 0;
}
