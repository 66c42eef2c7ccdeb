#!/usr/bin/env bash
# Quick start, step 1: install what is missing, build (release), render the example scene to
# out.exr and out.png in the current directory.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/tools/deps.sh"
vbnl_install_deps
[ -f "$here/build/build.ninja" ] || meson setup "$here/build" "$here" --buildtype=release >/dev/null
ninja -C "$here/build" >/dev/null
# The scene selects the vbnl integrator and its parameters in its global_settings block.
"$here/build/plugin/vbnl" render "$here/examples/cornell-box.pov" -o out.exr --png out.png \
    --width 512 --height 512 --spp 64
echo "wrote out.exr (scene-linear, with albedo, normal and depth layers) and out.png (sRGB, Standard view)"
