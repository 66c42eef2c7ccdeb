#!/usr/bin/env python3
"""Facts about an 8-bit PNG for the command-line tests, in Python's standard library alone.

usage: png_info.py FILE [X,Y ...]
prints "WIDTH HEIGHT CHANNELS MEAN" (MEAN: the mean of the colour channels in [0, 1], as stored)
and then, for each X,Y, the pixel's channel values (0..255) separated by spaces."""
import struct
import sys
import zlib


def read_png(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG file")
    pos, idat = 8, b""
    width = height = depth = ctype = None
    while pos < len(data):
        n = struct.unpack(">I", data[pos:pos + 4])[0]
        kind, chunk = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            width, height, depth, ctype = struct.unpack(">IIBB", chunk[:10])
        elif kind == b"IDAT":
            idat += chunk
    if depth != 8:
        raise SystemExit(f"{path}: {depth}-bit PNG (this reader takes 8 bits)")
    ch = {0: 1, 2: 3, 4: 2, 6: 4}[ctype]
    raw, stride, rows, prev, p = zlib.decompress(idat), width * ch, [], bytearray(width * ch), 0
    for _ in range(height):
        f, line = raw[p], bytearray(raw[p + 1:p + 1 + stride])
        p += 1 + stride
        for i in range(stride):
            a = line[i - ch] if i >= ch else 0
            b = prev[i]
            c = prev[i - ch] if i >= ch else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append(line)
        prev = line
    return width, height, ch, rows


def main():
    width, height, ch, rows = read_png(sys.argv[1])
    colour = min(ch, 3)
    total = sum(rows[y][x * ch + c] for y in range(height) for x in range(width) for c in range(colour))
    print(width, height, ch, f"{total / (255.0 * width * height * colour):.5f}")
    for xy in sys.argv[2:]:
        x, y = (int(v) for v in xy.split(","))
        print(" ".join(str(rows[y][x * ch + c]) for c in range(ch)))


if __name__ == "__main__":
    main()
