#!/usr/bin/env python3
"""Prints the attributes of an OpenEXR file's header as name=value lines (test helper)."""
import struct
import sys


def read_cstr(f):
    out = b""
    while True:
        c = f.read(1)
        if c in (b"", b"\0"):
            return out.decode()
        out += c


def main(path):
    with open(path, "rb") as f:
        magic, version = struct.unpack("<ii", f.read(8))
        if magic != 20000630:
            sys.exit("not an EXR file")
        while True:
            name = read_cstr(f)
            if not name:
                break
            kind = read_cstr(f)
            size = struct.unpack("<i", f.read(4))[0]
            data = f.read(size)
            if kind == "string":
                value = data.decode()
            elif kind == "int":
                value = struct.unpack("<i", data)[0]
            elif kind == "double":
                value = struct.unpack("<d", data)[0]
            elif kind == "float":
                value = struct.unpack("<f", data)[0]
            elif kind == "chlist":
                value = ",".join(n.decode() for n in data.split(b"\0")[::1] if n and n.isascii() and n[:1].isalpha())
            else:
                value = "<%s>" % kind
            print("%s=%s" % (name, value))


if __name__ == "__main__":
    main(sys.argv[1])
