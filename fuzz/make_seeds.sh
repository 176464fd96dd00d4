#!/bin/bash
# Makes the committed seed corpora of fuzz/corpus/ (small files, a few per reader) from a
# tiny synthesised scene and the files the program writes from it, plus hand-made edge cases:
# ASCII and big-endian PLY, COLMAP binary files, JPEGs (through libjpeg) and safetensors of
# every family of dtype. Run once by hand; the outputs are committed, not rebuilt by the build.
# Usage: bash fuzz/make_seeds.sh /path/to/gaussvid
set -euo pipefail
G=$(realpath "${1:?usage: bash fuzz/make_seeds.sh /path/to/gaussvid}")
ROOT=$(cd "$(dirname "$0")/.." && pwd)
C="$ROOT/fuzz/corpus"
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
cd "$W"
export OMP_NUM_THREADS=1

# A first byte that picks the reader (the harnesses' selector), then the file.
with_byte() { { printf "\\x$(printf %02x "$1")"; cat "$2"; } > "$3"; }
mkdir -p "$C"/{colmap_bin,colmap_text,transforms,ply,image,safetensors,clip,config,manifest,checkpoint,report}

"$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out A --quiet
"$G" scene synth --seed 4 --frames 14 --size 32x32 --samples 1 --out B --quiet
"$G" dataset build --scenes A B --eval-scenes B --intervals 6 --iters 5 --clips-per-run 1 --seed 5 --out D --quiet --threads 1
# A config smaller than the tiny preset keeps the checkpoint seeds near 100 KB.
cp "$ROOT/tests/cli/lib/micro.json" micro.json # the micro network of the tests
"$G" vae train --config micro.json --scenes A --steps 1 --crop 32x32 --stats-clips 1 --out vae.safetensors --quiet
"$G" pretrain --clips D --config micro.json --vae vae.safetensors --steps 1 --batch 1 --seed 1 --out base.safetensors --quiet

# COLMAP text: the scene's files, the points cut to a few.

with_byte 0 A/sparse/0/cameras.txt "$C/colmap_text/cameras"
with_byte 1 A/sparse/0/images.txt "$C/colmap_text/images"
head -n 12 A/sparse/0/points3D.txt > points.txt
with_byte 2 points.txt "$C/colmap_text/points3D"

# COLMAP binary (the format of colmap/src/colmap/scene/reconstruction_io.cc, little-endian).
python3 - "$C/colmap_bin" <<'PY'
import struct, sys
out = sys.argv[1]
def put(name, kind, body):
    open(f"{out}/{name}", "wb").write(bytes([kind]) + body)
# cameras: count, then id, model (1 PINHOLE), width, height, params
put("cameras", 0, struct.pack("<Q", 2) +
    struct.pack("<iiQQ4d", 1, 1, 32, 24, 30.0, 30.0, 16.0, 12.0) +
    struct.pack("<iiQQ3d", 2, 0, 32, 24, 30.0, 16.0, 12.0))
# images: count, then id, qvec, tvec, camera id, name NUL, 2D points count, (x, y, point id)
img = struct.pack("<i4d3di", 1, 1, 0, 0, 0, 0.1, -0.2, 2.0, 1) + b"frame_00000.png\0"
img += struct.pack("<Q", 1) + struct.pack("<ddq", 3.5, 4.5, 7)
img2 = struct.pack("<i4d3di", 2, 0.7071067811865476, 0, 0.7071067811865476, 0, 0, 0, 1, 2) + b"b.png\0" + struct.pack("<Q", 0)
put("images", 1, struct.pack("<Q", 2) + img + img2)
# points3D: count, then id, xyz, rgb, error, track length, (image id, point2D index)
pts = struct.pack("<Q3d3Bd", 7, 0.5, -0.5, 3.0, 200, 100, 50, 0.25) + struct.pack("<Q", 1) + struct.pack("<ii", 1, 0)
pts += struct.pack("<Q3d3Bd", 8, 0, 0, 1, 0, 0, 0, 0) + struct.pack("<Q", 0)
put("points3D", 2, struct.pack("<Q", 2) + pts)
PY

# transforms.json: the scene's own and a NeRF-synthetic style one with camera_angle_x.
cp A/transforms.json "$C/transforms/nerfstudio.json"
cat > "$C/transforms/blender.json" <<'JSON'
{"camera_angle_x": 0.69, "w": 32, "h": 24, "frames": [
 {"file_path": "./train/r_0", "rotation": 0.0, "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},
 {"file_path": "./train/r_1", "fl_x": 30, "fl_y": 31, "cx": 16, "cy": 12, "transform_matrix": [[0,0,1,4],[0,1,0,0],[-1,0,0,0],[0,0,0,1]]}]}
JSON

# PLY: 3DGS models of degree 0 and 1 (first byte 0), point clouds (first byte 1).
python3 - "$C/ply" <<'PY'
import struct, sys
out = sys.argv[1]
def gaussians(n, rest):
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(rest)] + ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    head = "ply\nformat binary_little_endian 1.0\ncomment seed\nelement vertex %d\n" % n
    head += "".join(f"property float {p}\n" for p in names) + "end_header\n"
    body = b""
    for i in range(n):
        v = [0.0] * len(names)
        v[0] = float(i); v[names.index("rot_0")] = 1.0; v[names.index("opacity")] = 0.5
        body += struct.pack("<%df" % len(v), *v)
    return head.encode() + body
open(f"{out}/model_deg0", "wb").write(b"\0" + gaussians(2, 0))
open(f"{out}/model_deg1", "wb").write(b"\0" + gaussians(1, 9))
ascii_ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n" \
    b"property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int vertex_indices\n" \
    b"end_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n"
open(f"{out}/points_ascii", "wb").write(b"\1" + ascii_ply)
head = b"ply\nformat binary_big_endian 1.0\nelement face 1\nproperty list uchar int vertex_indices\nelement vertex 2\n" \
    b"property double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
body = struct.pack(">B3i", 3, 0, 1, 1) + struct.pack(">3d3B", 1, 2, 3, 9, 8, 7) + struct.pack(">3d3B", -1, 0.5, 2, 0, 0, 0)
open(f"{out}/points_be", "wb").write(b"\1" + head + body)
PY
with_byte 1 A/points3D.ply points_full
head -c 600 points_full > "$C/ply/points_synth"   # a cut file: the reader must say truncated

# Images: the scene's PNGs (RGB) and JPEGs written through libjpeg (grey, 4:2:0, progressive).
cp A/images/frame_00000.png "$C/image/rgb.png"
cat > jpeg.c <<'CSRC'
#include <stdio.h>
#include <stdlib.h>
#include <jpeglib.h>
static void put(const char *path, int w, int h, int channels, int progressive, int quality)
{
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr e;
    c.err = jpeg_std_error(&e);
    jpeg_create_compress(&c);
    FILE *f = fopen(path, "wb");
    jpeg_stdio_dest(&c, f);
    c.image_width = w; c.image_height = h; c.input_components = channels;
    c.in_color_space = channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, quality, TRUE);
    if (progressive) jpeg_simple_progression(&c);
    jpeg_start_compress(&c, TRUE);
    unsigned char row[64 * 3];
    while (c.next_scanline < c.image_height) {
        for (int x = 0; x < w * channels; x++) row[x] = (unsigned char)(x * 7 + c.next_scanline * 13);
        JSAMPROW r = row;
        jpeg_write_scanlines(&c, &r, 1);
    }
    jpeg_finish_compress(&c);
    fclose(f);
    jpeg_destroy_compress(&c);
}
int main(int argc, char **argv)
{
    char p[4096];
    snprintf(p, sizeof p, "%s/grey.jpg", argv[1]); put(p, 8, 8, 1, 0, 50);
    snprintf(p, sizeof p, "%s/rgb420.jpg", argv[1]); put(p, 17, 9, 3, 0, 75);
    snprintf(p, sizeof p, "%s/progressive.jpg", argv[1]); put(p, 16, 16, 3, 1, 60);
    return 0;
}
CSRC
cc -O1 -o jpeg jpeg.c -ljpeg && ./jpeg "$C/image"
# A grey+alpha and a palette PNG, written by Python's zlib (the PNG chunks by hand).
python3 - "$C/image" <<'PY'
import struct, sys, zlib
def chunk(kind, data): return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
def png(w, h, depth, ctype, rows, extra=b"", interlace=0):
    raw = b"".join(b"\0" + r for r in rows)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, interlace)) + extra + \
        chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
out = sys.argv[1]
open(f"{out}/grey_alpha.png", "wb").write(png(4, 3, 8, 4, [bytes([x * 60, 255 - x * 60] * 1) * 1 + bytes([1, 2] * 3) for x in range(3)]))
open(f"{out}/palette.png", "wb").write(png(4, 2, 2, 3, [bytes([0b00011011]), bytes([0b11100100])],
    chunk(b"PLTE", bytes([0, 0, 0, 255, 0, 0, 0, 255, 0, 0, 0, 255])) + chunk(b"tRNS", bytes([0, 128]))))
open(f"{out}/rgb16_interlaced.png", "wb").write(png(3, 3, 16, 2, [bytes(range(18)) for _ in range(3)], interlace=1))
PY

# safetensors: every dtype family, metadata, an empty tensor, and the files the program writes.
python3 - "$C/safetensors" <<'PY'
import json, struct, sys
out = sys.argv[1]
def st(tensors, metadata=None):
    header, data = {}, b""
    for name, dtype, shape, raw in tensors:
        header[name] = {"dtype": dtype, "shape": shape, "data_offsets": [len(data), len(data) + len(raw)]}
        data += raw
    if metadata is not None: header["__metadata__"] = metadata
    h = json.dumps(header, separators=(",", ":")).encode()
    h += b" " * (-len(h) % 8)
    return struct.pack("<Q", len(h)) + h + data
open(f"{out}/floats", "wb").write(st([
    ("w.f32", "F32", [2, 2], struct.pack("<4f", 1, -2, 3.5, 0)),
    ("w.f16", "F16", [3], struct.pack("<3H", 0x3c00, 0x7c00, 0x0001)),
    ("w.bf16", "BF16", [1, 2], struct.pack("<2H", 0x3f80, 0xff80)),
    ("w.f64", "F64", [1], struct.pack("<d", 0.1))], {"format": "pt", "note": "seed"}))
open(f"{out}/integers", "wb").write(st([
    ("i64", "I64", [2], struct.pack("<2q", -1, 2**40)), ("u8", "U8", [3], b"abc"),
    ("flag", "BOOL", [2], b"\1\0"), ("empty", "F32", [0, 4], b""), ("scalar", "I32", [], struct.pack("<i", 7))]))
open(f"{out}/packed", "wb").write(st([("fp4", "F4", [4], b"\x12\x34"), ("fp8", "F8_E4M3", [2], b"\x38\xb8")], None))
PY
cp D/clips/*.safetensors "$C/safetensors/clip" 2>/dev/null || true
ls D/clips | head -1 | while read -r f; do with_byte 0 "D/clips/$f" "$C/clip/clip"; with_byte 1 "D/clips/$f" "$C/clip/clip_info"; done
rm -f "$C/safetensors/clip"
ls D/clips | head -1 | while read -r f; do cp "D/clips/$f" "$C/safetensors/clip"; done

# Configs: the micro config as given and as the program writes it (a checkpoint's metadata);
# the manifest and a run record.
python3 - base.safetensors "$C/config" <<'PY'
import json, struct, sys
raw = open(sys.argv[1], "rb").read()
n = struct.unpack("<Q", raw[:8])[0]
config = json.loads(json.loads(raw[8:8 + n])["__metadata__"]["config"])
open(f"{sys.argv[2]}/written.json", "w").write(json.dumps(config, indent=1))
PY
cp micro.json "$C/config/micro.json"
with_byte 0 D/manifest.json "$C/manifest/manifest"
with_byte 2 D/manifest.json "$C/manifest/stats"
ls D/runs | head -1 | while read -r f; do with_byte 1 "D/runs/$f" "$C/manifest/run"; done

# Checkpoints and weights: the pretrained base (info, full load, resume), the VAE, and other
# weights offered as LPIPS weights.
with_byte 0 base.safetensors "$C/checkpoint/base_info"
with_byte 1 base.safetensors "$C/checkpoint/base_load"
with_byte 2 vae.safetensors "$C/checkpoint/vae"
with_byte 3 "$C/safetensors/floats" "$C/checkpoint/lpips_other"  # not LPIPS weights: refused
with_byte 4 base.safetensors "$C/checkpoint/base_resume"
# metrics.json of a reconstruction folder: a held-out and a smooth run (tests/report/make_fixture.sh).
bash "$ROOT/tests/report/make_fixture.sh" "$G" A R 6 5 > /dev/null
cp R/metrics.json "$C/report/held_out.json"
bash "$ROOT/tests/report/make_fixture.sh" "$G" A R 4 5 smooth 4 > /dev/null
cp R/metrics.json "$C/report/both.json"
du -sh "$C"/*
