#!/usr/bin/env bash
# Builds the scene-parser libFuzzer target (language and object layers) with AddressSanitizer + UndefinedBehaviorSanitizer and
# runs it for SECONDS (default 60), seeded with the examples, the POV-Ray standard includes and
# the regression inputs. A crash leaves its input in build-fuzz/ and fails; add it to
# tests/scene_parser/language/regressions/ once fixed.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-60}
out="$here/build-fuzz"
mkdir -p "$out/corpus" "$out/seeds"
# every integrator folder is an include directory (they share headers, as in meson.build)
integrator_dirs=$(for d in "$here"/core/integrators/*/; do printf -- '-I %s ' "${d%/}"; done)
clang -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -D_GNU_SOURCE \
    -I "$here/core/include" -I "$here/core/src" $integrator_dirs \
    -I "$here/scene_parser/include" -I "$here/scene_parser/language" -I "$here/scene_parser/objects" \
    -I "$here/scene_parser/objects/shapes" -I "$here/scene_parser/objects/texture" \
    $(find "$here/scene_parser" -name '*.c' | sort) "$here"/core/src/*.c \
    "$here"/core/integrators/registry.c "$here"/core/integrators/*/*.c \
    "$here/tests/scene_parser/fuzz_parser.c" -lembree3 -lassimp -lpng -lm -lpthread -o "$out/fuzz_parser"
cp "$here"/tests/scene_parser/language/regressions/*.pov "$out/seeds/" 2>/dev/null || true
cp /usr/share/povray-3.7/include/*.inc "$out/seeds/" 2>/dev/null || true
cp "$here"/examples/*.pov "$out/seeds/" 2>/dev/null || true
"$out/fuzz_parser" -dict="$here/tests/scene_parser/sdl.dict" -max_len=8192 -timeout=20 -rss_limit_mb=2048 \
    -max_total_time="$seconds" -print_final_stats=1 -artifact_prefix="$out/" "$out/corpus" "$out/seeds" 2>&1 | tail -8
