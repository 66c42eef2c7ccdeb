#!/usr/bin/env bash
# Builds the libFuzzer targets with AddressSanitizer + UndefinedBehaviorSanitizer and runs them: the
# scene parser for SECONDS (default 60), mesh import for 300 inputs from a fixed seed. The scene
# parser (language and object layers) is seeded with the examples, the POV-Ray standard
# includes and the regression inputs; mesh import (tests/scene_parser/fuzz_mesh.c: the first byte
# picks PLY, OBJ, glTF, OFF or STL) with the examples' meshes and a small file of each format. A
# crash leaves its input in build-fuzz/ and fails; add it to
# tests/scene_parser/language/regressions/ (scenes) or fix the import (meshes).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-60}
out="$here/build-fuzz"
mkdir -p "$out/corpus" "$out/seeds"
# every integrator folder is an include directory (the union of what meson gives each folder)
integrator_dirs=$(for d in "$here"/core/integrators/*/; do printf -- '-I %s ' "${d%/}"; done)
build() { # TARGET_SOURCE OUTPUT
    clang -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -D_GNU_SOURCE \
        -I "$here/core/include" -I "$here/core/src" -I "$here/core/src/texture" $integrator_dirs \
        -I "$here/scene_parser/include" -I "$here/scene_parser/language" -I "$here/scene_parser/objects" \
        -I "$here/scene_parser/objects/shapes" -I "$here/scene_parser/objects/texture" -I "$here/scene_parser/image" \
        $(find "$here/scene_parser" -name '*.c' | sort) "$here"/core/src/*.c "$here"/core/src/texture/*.c \
        "$here"/core/integrators/registry.c $(ls "$here"/core/integrators/*/*.c | grep -v '_reference\.c$') \
        "$1" $(pkg-config --cflags --libs freetype2) -lembree3 -lassimp -lpng -lm -lpthread -ldl -o "$2"
}
build "$here/tests/scene_parser/fuzz_parser.c" "$out/fuzz_parser"
build "$here/tests/scene_parser/fuzz_mesh.c" "$out/fuzz_mesh"
cp "$here"/tests/scene_parser/language/regressions/*.pov "$out/seeds/" 2>/dev/null || true
cp /usr/share/povray-3.7/include/*.inc "$out/seeds/" 2>/dev/null || true
cp "$here"/examples/*.pov "$out/seeds/" 2>/dev/null || true
parser_s=$seconds

"$out/fuzz_parser" -dict="$here/tests/scene_parser/sdl.dict" -max_len=8192 -timeout=20 -rss_limit_mb=2048 \
    -max_total_time="$parser_s" -print_final_stats=1 -artifact_prefix="$out/" "$out/corpus" "$out/seeds" 2>&1 | tail -8
# mesh seeds: the format byte, then the file
rm -rf "$out/mesh-seeds"
mkdir -p "$out/mesh-seeds"
for f in "$here"/examples/*.obj "$here"/examples/mcguire/*.obj; do
    [ -f "$f" ] && { printf '\001'; cat "$f"; } > "$out/mesh-seeds/$(basename "$f")"
done
printf '\000ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' > "$out/mesh-seeds/tri.ply"
printf '\003OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' > "$out/mesh-seeds/tri.off"
printf '\004solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n' > "$out/mesh-seeds/tri.stl"
# Mesh import runs a fixed number of inputs from a fixed seed (the same inputs every time, so a
# pass stays a pass), without leak checks: assimp 5.2 leaks its own allocations on some error
# paths (a malformed STL keyword), which are not vbnl's to free.
ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0" "$out/fuzz_mesh" -seed=1 -runs=300 -detect_leaks=0 \
    -max_len=4096 -timeout=20 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$out/mesh-" "$out/mesh-seeds" 2>&1 | tail -8
