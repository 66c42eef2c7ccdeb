/* vbnl: libFuzzer target for the SDL language layer.
 *
 * The input is a scene text; #include is disabled and the limits are small so that every input
 * finishes quickly. Build and run:
 *   clang -g -O1 -fsanitize=fuzzer,address,undefined -D_GNU_SOURCE -I core/include -I scene_parser \
 *         -I scene_parser/include scene_parser/sdl_*.c core/src/error.c \
 *         tests/scene_parser/fuzz_parser.c -lm -lpthread -o fuzz_parser
 *   ./fuzz_parser -dict=tests/scene_parser/sdl.dict -max_len=8192 corpus_dir /usr/share/povray-3.7/include
 * Crashes become regression inputs in tests/scene_parser/regressions/ (test_sdl_regressions). */
#include <stddef.h>
#include <stdint.h>

#include "vbnl/sdl.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    vbnl_sdl_parser *p = NULL;
    if (vbnl_sdl_parser_create(&p, NULL) != VBNL_OK)
        return 0;
    vbnl_sdl_limits l;
    vbnl_sdl_limits_default(&l);
    l.max_loop_iterations = 2000;
    l.max_tokens = 50000;
    l.max_memory = (size_t)64 << 20;
    l.max_macro_depth = 64;
    l.max_nesting = 200;
    l.stack_bytes = (size_t)16 << 20;
    vbnl_sdl_set_limits(p, &l);
    vbnl_sdl_set_includes_enabled(p, 0);
    vbnl_sdl_parse_text(p, "fuzz.pov", (const char *)data, size, NULL);
    vbnl_sdl_parser_destroy(p);
    return 0;
}
