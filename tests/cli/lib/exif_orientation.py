#!/usr/bin/env python3
"""Sets the EXIF orientation tag of JPEG files, as a phone writes it: an APP1 "Exif" segment
right after the SOI marker holding a TIFF header and one IFD entry (tag 0x0112, SHORT, count 1).
Any APP1 Exif segment already there is replaced. Big-endian ("MM", as iPhones write) unless
--little ("II", as many Android phones write).
Usage: exif_orientation.py [--little] ORIENTATION FILE.jpg...   (ORIENTATION 1..8)"""
import struct
import sys


def exif_segment(orientation, little):
    e = "<" if little else ">"
    tiff = (b"II" if little else b"MM") + struct.pack(e + "HI", 42, 8)
    # one entry: tag, type 3 (SHORT), count 1, the value left-justified in the 4-byte field
    ifd = struct.pack(e + "H", 1) + struct.pack(e + "HHIHH", 0x0112, 3, 1, orientation, 0) + struct.pack(e + "I", 0)
    body = b"Exif\0\0" + tiff + ifd
    return b"\xff\xe1" + struct.pack(">H", len(body) + 2) + body


def strip_exif(data):
    """The bytes after SOI with any leading APP1 Exif segments removed."""
    pos = 2
    while data[pos:pos + 2] == b"\xff\xe1" and data[pos + 4:pos + 10] == b"Exif\0\0":
        pos += 2 + struct.unpack(">H", data[pos + 2:pos + 4])[0]
    return data[pos:]


def main():
    args = sys.argv[1:]
    little = args and args[0] == "--little"
    if little:
        args = args[1:]
    if len(args) < 2 or not args[0].isdigit() or not 1 <= int(args[0]) <= 8:
        sys.exit(__doc__)
    for path in args[1:]:
        with open(path, "rb") as f:
            data = f.read()
        if data[:2] != b"\xff\xd8":
            sys.exit(f"{path}: not a JPEG")
        with open(path, "wb") as f:
            f.write(b"\xff\xd8" + exif_segment(int(args[0]), little) + strip_exif(data))


main()
