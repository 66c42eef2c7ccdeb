#!/usr/bin/env python3
"""Writes the McGuire Cornell box with a finely tessellated bumpy sphere added (320K triangles by
default): a benchmark scene where Embree's traversal, not the per-hit work, dominates a ray.

    tools/gen_dense_box.py OUT_DIR [RINGS SEGMENTS]

The box is this repository's examples/mcguire/CornellBox-Original.obj and .mtl (written by
tools/gen_mcguire_boxes.py); OUT_DIR receives CornellBox-Dense.obj and a copy of the .mtl. The
sphere (radius 0.3, 5% bumps) stands on the left of the box's floor with the tall box's white
material; RINGS x SEGMENTS x 2 triangles (default 320 x 500). Then, for instance:

    build/tests/bench_splitting 2e6 1e5 0 3 3 OUT_DIR/CornellBox-Dense.obj camera
"""
import math
import os
import shutil
import sys


def main():
    if len(sys.argv) not in (2, 4):
        sys.exit(__doc__)
    src_dir = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "mcguire")
    out_dir = sys.argv[1]
    try:
        rings, segs = (int(sys.argv[2]), int(sys.argv[3])) if len(sys.argv) == 4 else (320, 500)
    except ValueError:
        sys.exit("gen_dense_box: RINGS and SEGMENTS must be integers, got '%s' '%s'" % (sys.argv[2], sys.argv[3]))
    if rings < 2 or segs < 3:
        sys.exit("gen_dense_box: RINGS >= 2 and SEGMENTS >= 3")
    for name in ("CornellBox-Original.obj", "CornellBox-Original.mtl"):
        if not os.path.isfile(os.path.join(src_dir, name)):
            sys.exit("gen_dense_box: %s: no such file (tools/gen_mcguire_boxes.py writes it)"
                     % os.path.normpath(os.path.join(src_dir, name)))
    with open(os.path.join(src_dir, "CornellBox-Original.obj")) as f:
        src = f.read()
    base = sum(1 for line in src.splitlines() if line.split()[:1] == ["v"])
    out = [src.rstrip("\n"), "o denseSphere", "usemtl tallBox"]
    r0, cx, cy, cz = 0.3, -0.3, 0.45, 0.3
    for j in range(rings + 1):
        th = math.pi * j / rings
        for i in range(segs):
            ph = 2.0 * math.pi * i / segs
            r = r0 * (1.0 + 0.05 * math.sin(7.0 * th) * math.cos(9.0 * ph))
            out.append("v %.6f %.6f %.6f" % (cx + r * math.sin(th) * math.cos(ph), cy + r * math.cos(th),
                                             cz + r * math.sin(th) * math.sin(ph)))
    for j in range(rings):
        for i in range(segs):
            a = base + 1 + j * segs + i
            b = base + 1 + j * segs + (i + 1) % segs
            out.append("f %d %d %d" % (a, a + segs, b))
            out.append("f %d %d %d" % (b, a + segs, b + segs))
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "CornellBox-Dense.obj"), "w") as f:
        f.write("\n".join(out) + "\n")
    shutil.copy(os.path.join(src_dir, "CornellBox-Original.mtl"), out_dir)
    print("%s: %d triangles added" % (os.path.join(out_dir, "CornellBox-Dense.obj"), 2 * rings * segs))


if __name__ == "__main__":
    main()
