"""What padding to the restorer's block does to a restoration (docs/RESULTS.md, issue 41):
crops clips to a size off the block, and compares their restoration with that of the
uncropped clips on the pixels both have.

  python3 scripts/pad_effect.py crop SRC_DIR DST_DIR W H
      every SRC_DIR/*.safetensors clip cut to its top-left W x H (frames, targets, coverage
      plane; cameras unchanged, as the pixels keep their coordinates) into DST_DIR
  python3 scripts/pad_effect.py compare FULL_DIR ODD_DIR
      FULL_DIR, ODD_DIR: `gaussvid restore --save-clips` outputs of the two; for the three
      restored frames of each clip: PSNR of the odd restoration against the full one cropped,
      on all pixels, on the band of 16 pixels along the right and bottom edges (beside the
      padding) and on the rest; and each one's PSNR against the ground truth there.
Pure Python (no numpy): clip files are safetensors with U8 inputs/targets [5, H, W, 3] and
coverage [3, H, W] (docs/FORMATS-DATASET.md)."""
import glob, json, math, os, struct, sys


def read(path):
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(n))
        data = f.read()
    return header, data


def tensor(header, data, name):
    a, b = header[name]["data_offsets"]
    return header[name]["shape"], data[a:b]


def crop_rows(buf, frames, h, w, c, H, W):
    out = bytearray()
    for f in range(frames):
        for y in range(H):
            at = ((f * h + y) * w) * c
            out += buf[at:at + W * c]
    return bytes(out)


def crop(src, dst, W, H):
    os.makedirs(dst, exist_ok=True)
    for path in sorted(glob.glob(os.path.join(src, "*.safetensors"))):
        header, data = read(path)
        meta = header.pop("__metadata__")
        h, w = int(meta["height"]), int(meta["width"])
        meta["width"], meta["height"] = str(W), str(H)
        blobs, out = [], {"__metadata__": meta}
        at = 0
        for name in sorted(header, key=lambda k: header[k]["data_offsets"][0]):
            shape, buf = tensor(header, data, name)
            if name in ("inputs", "targets"):
                buf, shape = crop_rows(buf, shape[0], h, w, 3, H, W), [shape[0], H, W, 3]
            elif name == "coverage":
                buf, shape = crop_rows(buf, shape[0], h, w, 1, H, W), [shape[0], H, W]
            out[name] = {"dtype": header[name]["dtype"], "shape": shape, "data_offsets": [at, at + len(buf)]}
            blobs.append(buf)
            at += len(buf)
        text = json.dumps(out, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 8)
        with open(os.path.join(dst, os.path.basename(path)), "wb") as f:
            f.write(struct.pack("<Q", len(text)) + text + b"".join(blobs))


def psnr(sq, n):
    return float("inf") if sq == 0 else 10 * math.log10(255.0 ** 2 * n / sq)


def compare(full_dir, odd_dir):
    acc = {k: [0, 0] for k in ("odd-full all", "odd-full band", "odd-full rest",
                                "full-gt band", "odd-gt band", "full-gt rest", "odd-gt rest")}
    clips = 0
    for path in sorted(glob.glob(os.path.join(odd_dir, "*.safetensors"))):
        ho, do = read(path)
        hf, df = read(os.path.join(full_dir, os.path.basename(path)))
        H, W = int(ho["__metadata__"]["height"]), int(ho["__metadata__"]["width"])
        h, w = int(hf["__metadata__"]["height"]), int(hf["__metadata__"]["width"])
        odd = tensor(ho, do, "inputs")[1]
        full = crop_rows(tensor(hf, df, "inputs")[1], 5, h, w, 3, H, W)
        gt = tensor(ho, do, "targets")[1]
        for f in (1, 2, 3):
            for y in range(H):
                for x in range(W):
                    band = x >= W - 16 or y >= H - 16
                    for c in range(3):
                        i = ((f * H + y) * W + x) * 3 + c
                        d, a, b = odd[i] - full[i], full[i] - gt[i], odd[i] - gt[i]
                        where = "band" if band else "rest"
                        for key, v in (("odd-full all", d), ("odd-full " + where, d), ("full-gt " + where, a),
                                       ("odd-gt " + where, b)):
                            acc[key][0] += v * v
                            acc[key][1] += 1
        clips += 1
    print("%d clips, %dx%d of %dx%d, frames 1-3" % (clips, W, H, w, h))
    for k, (sq, n) in acc.items():
        print("%-14s PSNR %6.2f dB over %d values" % (k, psnr(sq, n), n))


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "crop":
        crop(sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]))
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        compare(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
