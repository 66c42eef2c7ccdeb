#!/usr/bin/env bash
# POV-Ray's command line and .ini files in `vbnl` (docs/povray-command-line.md): switches, keys,
# their order, .ini sections and nesting, animation frames and file names, clock values, declared
# constants, library folders, outputs, the console lines and All_File that Blender's POV-Ray
# add-on reads, SIGTERM, bad keys and switches; and the folders `vbnl render` opens to a scene
# (--read-dir, --write-dir). TAP output.
# usage: test_pov_cli.sh VBNL_BINARY SOURCE_DIR
set -u
VBNL=$1
SRC=$2
PNG="python3 $SRC/tests/cli/png_info.py"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
source "$SRC/tests/cli/tap.sh"
# size FILE W H CHANNELS: the PNG's size and channels
size_is() {
    local name=$1 file=$2 want=$3 got
    got=$($PNG "$file" 2>&1 | head -1 | cut -d' ' -f1-3)
    [ "$got" = "$want" ] && ok "$name" || not_ok "$name" "got '$got', want '$want'"
}
FAST="--spp 1 --integrator path"
cd "$TMP" || exit 1

# A scene that reports the clock values it sees and stops unless its declared constants are there.
cat > s.pov <<'POV'
#ifndef (Need) #declare Need = 0; #end
#if (Need > 0 & Need != 2) #error "Need is not 2" #end
#debug concat("clock=", str(clock, 0, 3), " frame=", str(frame_number, 0, 0), " delta=", str(clock_delta, 0, 3),
              " on=", str(clock_on, 0, 0), " first=", str(initial_frame, 0, 0), " last=", str(final_frame, 0, 0), "\n")
camera { location <0, 0, -5> look_at 0 }
light_source { <0, 5, -5> rgb 10 }
sphere { 0, 1 pigment { rgb 0.5 } }
POV

# ---- switches and keys ------------------------------------------------------------------------
expect "switches render a PNG at the named path" 0 "Wrote a.png" -- "$VBNL" +Is.pov +W24 +H16 +Oa.png -D $FAST
size_is "+W +H set the size; RGB without +UA" a.png "24 16 3"
expect "KEY=VALUE on the command line" 0 "" -- "$VBNL" Input_File_Name=s.pov Width=20 Height=10 Output_File_Name=b.png $FAST
size_is "Width and Height" b.png "20 10 3"
expect "a bare .pov file is the scene; the image is named after it, beside it" 0 "Wrote s.png" -- "$VBNL" s.pov +W8 +H8 $FAST
size_is "POV-Ray's default name" s.png "8 8 3"
expect "+UA writes RGBA" 0 "" -- "$VBNL" +Is.pov +W12 +H12 +UA +Orgba.png $FAST
size_is "an RGBA PNG" rgba.png "12 12 4"
expect "+FE writes OpenEXR with the .exr extension" 0 "Wrote e.exr" -- "$VBNL" +Is.pov +W8 +H8 +FE +Oe $FAST
[ "$(head -c 4 e.exr | od -An -tx1 | tr -d ' \n')" = "762f3101" ] && ok "the .exr file is OpenEXR" || not_ok "the .exr file is OpenEXR"
expect "-F renders without writing" 0 "Output file: none" -- "$VBNL" +Is.pov +W8 +H8 -F +Onone.png $FAST
[ ! -e none.png ] && ok "Output_To_File off writes no image" || not_ok "Output_To_File off writes no image"
expect "Output_File_Name without an extension gets .png" 0 "Wrote noext.png" -- "$VBNL" +Is.pov +W8 +H8 +Onoext $FAST
expect "an extension of another case is kept, .png appended" 0 "Wrote UP.PNG.png" -- "$VBNL" +Is.pov +W8 +H8 +OUP.PNG $FAST

# ---- order: left to right, the later setting wins ----------------------------------------------
printf 'Input_File_Name=s.pov\nWidth=32\nHeight=24 ; a comment\nOutput_File_Name=ini.png\n' > size.ini
expect "a switch after the .ini wins" 0 "" -- "$VBNL" size.ini +W20 $FAST
size_is "+W20 after size.ini" ini.png "20 24 3"
expect "the .ini after a switch wins" 0 "" -- "$VBNL" +W20 size.ini $FAST
size_is "size.ini after +W20" ini.png "32 24 3"
printf 'Width=40\n[Small]\nWidth=10\nHeight=6\n[Other]\nWidth=99\n' > sect.ini
expect "a named section is read only when asked for" 0 "" -- "$VBNL" size.ini "sect.ini[Small]" $FAST
size_is "sect.ini[Small]" ini.png "10 6 3"
expect "without a section name, named sections are skipped" 0 "" -- "$VBNL" size.ini sect.ini $FAST
size_is "sect.ini" ini.png "40 24 3"
printf 'Include_Ini=size.ini\n+W16 +H12\n' > outer.ini
expect "Include_Ini and a line of switches" 0 "" -- "$VBNL" outer.ini $FAST
size_is "outer.ini includes size.ini, then +W16 +H12" ini.png "16 12 3"
# Blender's exporter writes quoted paths and %4g fractions
cat > blender.ini <<INI
Version=3.7
All_File=1
Input_File_Name='$TMP/s.pov'
Output_File_Name='$TMP/blender.png'
Width=40
Height=30
Start_Column=   0
End_Column=   1
Start_Row=   0
End_Row=   1
Bounding_Method=2
Display=1
Pause_When_Done=0
Output_File_Type=N
Output_Alpha=1
Antialias=on
Antialias_Depth=3
Antialias_Threshold=0.3
Sampling_Method=1
Antialias_Gamma=2.5
Jitter=off
INI
out=$("$VBNL" blender.ini -d $FAST 2>&1)
rc=$?
[ $rc -eq 0 ] && ok "Blender's .ini renders" || not_ok "Blender's .ini renders" "$out"
size_is "Blender's .ini: a full-size RGBA PNG at the named path" blender.png "40 30 4"
grep -qF "==== [Parsing...] ====" <<<"$out" && grep -qF "==== [Rendering...] ====" <<<"$out" && grep -qE "\(100%\)" <<<"$out" &&
    ok "POV-Ray's console lines: [Parsing...], [Rendering...], (NN%)" || not_ok "POV-Ray's console lines" "$out"
[ "$(grep -c "note: Antialias" <<<"$out")" = 1 ] && grep -q "Antialias, Antialias_Depth, Antialias_Threshold, Sampling_Method, Antialias_Gamma: do not apply" <<<"$out" &&
    ok "keys that do not apply get one note" || not_ok "keys that do not apply get one note" "$out"
grep -q "note: Display: does not apply" <<<"$out" && ! grep -q "Pause_When_Done" <<<"$out" &&
    ok "Display=1 gets a note, Pause_When_Done=0 (what vbnl does anyway) none" || not_ok "Display and Pause_When_Done notes" "$out"
if [ -s alltext.out ] && grep -qF "[Rendering...]" alltext.out && grep -qE "\(100%\)" alltext.out && grep -q "spp in" alltext.out; then
    ok "All_File=1 writes alltext.out beside the image with every message"
else
    not_ok "All_File=1 writes alltext.out beside the image" "$(cat alltext.out 2>&1)"
fi

# ---- the render window --------------------------------------------------------------------------
expect "a render window as fractions" 0 "" -- "$VBNL" +Is.pov +W40 +H20 +SC0.25 +EC0.75 +SR0.5 +ER1.0 +UA +Owin.png $FAST
w=$($PNG win.png 0,0 20,15 2>&1)
if [ "$(sed -n 1p <<<"$w" | cut -d' ' -f1-3)" = "40 20 4" ] && [ "$(sed -n 2p <<<"$w" | cut -d' ' -f4)" = 0 ] &&
    [ "$(sed -n 3p <<<"$w" | cut -d' ' -f4)" = 255 ]; then
    ok "the window renders inside a full-size image, transparent outside"
else
    not_ok "the window renders inside a full-size image, transparent outside" "$w"
fi
expect "a window in pixels (from 1) equals the fractions" 0 "" -- "$VBNL" +Is.pov +W40 +H20 +SC11 +EC30 +SR11 +ER20 +UA +Owin2.png $FAST
cmp -s win.png win2.png && ok "+SC11 +EC30 +SR11 +ER20 is +SC0.25 +EC0.75 +SR0.5 +ER1.0" || not_ok "pixel and fraction windows agree"
expect "a window outside the image is refused" 2 "does not fit the 40x20 image" -- "$VBNL" +Is.pov +W40 +H20 +SC50 $FAST

# ---- animation ------------------------------------------------------------------------------------
out=$("$VBNL" +Is.pov +W8 +H8 +KFI1 +KFF3 +Oanim.png $FAST 2>&1)
[ -s anim1.png ] && [ -s anim2.png ] && [ -s anim3.png ] && ok "frames 1 to 3: anim1.png anim2.png anim3.png" || not_ok "frames 1 to 3" "$out" "$(ls)"
grep -q "clock=0.000 frame=1 delta=0.500 on=1 first=1 last=3" <<<"$out" && grep -q "clock=0.500 frame=2" <<<"$out" &&
    grep -q "clock=1.000 frame=3" <<<"$out" && ok "clock, frame_number, clock_delta, clock_on, initial_frame, final_frame" ||
    not_ok "the animation identifiers" "$out"
out=$("$VBNL" +Is.pov +W8 +H8 +KFF12 +SF11 +EF12 +KI2 +KF13 +Osub $FAST 2>&1)
[ -s sub11.png ] && [ -s sub12.png ] && [ ! -e sub10.png ] && [ ! -e sub01.png ] &&
    ok "a subset of frames, numbered with the last frame's digits" || not_ok "a subset of frames" "$out" "$(ls)"
grep -q "clock=12.000 frame=11 delta=1.000" <<<"$out" && ok "Initial_Clock and Final_Clock spread over the frames" || not_ok "the clock of frame 11" "$out"
printf 'Input_File_Name=s.pov\nOutput_File_Name=cyc\nInitial_Frame=1\nFinal_Frame=9\nCyclic_Animation=on\nFrame_Step=4\nWidth=8\nHeight=8\n' > cyc.ini
out=$("$VBNL" cyc.ini $FAST 2>&1)
[ "$(ls cyc*.png | tr '\n' ' ')" = "cyc01.png cyc05.png cyc09.png " ] && grep -q "clock=0.000 frame=1 delta=0.111" <<<"$out" &&
    ok "Cyclic_Animation counts one frame more (two digits, delta 1/9); Frame_Step 4" || not_ok "cyclic animation" "$out" "$(ls cyc*)"
out=$("$VBNL" +Is.pov +W8 +H8 +K0.25 +Ostill $FAST 2>&1)
[ -s still.png ] && grep -q "clock=0.250 frame=0 delta=0.000 on=1 first=0 last=0" <<<"$out" &&
    ok "a still image with Clock: clock_on, no number in the name" || not_ok "a still image with Clock" "$out"
out=$("$VBNL" +Is.pov +W8 +H8 +Ostill $FAST 2>&1)
grep -q "clock=0.000 frame=0 delta=0.000 on=0" <<<"$out" && ok "without Clock clock_on is 0" || not_ok "without Clock clock_on is 0" "$out"

# ---- declared constants, library folders --------------------------------------------------------
expect "Declare=Need=2 reaches the scene" 0 "" -- "$VBNL" +Is.pov +W8 +H8 Declare=Need=2 $FAST
expect "another value stops the scene" 3 "Need is not 2" -- "$VBNL" +Is.pov +W8 +H8 Declare=Need=3 $FAST
mkdir -p lib
printf '#declare FromLib = 1;\n' > lib/lib.inc
printf '#include "lib.inc"\n#if (FromLib != 1) #error "no lib" #end\ncamera { location -5 look_at 0 } light_source { 5 rgb 1 } sphere { 0, 1 }\n' > inc.pov
expect "without +L the include is not found" 3 "cannot find include file 'lib.inc'" -- "$VBNL" +Iinc.pov +W8 +H8 $FAST
expect "+L adds a library folder" 0 "" -- "$VBNL" +Iinc.pov +W8 +H8 +L"$TMP/lib" $FAST
expect "Library_Path too" 0 "" -- "$VBNL" +Iinc.pov +W8 +H8 Library_Path="$TMP/lib" $FAST

# ---- errors --------------------------------------------------------------------------------------
expect "an unknown key is named" 2 "unknown key 'Widht'" -- "$VBNL" +Is.pov Widht=8
expect "an unknown switch is named" 2 "unknown switch '\+ZZ3'" -- "$VBNL" +Is.pov +ZZ3
printf 'Input_File_Name=s.pov\n\nFrobnicate=1\n' > bad.ini
expect "an unknown key in an .ini names the file and line" 2 "bad.ini:3: unknown key 'Frobnicate'" -- "$VBNL" bad.ini
expect "a bad value is named" 2 "Width takes a whole number, got 'wide'" -- "$VBNL" +Is.pov Width=wide
expect "a bad boolean is named" 2 "Output_Alpha takes on or off" -- "$VBNL" +Is.pov Output_Alpha=maybe
expect "an image type vbnl does not write" 2 "output file type 'T' is not one vbnl writes" -- "$VBNL" +Is.pov +FT
expect "no scene" 2 "no scene: give a .pov file" -- "$VBNL" +W8 +H8
expect "a missing .ini" 2 "cannot open INI file 'nothere.ini'" -- "$VBNL" nothere.ini
mkfifo fifo.ini
expect "a FIFO .ini is refused at once" 2 "cannot open INI file 'fifo.ini': it is a FIFO, not a regular file" -- timeout 20 "$VBNL" fifo.ini
expect "vbnl's options that POV-Ray sets otherwise are refused with the way" 2 "--width: on POV-Ray's command line give \+W or Width" -- "$VBNL" +Is.pov --width 8
expect "an unknown vbnl option" 2 "unknown option '--frobnicate'" -- "$VBNL" +Is.pov --frobnicate
expect "vbnl's options stand among the switches" 0 "" -- "$VBNL" --spp 2 +Is.pov --integrator path +W8 +H8 --seed 3 +Oopt.png
printf 'Output_File_Name=trap.png\n' > trap.png
expect "the image never replaces an .ini file" 2 "is the INI file" -- "$VBNL" +Is.pov ./trap.png $FAST
grep -q "Output_File_Name=trap.png" trap.png && ok "the .ini is untouched" || not_ok "the .ini is untouched"
printf 'camera { location 0 look_at z }\nsphere { 0, 1 frobnicate }\n' > bad.pov
expect "a scene error keeps its file:line:col" 3 "bad.pov:2:15: error: unexpected 'frobnicate' in 'sphere'" -- "$VBNL" +Ibad.pov +W8 +H8

# ---- SIGTERM: the partial image, as Blender's stop button gets it ---------------------------------
"$VBNL" +Is.pov +W64 +H64 +Osig.png --spp 1000000 --integrator path >/dev/null 2>&1 &
pid=$!
sleep 1.5
kill -TERM $pid
wait $pid
rc=$?
[ $rc -eq 130 ] && [ "$($PNG sig.png 2>/dev/null | cut -d' ' -f1-2)" = "64 64" ] && ok "SIGTERM writes the partial image and exits 130" ||
    not_ok "SIGTERM writes the partial image and exits 130" "exit $rc"

# ---- folders opened to a scene (vbnl render and POV-Ray's command line) ----------------------------
mkdir -p scene data out
printf '#declare FromData = 1;\n' > data/d.inc
cat > scene/open.pov <<POV
#include "$TMP/data/d.inc"
camera { location <0, 1, -5> look_at 0 } light_source { 5 rgb 1 } sphere { 0, 1 pigment { rgb 0.5 } } plane { y, -1 pigment { rgb 0.5 } }
#ifdef (vbnl_version) global_settings { integrator { "vbnl" save_lights "$TMP/out/l.vls" virtual_lights 64 photon_paths 1000 } } #end
POV
expect "a scene reads outside its folders only when --read-dir opens one" 3 "is outside the folders a scene may read" -- "$VBNL" render scene/open.pov -o x.exr --spp 1 --width 8 --height 8 -q
expect "a read folder is not a write folder" 3 "is an absolute path: a scene writes inside its own folder" -- "$VBNL" render scene/open.pov -o x.exr --spp 1 --width 8 --height 8 -q --read-dir data --read-dir out
expect "--read-dir and --write-dir open the folders" 0 "" -- "$VBNL" render scene/open.pov -o x.exr --spp 1 --width 8 --height 8 -q --read-dir data --write-dir out
[ -s out/l.vls ] && ok "the scene wrote its lights into the write folder" || not_ok "the scene wrote its lights into the write folder" "$(ls out)"
rm -f out/l.vls
expect "the same among POV-Ray's switches" 0 "" -- "$VBNL" +Iscene/open.pov +W8 +H8 --spp 1 -F --read-dir data --write-dir out
[ -s out/l.vls ] && ok "POV-Ray's command line: the lights in the write folder" || not_ok "POV-Ray's command line: the lights in the write folder"
expect "a folder that does not exist is refused" 2 "read_dir '.*nowhere' is not an existing folder" -- "$VBNL" render scene/open.pov -o x.exr -q --read-dir "$TMP/nowhere"

tap_end
