#!/usr/bin/env python3
"""Runs the commands of the README (its ```sh blocks) at tiny sizes, as a TAP test.

Usage: test_readme.py VBNL_EXECUTABLE SOURCE_DIR

Every `vbnl ...` line (continuation lines joined, comments dropped) runs with the build's
executable in an empty temporary folder that links examples/ and tests/ of the repository, so the
README's relative paths work and its outputs land in the folder; it must exit 0 and leave the
files it names (-o, --png, --out). Sizes are made tiny, nothing else: images 16x16, --spp 2,
--time 1, virtual_lights 300 and photon_paths 20000 where set, and `bench --equal-time` on one
8x8 scene (cornell) with 0.2 s budgets and 2-spp references. Stand-ins: `scene.pov` (the README's
name for any scene, also as +Iscene.pov) is examples/cornell-box.pov, POV-Ray's +W and +H sizes
16; an image a compare line reads that no line makes
(b.exr) is a copy of the first one it reads after the reference.

Not run: `bash tools/quickstart.sh` (installs packages, then a 15 s render) and
`bash tools/test.sh` (the suite that runs this test); both must exist and parse (bash -n).
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile

TINY = {"--width": "16", "--height": "16", "--spp": "2", "--time": "1"}
TINY_SETS = {"virtual_lights": "300", "photon_paths": "20000"}
STAND_INS = {"scene.pov": "examples/cornell-box.pov"}
NOT_RUN = {"tools/quickstart.sh", "tools/test.sh"}


def commands(readme):
    """The lines of the ```sh blocks, continuations joined, comments and blanks dropped."""
    out, block, pending = [], False, ""
    for line in open(readme, encoding="utf-8"):
        line = line.rstrip("\n")
        if line.startswith("```"):
            block = line.strip() == "```sh"
            continue
        if not block:
            continue
        line = pending + line
        if line.endswith("\\"):
            pending = line[:-1] + " "
            continue
        pending = ""
        words = shlex.split(line, comments=True)
        if words:
            out.append(words)
    return out


def tiny(words):
    """The command with tiny sizes (see the module's doc)."""
    w = [STAND_INS.get(x, x) for x in words]
    # POV-Ray's switches: +Iscene.pov takes the stand-in, +W/+H the tiny size
    w = ["+I" + STAND_INS.get(x[2:], x[2:]) if x.startswith("+I") else
         "+W" + TINY["--width"] if re.fullmatch(r"\+W\d+", x) else
         "+H" + TINY["--height"] if re.fullmatch(r"\+H\d+", x) else x for x in w]
    i = 0
    while i < len(w):
        if w[i] in TINY and i + 1 < len(w):
            w[i + 1] = TINY[w[i]]
        elif w[i] == "--set" and i + 1 < len(w):
            key = w[i + 1].split("=", 1)[0]
            if key in TINY_SETS:
                w[i + 1] = key + "=" + TINY_SETS[key]
        i += 1
    if w[1] == "render":
        for opt in ("--width", "--height"):
            if opt not in w:
                w += [opt, TINY[opt]]
        w.append("--quiet")
    if w[1] == "bench" and "--equal-time" in w:
        for opt, value in (("--size", "8"), ("--budgets", "0.2"), ("--ref-spp", "2"), ("--only", "cornell"),
                           ("--repeat", "1")):
            if opt in w:
                k = w.index(opt)
                w[k + 1] = value
            else:
                w += [opt, value]
        if "--ref-time" in w:
            k = w.index("--ref-time")
            del w[k:k + 2]
    return w


def outputs(words):
    names = []
    for opt in ("-o", "--png", "--out"):
        if opt in words:
            names.append(words[words.index(opt) + 1])
    return names


def main():
    vbnl, src = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    cmds = commands(os.path.join(src, "README.md"))
    print("TAP version 13")
    print("1..%d" % len(cmds))
    failed = 0
    work = tempfile.mkdtemp(prefix="vbnl-readme-")
    try:
        for sub in ("examples", "tests"):
            os.symlink(os.path.join(src, sub), os.path.join(work, sub))
        for n, words in enumerate(cmds, 1):
            text = " ".join(words)
            if words[0] == "bash" and len(words) > 1 and words[1] in NOT_RUN:
                ok = subprocess.run(["bash", "-n", os.path.join(src, words[1])]).returncode == 0
                print("%s %d - %s (not run: parses)" % ("ok" if ok else "not ok", n, text))
                failed += not ok
                continue
            if words[0] != "vbnl":
                print("not ok %d - %s (not a vbnl command: add it to the test)" % (n, text))
                failed += 1
                continue
            w = tiny(words)
            if w[1] == "compare":
                reads = [x for x in w[2:] if x.endswith(".exr")]
                for name in reads[2:]:
                    if not os.path.exists(os.path.join(work, name)):
                        shutil.copy(os.path.join(work, reads[1]), os.path.join(work, name))
            r = subprocess.run([vbnl] + w[1:], cwd=work, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True, timeout=600)
            missing = [o for o in outputs(w) if not os.path.exists(os.path.join(work, o))]
            ok = r.returncode == 0 and not missing
            print("%s %d - %s" % ("ok" if ok else "not ok", n, text))
            if not ok:
                failed += 1
                print("# ran: vbnl %s" % " ".join(w[1:]))
                print("# exit %d, missing outputs: %s" % (r.returncode, missing))
                for line in r.stdout.splitlines()[-15:]:
                    print("#   " + line)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
