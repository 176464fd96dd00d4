"""A scene of the same cameras at another picture size, for the any-size tests: copies
transforms.json (its w, h, cx, cy set for the new size, the focal lengths scaled by the width)
and points3D.ply from SRC, and writes each frame as a W x H RGB PNG of a smooth pattern that
moves from frame to frame (the pictures need not agree with the geometry: the tests check
that every stage runs and writes frames of that size). No sparse/ folder: transforms.json is
the description. Usage: python3 resize_scene.py SRC DST W H"""
import json, math, os, shutil, struct, sys, zlib


def png(path, w, h, rows):
    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


src, dst, w, h = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
t = json.load(open(os.path.join(src, "transforms.json")))
scale = w / t["w"]
t["fl_x"], t["fl_y"] = t["fl_x"] * scale, t["fl_y"] * scale
t["w"], t["h"], t["cx"], t["cy"] = w, h, w / 2, h / 2
os.makedirs(os.path.join(dst, "images"), exist_ok=True)
shutil.copy(os.path.join(src, "points3D.ply"), dst)
for k, frame in enumerate(t["frames"]):
    rows = [[int(128 + 100 * math.sin(0.3 * x + 0.2 * y + 0.15 * k + c)) for x in range(w) for c in range(3)]
            for y in range(h)]
    png(os.path.join(dst, frame["file_path"]), w, h, rows)
json.dump(t, open(os.path.join(dst, "transforms.json"), "w"), indent=1)
