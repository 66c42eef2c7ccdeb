#!/usr/bin/env python3
"""Writes examples/door-ajar.obj/.mtl: two rooms joined by a door left ajar; the light is in the
far room and reaches the camera's room only through the gap."""
import math
import os

OPEN_DEGREES = 20.0
V, F = [], []


def quad(p, mat):
    b = len(V) + 1
    V.extend(p)
    F.append((mat, [b, b + 1, b + 2, b + 3]))


def box(x0, x1, y0, y1, z0, z1, mat, rot=None):
    c = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
    if rot:
        px, pz, a = rot
        ca, sa = math.cos(a), math.sin(a)
        c = [(px + (x - px) * ca - (z - pz) * sa, y, pz + (x - px) * sa + (z - pz) * ca) for x, y, z in c]
    i = lambda a, b, cc: c[a * 4 + b * 2 + cc]
    for f in [(i(0, 0, 0), i(0, 0, 1), i(0, 1, 1), i(0, 1, 0)), (i(1, 0, 0), i(1, 1, 0), i(1, 1, 1), i(1, 0, 1)),
              (i(0, 0, 0), i(1, 0, 0), i(1, 0, 1), i(0, 0, 1)), (i(0, 1, 0), i(0, 1, 1), i(1, 1, 1), i(1, 1, 0)),
              (i(0, 0, 0), i(0, 1, 0), i(1, 1, 0), i(1, 0, 0)), (i(0, 0, 1), i(1, 0, 1), i(1, 1, 1), i(0, 1, 1))]:
        quad(list(f), mat)


H = 2.5
quad([(-3, 0, -2), (4, 0, -2), (4, 0, 2), (-3, 0, 2)], 'floor')
quad([(-3, H, -2), (-3, H, 2), (4, H, 2), (4, H, -2)], 'white')
quad([(-3, 0, -2), (-3, H, -2), (4, H, -2), (4, 0, -2)], 'white')
quad([(-3, 0, 2), (4, 0, 2), (4, H, 2), (-3, H, 2)], 'white')
quad([(-3, 0, -2), (-3, 0, 2), (-3, H, 2), (-3, H, -2)], 'white')
quad([(4, 0, -2), (4, H, -2), (4, H, 2), (4, 0, 2)], 'white')
box(0, 0.1, 0, H, -2, -0.5, 'white')
box(0, 0.1, 0, H, 0.5, 2, 'white')
box(0, 0.1, 2.0, H, -0.5, 0.5, 'white')
box(-0.05, 0.0, 0.0, 1.98, -0.5, 0.49, 'door', rot=(0.0, -0.5, math.radians(-OPEN_DEGREES)))
quad([(-2.2, H - 0.01, -0.6), (-0.8, H - 0.01, -0.6), (-0.8, H - 0.01, 0.6), (-2.2, H - 0.01, 0.6)], 'light')

here = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'examples')
with open(os.path.join(here, 'door-ajar.obj'), 'w') as f:
    f.write('# Two rooms joined by a door left ajar: the light is in the far room and reaches the\n'
            "# camera's room only through the gap (Veach's door). Written for vbnl by tools/gen_door_ajar.py; CC0.\n"
            '# Camera: --camera 3.6,1.3,1.6,0,1,-0.2,60\nmtllib door-ajar.mtl\n')
    for v in V:
        f.write('v %.5f %.5f %.5f\n' % v)
    cur = None
    for m, idx in F:
        if m != cur:
            f.write('usemtl %s\n' % m)
            cur = m
        f.write('f %s\n' % ' '.join(map(str, idx)))
with open(os.path.join(here, 'door-ajar.mtl'), 'w') as f:
    f.write('# door-ajar materials. Written for vbnl; CC0.\n'
            'newmtl white\nKd 0.7 0.7 0.7\nillum 2\n'
            'newmtl floor\nKd 0.55 0.45 0.35\nKs 0.3 0.3 0.3\nNs 200\nNi 1.5\nillum 2\n'
            'newmtl door\nKd 0.45 0.3 0.2\nillum 2\n'
            'newmtl light\nKd 0 0 0\nKe 40 38 34\nillum 2\n')
