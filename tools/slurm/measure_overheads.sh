#!/usr/bin/env bash
# The per-job figures of docs/farm.md's speed-up model, measured on this machine (one node): each
# is the median of RUNS runs (default 3), in seconds. Needs no Slurm (the scheduler's own latency
# is measured on the local cluster: docs/farm.md says how).
#
#   tools/slurm/measure_overheads.sh VBNL SCENE [render options...]
#   e.g. tools/slurm/measure_overheads.sh build/plugin/vbnl examples/door-ajar.pov --width 1920 --height 1080 \
#            --set virtual_lights=130000 --set photon_paths=2e7
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 VBNL SCENE [render options...]" >&2; exit 2; }
HERE=$(cd "$(dirname "$0")/../.." && pwd)
VBNL=$(realpath "$1")
SCENE=$(realpath "$2")
shift 2
OPTS=("$@" --seed 1 -q)
RUNS=${RUNS:-3}
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
cd "$W"

median() { sort -n | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }
wall() { # wall seconds of a command
    local s e
    s=$(date +%s.%N)
    "$@" >/dev/null 2>&1
    e=$(date +%s.%N)
    echo "$e - $s" | bc
}
runs() { for _ in $(seq "$RUNS"); do wall "$@"; done | median; }
attr() { # attribute of an EXR header (as tests/cli/exr_header.py prints it)
    python3 "$HERE/tests/cli/exr_header.py" "$1" | grep "^$2=" | cut -d= -f2
}
vlfield() { # a double of a light file's header at byte offset $2
    python3 -c "import struct,sys; print(struct.unpack_from('<d', open(sys.argv[1], 'rb').read(160), int(sys.argv[2]))[0])" "$1" "$2"
}

echo "# $(uname -n), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); $RUNS runs each; scene $SCENE ${OPTS[*]}"
"$VBNL" prepare "$SCENE" "${OPTS[@]}" -o place.vls
echo "prepare job (vbnl prepare, wall)        $(runs "$VBNL" prepare "$SCENE" "${OPTS[@]}" -o place.vls)"
echo "  of which placement, elimination        $(vlfield place.vls 128) $(vlfield place.vls 136)"
echo "  placement file, bytes                  $(stat -c %s place.vls)"
for k in 0 1 2; do
    w=$(wall "$VBNL" photons "$SCENE" "${OPTS[@]}" --placement place.vls --part "$k/16" -o "part$k.vls")
    echo "$w $(vlfield "part$k.vls" 144)"
done > parts.txt
echo "photon job of 1/16 (wall, photon s)      $(cut -d' ' -f1 parts.txt | median) $(cut -d' ' -f2 parts.txt | median)"
echo "  its overhead (wall - photons)          $(awk '{print $1 - $2}' parts.txt | median)"
echo "  part file, bytes                       $(stat -c %s part0.vls)"
echo "merge-lights of 1 part (wall)            $(runs "$VBNL" merge-lights --partial part0.vls -o m.vls)"
echo "merge-lights of 3 parts (wall)           $(runs "$VBNL" merge-lights --partial part0.vls part1.vls part2.vls -o m.vls)"
"$VBNL" photons "$SCENE" "${OPTS[@]}" --placement place.vls --part 0/1 -o lights.vls
echo "all photon paths in one job (photon s)   $(vlfield lights.vls 144)"
echo "job start: scene loaded, 1 pixel (wall)  $(runs "$VBNL" render "$SCENE" "${OPTS[@]}" --integrator path --crop 0,0,1,1 --spp 1 -o p.exr)"
echo "tile job of 16x16 pixels, 1 spp (wall)   $(runs "$VBNL" render "$SCENE" "${OPTS[@]}" --load-lights lights.vls --crop 0,0,16,16 --spp 1 -o t.exr)"
for _ in $(seq "$RUNS"); do
    w=$(wall "$VBNL" render "$SCENE" "${OPTS[@]}" --load-lights lights.vls --spp 4 -o r.exr --png r.png)
    echo "$w $(attr r.exr vbnl/time/render) $(attr r.exr vbnl/time/prepare)"
done > render.txt
echo "render, 4 spp (render s)                 $(cut -d' ' -f2 render.txt | median)"
echo "  outputs and start (wall - render - prepare) $(awk '{print $1 - $2 - $3}' render.txt | median)"
"$VBNL" farm "$SCENE" "${OPTS[@]}" --spp 1 -o f.exr --photon-jobs 1 --tiles 16 --local
echo "merge-tiles of 16 tiles, EXR (wall)      $(runs "$VBNL" merge-tiles f.farm/tiles/tile-*.exr -o mt.exr)"
echo "merge-tiles of 16 tiles, EXR+PNG (wall)  $(runs "$VBNL" merge-tiles f.farm/tiles/tile-*.exr -o mt.exr --png mt.png)"
for i in $(seq 0 15); do attr "f.farm/tiles/tile-$i.exr" vbnl/rays; done |
    awk '{s += $1; if ($1 > m) m = $1} END {printf "tile imbalance, 16 tiles (max/mean rays) %.3f\n", m / (s / NR)}'
