#!/usr/bin/env python3
"""Copies a dataset folder with its clips' coverage planes removed: the clips as they were
before the plane existed (tests/cli/coverage_mask.sh). Prints how many clips had a plane.
Standard library only: a safetensors file is 8 bytes of header length, the JSON header, data.
Usage: strip_coverage.py SRC_DATASET DST_DATASET"""
import json, os, shutil, struct, sys

src, dst = sys.argv[1], sys.argv[2]
shutil.copytree(src, dst, ignore=shutil.ignore_patterns('latents_*', 'clips'))
os.makedirs(os.path.join(dst, 'clips'))
had = 0
for name in sorted(os.listdir(os.path.join(src, 'clips'))):
    with open(os.path.join(src, 'clips', name), 'rb') as f:
        n = struct.unpack('<Q', f.read(8))[0]
        header = json.loads(f.read(n))
        data = f.read()
    had += 'coverage' in header
    header.pop('coverage', None)
    out, parts = {}, []
    offset = 0
    for key, t in header.items():
        if key == '__metadata__':
            out[key] = t
            continue
        blob = data[t['data_offsets'][0]:t['data_offsets'][1]]
        out[key] = dict(t, data_offsets=[offset, offset + len(blob)])
        parts.append(blob)
        offset += len(blob)
    text = json.dumps(out, separators=(',', ':')).encode()
    text += b' ' * (-len(text) % 8)
    with open(os.path.join(dst, 'clips', name), 'wb') as f:
        f.write(struct.pack('<Q', len(text)) + text + b''.join(parts))
print(had)
