"""Test helper (tests/cli/adapt.sh): rewrites a safetensors file's header.
  pad_checkpoint.py pad IN OUT BYTES   OUT = IN with one more U8 tensor of BYTES zero bytes at
                                       the end of the data, written sparse (no disk for it)
  pad_checkpoint.py meta IN OUT K=V... OUT = IN with metadata keys set"""
import json
import struct
import sys


def read(path):
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        return json.loads(f.read(n)), f.read()


def write(path, header, data, extra=0):
    text = json.dumps(header, separators=(",", ":")).encode()
    text += b" " * ((8 - len(text) % 8) % 8)
    with open(path, "wb") as f:
        f.write(struct.pack("<Q", len(text)) + text + data)
        f.truncate(8 + len(text) + len(data) + extra)


def main():
    what, src, out = sys.argv[1:4]
    header, data = read(src)
    if what == "pad":
        extra = int(sys.argv[4])
        header["zz_padding"] = {"dtype": "U8", "shape": [extra], "data_offsets": [len(data), len(data) + extra]}
        write(out, header, data, extra)
    else:
        for pair in sys.argv[4:]:
            key, value = pair.split("=", 1)
            header["__metadata__"][key] = value
        write(out, header, data)


main()
