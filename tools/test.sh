#!/usr/bin/env bash
# Quick start, step 2: install what is missing, build (release) and run the whole test suite.
# Extra arguments go to `meson test` (for example a suite name).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/tools/deps.sh"
vbnl_install_deps povray-includes povray-examples ${VBNL_EXTRA_PACKAGES:-}
build=${VBNL_BUILD_DIR:-$here/build}
[ -f "$build/build.ninja" ] || meson setup "$build" "$here" --buildtype=release ${VBNL_MESON_ARGS:-} >/dev/null
ninja -C "$build"
meson test -C "$build" --print-errorlogs "$@"
