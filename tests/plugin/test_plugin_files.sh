#!/usr/bin/env bash
# The plugin as files: exported symbols, the public header under strict C and C++, the host with a
# fake or missing module, and `meson install` into a temporary prefix. TAP output.
# usage: test_plugin_files.sh PLUGIN FAKE_PLUGIN LYING_PLUGIN VBNL SOURCE_DIR BUILD_DIR CC CXX
set -u
PLUGIN=$1 FAKE=$2 LYING=$3 VBNL=$4 SRC=$5 BUILD=$6 CC=$7 CXX=$8
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
n=0
failed=0
ok() { n=$((n + 1)); echo "ok $n - $1"; }
not_ok() { n=$((n + 1)); failed=$((failed + 1)); echo "not ok $n - $1"; shift; for l in "$@"; do echo "# $l"; done; }
check() { local name=$1; shift; if "$@"; then ok "$name"; else not_ok "$name"; fi; }
expect() { # NAME STATUS PATTERN -- COMMAND...
    local name=$1 status=$2 pattern=$3 out rc
    shift 4
    out=$("$@" 2>&1)
    rc=$?
    if [ "$rc" -eq "$status" ] && grep -qE -- "$pattern" <<<"$out"; then ok "$name"; else not_ok "$name" "exit $rc (want $status), output:" "$out"; fi
}

# Exactly one exported symbol.
syms=$(nm -D --defined-only "$PLUGIN" | awk '{print $3}')
[ "$syms" = "vbnl_plugin_entry" ] && ok "nm -D: only vbnl_plugin_entry is exported" || not_ok "nm -D: only vbnl_plugin_entry is exported" "$syms"

# The public header alone, as strict C11 and as C++ (both must use the table).
cat > "$TMP/use.c" <<'C'
#include <vbnl/vbnl_plugin.h>
#include <stdio.h>
int use(const vbnl_plugin_api *api);
int use(const vbnl_plugin_api *api)
{
    vbnl_plugin_options o;
    vbnl_plugin_view v;
    api->options_init(&o);
    api->view_init(&v);
    return VBNL_PLUGIN_HAS(api, run_command) && o.width > 0 && v.png_bits == 8;
}
C
cp "$TMP/use.c" "$TMP/use.cpp"
check "header compiles as C11 -pedantic" $CC -std=c11 -pedantic-errors -Wall -Wextra -Werror -I "$SRC/plugin/include" -c "$TMP/use.c" -o "$TMP/use_c.o"
check "header compiles as C99 -pedantic" $CC -std=c99 -pedantic-errors -Wall -Wextra -Werror -I "$SRC/plugin/include" -c "$TMP/use.c" -o "$TMP/use_c99.o"
check "header compiles as C++11 -pedantic" $CXX -std=c++11 -pedantic-errors -Wall -Wextra -Werror -I "$SRC/plugin/include" -c "$TMP/use.cpp" -o "$TMP/use_cpp.o"

# The host refuses a module of another ABI, a lying module and a missing one, with exit 4.
expect "fake plugin of ABI 99 is refused" 4 "has another ABI \(this host needs ABI major 1\): fake module built for plugin ABI 99.0" -- "$VBNL" --plugin "$FAKE" info
expect "a table with another major is refused" 4 "its table has ABI 99.0" -- "$VBNL" --plugin "$LYING" info
expect "missing plugin named by --plugin" 4 "plugin '$TMP/none.so': No such file" -- "$VBNL" --plugin "$TMP/none.so" info
expect "missing plugin named by VBNL_PLUGIN" 4 "plugin '$TMP/none.so'" -- env VBNL_PLUGIN="$TMP/none.so" "$VBNL" info
expect "a file that is not a module" 4 "cannot load plugin" -- "$VBNL" --plugin "$SRC/README.md" info
cp "$VBNL" "$TMP/vbnl-alone"
expect "no plugin anywhere: clear message" 4 "plugin vbnl_plugin.so not found.*--plugin PATH" -- env -u VBNL_PLUGIN "$TMP/vbnl-alone" info
expect "help works without a plugin" 0 "usage: vbnl" -- "$TMP/vbnl-alone" --help
expect "VBNL_PLUGIN finds the module" 0 "integrator ABI|ABI 1\.3" -- env VBNL_PLUGIN="$PLUGIN" "$TMP/vbnl-alone" info

# meson install into a temporary prefix: host, plugin, header, pkg-config file.
DEST=$TMP/dest
if meson install -C "$BUILD" --no-rebuild --quiet --destdir "$DEST" >"$TMP/install.log" 2>&1; then
    ok "meson install --destdir"
else
    not_ok "meson install --destdir" "$(tail -5 "$TMP/install.log")"
fi
host=$(find "$DEST" -path '*/bin/vbnl' -type f | head -1)
mod=$(find "$DEST" -name vbnl_plugin.so | head -1)
hdr=$(find "$DEST" -path '*/include/vbnl/vbnl_plugin.h' | head -1)
pc=$(find "$DEST" -name vbnl-plugin.pc | head -1)
[ -x "$host" ] && [ -f "$mod" ] && [ -f "$hdr" ] && [ -f "$pc" ] && ok "installed host, plugin, header and .pc" || not_ok "installed host, plugin, header and .pc" "$(find "$DEST" -type f)"
# the installed host finds the installed plugin relative to itself
expect "installed host renders" 0 "spp in" -- env -u VBNL_PLUGIN "$host" render "$SRC/examples/cornell-box.obj" --png "$TMP/inst.png" --width 16 --height 16 --spp 1
grep -q "vbnl_plugin.so" <<<"$(env -u VBNL_PLUGIN "$host" --version)" && [[ "$(env -u VBNL_PLUGIN "$host" --version)" == *"$DEST"* ]] && ok "installed host uses the installed plugin" || not_ok "installed host uses the installed plugin" "$(env -u VBNL_PLUGIN "$host" --version 2>&1)"
# a host compiled from the installed header through pkg-config loads the installed module
cat > "$TMP/mini.c" <<'C'
#include <dlfcn.h>
#include <stdio.h>
#include <vbnl/vbnl_plugin.h>
int main(int argc, char **argv)
{
    void *so = dlopen(argv[1], RTLD_NOW);
    if (!so || argc < 2) { fprintf(stderr, "%s\n", dlerror()); return 1; }
    vbnl_plugin_entry_fn entry;
    *(void **)&entry = dlsym(so, VBNL_PLUGIN_ENTRY_NAME);
    const vbnl_plugin_api *api = entry ? entry(VBNL_PLUGIN_ABI_MAJOR, NULL) : NULL;
    if (!api) return 1;
    printf("version %s, %u integrators\n", api->version(), api->integrator_count());
    return 0;
}
C
# a module built with sanitizers needs their runtimes first in the host too
san=""
readelf -d "$mod" | grep -q "libasan" && san="-fsanitize=address,undefined"
export PKG_CONFIG_PATH=$(dirname "$pc")
prefix=$(pkg-config --variable=prefix vbnl-plugin)
PC="pkg-config --define-variable=prefix=$DEST$prefix"
cflags=$($PC --cflags vbnl-plugin 2>&1) && libs=$($PC --libs vbnl-plugin 2>&1) \
    && plugvar=$($PC --variable=plugin vbnl-plugin) \
    && $CC -std=c11 $san $cflags "$TMP/mini.c" -o "$TMP/mini" $libs 2>"$TMP/cc.log" \
    && out=$("$TMP/mini" "$plugvar" 2>&1) && grep -q "version 0.1.0, [1-9]" <<<"$out" \
    && [[ "$plugvar" == "$DEST"* ]] \
    && ok "pkg-config: a host built from the installed header loads the installed plugin" \
    || not_ok "pkg-config: a host built from the installed header loads the installed plugin" "cflags=$cflags libs=${libs:-} plugin=${plugvar:-}" "$(cat "$TMP/cc.log" 2>/dev/null)" "${out:-}"

echo "1..$n"
[ $failed -eq 0 ]
