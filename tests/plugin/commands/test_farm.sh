#!/usr/bin/env bash
# The farm's stages and merges without Slurm (docs/farm.md): `vbnl farm --local` runs the job
# scripts a submission writes, one after another, and the merged image must be `vbnl render`'s,
# bit for bit; the merges refuse parts of another render and missing parts; the front end refuses
# what cannot be rendered before writing anything. TAP output.
# usage: test_farm.sh VBNL_BINARY SOURCE_DIR EXR_SAME_BINARY
set -u
VBNL=$1
SRC=$2
SAME=$3
SCENE=$SRC/examples/cornell-box.pov
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
source "$SRC/tests/cli/tap.sh"
source "$SRC/tests/plugin/commands/farm_tap.sh"

OPTS=(--width 40 --height 32 --spp 4 --seed 3 --set virtual_lights=2000 --set photon_paths=50000 -q)
cd "$TMP"
"$VBNL" render "$SCENE" "${OPTS[@]}" -o single.exr --png single.png

# Prepare once, photons apart, tiles apart: the image of one render, for 1, 3 and 7 photon jobs
# and 1, 4 and 9 tiles.
for pt in 1:1 3:4 7:9; do
    p=${pt%:*}
    t=${pt#*:}
    if out=$("$VBNL" farm "$SCENE" "${OPTS[@]}" -o "farm-$p-$t.exr" --png "farm-$p-$t.png" --photon-jobs "$p" --tiles "$t" --local 2>&1); then
        same "farm --local, $p photon jobs, $t tiles: the single render bit for bit (EXR, header, PNG)" \
            single.exr "farm-$p-$t.exr" single.png "farm-$p-$t.png"
    else
        not_ok "farm --local, $p photon jobs, $t tiles" "$out"
    fi
done
ls farm-3-4.farm/lights/photons-{0,1,2}.vls farm-3-4.farm/tiles/tile-{0,1,2,3}.exr farm-3-4.farm/jobs/*.sh >/dev/null 2>&1 &&
    ok "the work folder holds the parts and the job scripts" || not_ok "the work folder holds the parts and the job scripts" "$(find farm-3-4.farm)"
# an integrator without lights: tiles and merge only
"$VBNL" render "$SCENE" --width 24 --height 16 --spp 2 --integrator path -q -o path.exr
if out=$("$VBNL" farm "$SCENE" --width 24 --height 16 --spp 2 --integrator path -q -o path-farm.exr --tiles 3x2 --local 2>&1); then
    same "farm --local with path (no lights): the single render bit for bit" path.exr path-farm.exr
    [ ! -e path-farm.farm/jobs/prepare.sh ] && ok "path has no preparation stages" || not_ok "path has no preparation stages"
else
    not_ok "farm --local with path" "$out"
fi

# The stages by hand: one tile written as its window, the header naming it and its inputs.
W=farm-3-4.farm
"$VBNL" render "$SCENE" "${OPTS[@]}" --load-lights "$W/lights/lights.vls" --crop 0,0,20,16 -o t0.exr
hdr=$("$SAME" t0.exr "$W/tiles/tile-0.exr" --attrs vbnl/crop,vbnl/lights/fingerprint,vbnl/lights/photons 2>&1)
[ $? -eq 0 ] && ok "a tile rendered by hand equals the farm's, window and inputs" || not_ok "a tile rendered by hand equals the farm's" "$hdr"
expect "a tile is its window: the data window of the 40x32 image" 0 "" -- \
    bash -c "python3 '$SRC/tests/cli/exr_header.py' t0.exr | grep -q 'vbnl/crop=0,0,20,16'"

# The merges refuse parts that do not belong together, and missing parts.
T=("$W"/tiles/tile-{0,1,2,3}.exr)
expect "merge-tiles by hand" 0 "4 tiles, 40x32 pixels" -- "$VBNL" merge-tiles "${T[@]}" -o m.exr
"$VBNL" render "$SCENE" "${OPTS[@]}" --seed 4 --load-lights "$W/lights/lights.vls" --set reuse_lights=on --crop 20,0,40,16 -o seed4.exr
expect "merge-tiles refuses a tile of another seed" 1 "seed4.exr' has vbnl/seed = '4'" -- \
    "$VBNL" merge-tiles "${T[0]}" seed4.exr "${T[2]}" "${T[3]}" -o m2.exr
expect "merge-tiles refuses a missing tile" 1 "the 3 tiles hold 960 of the 40x32 pixels .* a tile is missing" -- \
    "$VBNL" merge-tiles "${T[0]}" "${T[1]}" "${T[3]}" -o m2.exr
expect "merge-tiles refuses overlapping tiles" 1 "both hold pixel" -- "$VBNL" merge-tiles "${T[@]}" t0.exr -o m2.exr
[ ! -e m2.exr ] && ok "a refused merge writes nothing" || not_ok "a refused merge writes nothing"
"$VBNL" render "$SCENE" "${OPTS[@]}" --spp 2 --load-lights "$W/lights/lights.vls" --crop 20,0,40,16 -o spp2.exr
expect "merge-tiles refuses a tile of other options" 1 "has vbnl/spp = 2" -- "$VBNL" merge-tiles "${T[0]}" spp2.exr "${T[2]}" "${T[3]}" -o m2.exr
expect "merge-tiles refuses an output that is a tile" 2 "an output never replaces an input" -- "$VBNL" merge-tiles "${T[@]}" -o "${T[1]}"
expect "merge-lights by hand" 0 "3 files, [0-9]+ virtual lights, photon paths \[0, 50000\) of 50000" -- \
    "$VBNL" merge-lights "$W"/lights/photons-{2,0,1}.vls -o l.vls
cmp -s l.vls "$W/lights/lights.vls" && ok "merge-lights in any order writes the same file" || not_ok "merge-lights in any order writes the same file"
expect "merge-lights refuses a missing photon range" 1 "leave \[[0-9]+, 50000\) of the 50000 paths" -- \
    "$VBNL" merge-lights "$W"/lights/photons-{0,1}.vls -o l2.vls
expect "merge-lights --partial takes one contiguous part" 0 "photon paths \[0, [0-9]+\)" -- \
    "$VBNL" merge-lights --partial "$W"/lights/photons-{0,1}.vls -o l2.vls
# the same box with one more sphere: another scene
{ cat "$SCENE"; echo 'sphere { <0, 0.3, 0>, 0.2 texture { White } }'; } > other.pov
"$VBNL" prepare other.pov "${OPTS[@]}" -o other-place.vls
"$VBNL" photons other.pov "${OPTS[@]}" --placement other-place.vls --part 1/3 -o other-1.vls
if [ -s other-1.vls ]; then
    expect "merge-lights refuses a light file of another scene" 1 "other-1.vls' was prepared for another scene than" -- \
        "$VBNL" merge-lights "$W"/lights/photons-0.vls other-1.vls "$W"/lights/photons-2.vls -o l3.vls
else
    not_ok "a light file of another scene to refuse" "$(ls)"
fi
expect "a render refuses lights prepared for another image size" 1 "was prepared for a 40x32 image, this render is 32x32" -- \
    "$VBNL" render "$SCENE" "${OPTS[@]}" --width 32 --load-lights "$W/lights/lights.vls" -o x.exr
expect "a render refuses lights prepared with another seed" 1 "was prepared with seed 3, this render has seed 5" -- \
    "$VBNL" render "$SCENE" "${OPTS[@]}" --seed 5 --load-lights "$W/lights/lights.vls" -o x.exr
expect "prepare refuses another integrator" 2 "only 'vbnl' prepares virtual lights" -- \
    "$VBNL" prepare "$SCENE" --integrator path -o p.vls
expect "photons refuses a part past the end" 2 "--part takes K/N with 0 <= K < N" -- \
    "$VBNL" photons "$SCENE" "${OPTS[@]}" --placement "$W/lights/placement.vls" --part 3/3 -o p.vls
expect "photons refuses a set that has its photons" 1 "holds photon paths \[0, 50000\) already" -- \
    "$VBNL" photons "$SCENE" "${OPTS[@]}" --placement "$W/lights/lights.vls" --part 0/3 -o p.vls

# The front end: nothing is written or submitted for a scene that cannot be rendered.
printf '#!/bin/sh\ntouch %s/sbatch-called\necho 1\n' "$TMP" > fake-sbatch
chmod +x fake-sbatch
printf 'camera { location 0 look_at z }\nsphere { 0, 1 frobnicate }\n' > bad.pov
expect "farm refuses a scene it cannot load" 3 "bad.pov:2:15: error: unexpected 'frobnicate'" -- \
    "$VBNL" farm bad.pov -o bad.exr --sbatch ./fake-sbatch
expect "farm refuses an unknown parameter" 2 "did you mean 'virtual_lights'" -- \
    "$VBNL" farm "$SCENE" -o bad.exr --set virtual_light=3 --sbatch ./fake-sbatch
expect "farm refuses --crop" 2 "--crop is an option of one render" -- "$VBNL" farm "$SCENE" -o bad.exr --crop 0,0,4,4 --sbatch ./fake-sbatch
expect "farm refuses --time" 2 "--time is an option of one render" -- "$VBNL" farm "$SCENE" -o bad.exr --time 5 --sbatch ./fake-sbatch
expect "farm refuses more tiles than pixels" 2 "does not fit the 40x32 image" -- "$VBNL" farm "$SCENE" "${OPTS[@]}" -o bad.exr --tiles 41x1 --sbatch ./fake-sbatch
expect "farm refuses an unwritable output" 1 "folder does not exist" -- "$VBNL" farm "$SCENE" "${OPTS[@]}" -o no/such/bad.exr --sbatch ./fake-sbatch
[ ! -e sbatch-called ] && [ ! -e bad.farm ] && ok "the refused farms submitted nothing and wrote nothing" ||
    not_ok "the refused farms submitted nothing and wrote nothing" "$(ls)"

# What a submission asks of Slurm: arrays, afterok dependencies that cancel on failure, names and logs.
out=$("$VBNL" farm "$SCENE" "${OPTS[@]}" -o sub.exr --photon-jobs 3 --tiles 4 --name shot --dry-run 2>&1)
lines=$(grep -c "^'sbatch' --parsable --requeue '--job-name=vbnl-shot-" <<<"$out")
if [ "$lines" = 5 ] && grep -q "vbnl-shot-photons' .*--array=0-2 --dependency=afterok:\$prepare --kill-on-invalid-dep=yes" <<<"$out" &&
    grep -q "vbnl-shot-tiles' .*logs/tiles-%A_%a.log' --array=0-3 --dependency=afterok:\$merge-lights" <<<"$out"; then
    ok "dry run: five stages, arrays, afterok dependencies, job names and log files"
else
    not_ok "dry run: five stages, arrays, afterok dependencies, job names and log files" "$out"
fi
expect "a work folder is used once" 2 "holds the farm of an earlier submission" -- "$VBNL" farm "$SCENE" "${OPTS[@]}" -o sub.exr --dry-run

# Animations: every frame is the one `vbnl`'s POV-Ray command line renders (+KFI.. +KFF..), with
# POV-Ray's identifiers: a sphere moves with the clock and grows with the frame number.
{ cat "$SCENE"; echo 'sphere { <-0.6 + clock, 0.3, -0.2>, 0.1 + 0.04 * frame_number texture { White } }'; } > anim.pov
AOPTS=(--width 40 --height 32 --spp 4 --seed 3 --set virtual_lights=2000 --set photon_paths=50000 -q)
"$VBNL" anim.pov +W40 +H32 +KFI2 +KFF4 +KI0.25 +KF1.25 +FE +Opov.exr --spp 4 --seed 3 --set virtual_lights=2000 --set photon_paths=50000 --quiet >/dev/null 2>&1
if out=$("$VBNL" farm anim.pov "${AOPTS[@]}" -o farm.exr --initial-frame 2 --final-frame 4 --initial-clock 0.25 --final-clock 1.25 --photon-jobs 2 --tiles 2 --local 2>&1); then
    for fr in 2 3 4; do
        o=$("$SAME" "pov$fr.exr" "farm$fr.exr" 2>&1) && ok "animation frame $fr: the POV-Ray command line's frame bit for bit" ||
            not_ok "animation frame $fr: the POV-Ray command line's frame bit for bit" "$o"
    done
    o=$("$SAME" pov2.exr pov3.exr 2>&1) && not_ok "the frames differ (the clock reaches the scene)" || ok "the frames differ (the clock reaches the scene)"
else
    not_ok "farm --local of an animation" "$out"
fi
# POV-Ray's clocks, frame numbers and file names (frames 3..12, subset 5..7; cyclic: one frame more)
"$VBNL" farm "$SCENE" "${OPTS[@]}" -o anim.exr --initial-frame 3 --final-frame 12 --subset-start 5 --subset-end 7 --dry-run >/dev/null 2>&1
s=anim.farm/jobs/merge.sh
if grep -q "^frames=(5 6 7)$" "$s" && grep -q "'clock=0.22222222222222221 clock_delta=0.1111111111111111 clock_on=1 frame_number=5 initial_clock=0 final_clock=1 initial_frame=3 final_frame=12'" "$s" &&
    grep -q "^exrs=('$TMP/anim05.exr' '$TMP/anim06.exr' '$TMP/anim07.exr')$" "$s" && [ -d anim.farm/frame05/tiles ]; then
    ok "animation: POV-Ray's identifiers and frame-numbered outputs"
else
    not_ok "animation: POV-Ray's identifiers and frame-numbered outputs" "$(head -20 "$s")"
fi
"$VBNL" farm "$SCENE" "${OPTS[@]}" -o cyc.exr --initial-frame 3 --final-frame 12 --subset-start 11 --cyclic --dry-run >/dev/null 2>&1
if grep -q "^frames=(11 12)$" cyc.farm/jobs/tiles.sh && grep -q "'clock=0.80000000000000004 .* final_frame=13'" cyc.farm/jobs/tiles.sh; then
    ok "cyclic animation: one frame more for the clock"
else
    not_ok "cyclic animation: one frame more for the clock" "$(head -20 cyc.farm/jobs/tiles.sh)"
fi
expect "vbnl render refuses an identifier POV-Ray has not" 2 "--builtin takes NAME=VALUE with NAME one of clock" -- \
    "$VBNL" render anim.pov "${AOPTS[@]}" --builtin clocks=1 -o x.exr
expect "an animation's clock comes from its frame options" 2 "--clock sets a still image's clock" -- \
    "$VBNL" farm "$SCENE" "${OPTS[@]}" -o c.exr --final-frame 3 --clock 0.5 --dry-run

tap_end
