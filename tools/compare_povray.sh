#!/usr/bin/env bash
# Renders POV-Ray sample scenes with vbnl and with POV-Ray 3.7 itself, small, and writes each
# pair side by side (POV-Ray left, vbnl right) for a person to look at: OUT/index.html, and one
# PNG per scene when oiiotool (openimageio-tools) is installed. A tool, not a test: it judges
# nothing. Without `povray` it says so and stops.
#
#   tools/compare_povray.sh [-o OUT] [-w WIDTH] [-h HEIGHT] [-s SPP] [-v VBNL] [SCENE.pov ...]
#
# SCENE paths are relative to POV-Ray's sample scenes (/usr/share/povray-3.7/scenes) or absolute;
# without any, a set that shows the curved shapes (text, lathe, sor, prism, quartic, isosurface,
# blob, julia_fractal, superellipsoid, height_field, CSG). Defaults: OUT compare-povray/, 320x240,
# 32 samples per pixel, VBNL build/plugin/vbnl (from the source tree) or `vbnl` on the PATH.
set -euo pipefail

out=compare-povray
width=320
height=240
spp=32
here="$(cd "$(dirname "$0")/.." && pwd)"
vbnl="$here/build/plugin/vbnl"
[ -x "$vbnl" ] || vbnl="$(command -v vbnl || true)"
scenes_dir=/usr/share/povray-3.7/scenes

while getopts "o:w:h:s:v:" opt; do
    case $opt in
    o) out=$OPTARG ;;
    w) width=$OPTARG ;;
    h) height=$OPTARG ;;
    s) spp=$OPTARG ;;
    v) vbnl=$OPTARG ;;
    *) sed -n '2,14p' "$0"; exit 2 ;;
    esac
done
shift $((OPTIND - 1))

if ! command -v povray >/dev/null 2>&1; then
    echo "compare_povray: povray is not installed (apt-get install povray povray-includes povray-examples); nothing to compare" >&2
    exit 0
fi
if [ -z "$vbnl" ] || [ ! -x "$vbnl" ]; then
    echo "compare_povray: no vbnl executable (build it, or give -v PATH)" >&2
    exit 1
fi

if [ $# -eq 0 ]; then
    set -- advanced/pawns.pov advanced/glasschess/glasschess.pov objects/lathe2.pov objects/sor1.pov \
        objects/prism2.pov objects/quartic/helix.pov objects/quartic/torus.pov objects/isosurfaces.pov \
        objects/blob.pov objects/fractal3.pov objects/superel3.pov objects/csg/hfclip.pov \
        incdemo/shapes.pov advanced/blocks/stackergold.pov advanced/benchmark/benchmark.pov
fi

mkdir -p "$out"
out="$(cd "$out" && pwd)"
html="$out/index.html"
{
    echo "<!doctype html><html><head><meta charset=\"utf-8\"><title>POV-Ray | vbnl</title>"
    echo "<style>body{font-family:sans-serif;background:#222;color:#ddd}img{margin:2px}td{vertical-align:top}</style>"
    echo "</head><body><h1>POV-Ray 3.7 (left) | vbnl (right), ${width}x${height}</h1><table>"
} >"$html"

for scene in "$@"; do
    case $scene in /*) path=$scene ;; *) path="$scenes_dir/$scene" ;; esac
    if [ ! -f "$path" ]; then
        echo "compare_povray: $path does not exist; skipped" >&2
        continue
    fi
    name=$(basename "$path" .pov)
    dir=$(dirname "$path")
    echo "== $scene" >&2
    # POV-Ray writes next to the scene unless told otherwise; -D: no display window
    if ! (cd "$dir" && povray +W"$width" +H"$height" -D +A0.3 +O"$out/$name.pov.png" "$path" >"$out/$name.pov.log" 2>&1); then
        echo "   povray failed (see $out/$name.pov.log)" >&2
    fi
    if ! "$vbnl" render "$path" -o "$out/$name.vbnl.exr" --png "$out/$name.vbnl.png" --width "$width" \
        --height "$height" --spp "$spp" >"$out/$name.vbnl.log" 2>&1; then
        echo "   vbnl failed (see $out/$name.vbnl.log)" >&2
    fi
    if command -v oiiotool >/dev/null 2>&1 && [ -f "$out/$name.pov.png" ] && [ -f "$out/$name.vbnl.png" ]; then
        oiiotool "$out/$name.pov.png" --ch R,G,B "$out/$name.vbnl.png" --ch R,G,B --mosaic 2x1 -o "$out/$name.png" >/dev/null 2>&1 ||
            echo "   oiiotool could not join the pair" >&2
    fi
    echo "<tr><td>$scene<br><small>$(grep -c 'warning' "$out/$name.vbnl.log" 2>/dev/null || echo 0) vbnl warnings</small></td>" \
        "<td><img src=\"$name.pov.png\"></td><td><img src=\"$name.vbnl.png\"></td></tr>" >>"$html"
done
echo "</table></body></html>" >>"$html"
echo "compare_povray: $html" >&2
