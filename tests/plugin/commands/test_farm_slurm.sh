#!/usr/bin/env bash
# `vbnl farm` through a real Slurm: a one-machine cluster of two fake nodes of two CPUs each
# (tools/slurm/local_cluster.sh) runs the job graph, and the merged image must be `vbnl render`'s
# bit for bit, also when an array element fails once and is run again; a scene that cannot be
# loaded submits nothing. Skipped (a TAP skip) only where Slurm cannot start here; every daemon the
# test started is stopped by PID. TAP output.
# usage: test_farm_slurm.sh VBNL_BINARY SOURCE_DIR EXR_SAME_BINARY
set -u
VBNL=$1
SRC=$2
SAME=$3
SCENE=$SRC/examples/cornell-box.pov
TMP=$(mktemp -d)
chmod 755 "$TMP" # munged's socket below it is for every user
CLUSTER=$TMP/cluster
mkdir "$CLUSTER"
cleanup() {
    bash "$SRC/tools/slurm/local_cluster.sh" stop "$CLUSTER"
    rm -rf "$TMP"
}
trap cleanup EXIT
source "$SRC/tests/cli/tap.sh"
source "$SRC/tests/plugin/commands/farm_tap.sh"

t0=$(date +%s.%N)
if ! out=$(bash "$SRC/tools/slurm/local_cluster.sh" start "$CLUSTER" 2 2 2>&1); then
    if grep -q "Slurm cannot run here" <<<"$out"; then
        echo "1..0 # SKIP $out"
        exit 0
    fi
    echo "Bail out! the local cluster did not start: $out"
    exit 1
fi
eval "$out" # export SLURM_CONF=...
echo "# cluster of 2 nodes up in $(echo "$(date +%s.%N) - $t0" | bc) s"
jobs_known() { scontrol -o show jobs 2>/dev/null | grep -c JobId=; }

OPTS=(--width 40 --height 32 --spp 4 --seed 3 --set virtual_lights=2000 --set photon_paths=50000 -q)
cd "$TMP"
"$VBNL" render "$SCENE" "${OPTS[@]}" -o single.exr --png single.png

# The graph on the cluster for 1, 3 and 7 photon jobs and 1, 4 and 9 tiles.
for pt in 1:1 3:4 7:9; do
    p=${pt%:*}
    t=${pt#*:}
    s=$(date +%s.%N)
    if out=$("$VBNL" farm "$SCENE" "${OPTS[@]}" -o "slurm-$p-$t.exr" --png "slurm-$p-$t.png" --photon-jobs "$p" --tiles "$t" --wait 2>&1); then
        same "Slurm, $p photon jobs, $t tiles: the single render bit for bit (EXR, header, PNG)" \
            single.exr "slurm-$p-$t.exr" single.png "slurm-$p-$t.png"
    else
        not_ok "Slurm, $p photon jobs, $t tiles" "$out"
    fi
    echo "# $p photon jobs, $t tiles: $(echo "$(date +%s.%N) - $s" | bc) s on the cluster"
done
# names and logs a user can find
logs=$(ls slurm-7-9.farm/logs | grep -c '^tiles-[0-9]*_[0-8]\.log$')
names=$(scontrol -o show jobs | grep -o 'JobName=vbnl-slurm-7-9-[a-z-]*' | sort -u | tr '\n' ' ')
if [ "$logs" = 9 ] && [ "$names" = "JobName=vbnl-slurm-7-9-merge JobName=vbnl-slurm-7-9-merge-lights JobName=vbnl-slurm-7-9-photons JobName=vbnl-slurm-7-9-prepare JobName=vbnl-slurm-7-9-tiles " ]; then
    ok "one log per tile element, job names vbnl-NAME-STAGE"
else
    not_ok "one log per tile element, job names vbnl-NAME-STAGE" "$logs logs" "$names"
fi

# A failed array element runs again, and the image is still exact: tile 2 fails its first run.
cat > flaky-vbnl <<EOF
#!/bin/bash
if [ "\$3" = render ] && [ "\${SLURM_ARRAY_TASK_ID:-}" = 2 ] && mkdir "$TMP/failed-once" 2>/dev/null; then
    echo "test: tile 2 fails its first run" >&2
    exit 1
fi
exec "$VBNL" "\$@"
EOF
chmod +x flaky-vbnl
out=$("$VBNL" farm "$SCENE" "${OPTS[@]}" -o retry.exr --png retry.png --photon-jobs 2 --tiles 4 --vbnl ./flaky-vbnl --wait 2>&1)
rc=$?
log=$(cat retry.farm/logs/tiles-*_2.log 2>/dev/null)
if [ $rc -eq 0 ] && [ -d failed-once ] && grep -q "tile 2 fails its first run" <<<"$log" && grep -q "attempt 2 of 3" <<<"$log" &&
    "$SAME" single.exr retry.exr --attrs "$DET" >/dev/null 2>&1 && cmp -s single.png retry.png; then
    ok "a failed tile element is run again and the image is still exact"
else
    not_ok "a failed tile element is run again and the image is still exact" "farm exit $rc: $out" "$log"
fi
# An element that keeps failing fails its stage, and the stages after it are cancelled.
cat > broken-vbnl <<EOF
#!/bin/bash
[ "\$3" = photons ] && [ "\${SLURM_ARRAY_TASK_ID:-}" = 1 ] && exit 1
exec "$VBNL" "\$@"
EOF
chmod +x broken-vbnl
out=$("$VBNL" farm "$SCENE" "${OPTS[@]}" -o broken.exr --photon-jobs 2 --tiles 2 --retries 1 --vbnl ./broken-vbnl --wait 2>&1)
rc=$?
if [ $rc -eq 1 ] && grep -q "photons element 1: JobState=FAILED" <<<"$out" && grep -q "merge element 0: JobState=CANCELLED" <<<"$out" &&
    [ ! -e broken.exr ] && [ -z "$(squeue -h)" ]; then
    ok "a stage that keeps failing cancels the stages after it, and --wait says so"
else
    not_ok "a stage that keeps failing cancels the stages after it, and --wait says so" "farm exit $rc: $out" "$(squeue)"
fi

# A scene that cannot be loaded is refused before anything is submitted.
printf 'camera { location 0 look_at z }\nsphere { 0, 1 frobnicate }\n' > bad.pov
before=$(jobs_known)
out=$("$VBNL" farm bad.pov -o bad.exr --wait 2>&1)
rc=$?
if [ $rc -eq 3 ] && grep -q "bad.pov:2:15: error" <<<"$out" && [ "$(jobs_known)" = "$before" ] && [ ! -e bad.farm ]; then
    ok "an unloadable scene is refused and nothing is submitted"
else
    not_ok "an unloadable scene is refused and nothing is submitted" "exit $rc: $out" "jobs $before -> $(jobs_known)"
fi

tap_end
