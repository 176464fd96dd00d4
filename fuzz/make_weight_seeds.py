#!/usr/bin/env python3
"""Makes the committed seeds of fuzz/corpus/pth and fuzz/corpus/st_index (the readers of the
published weights, docs/PTH.md and docs/SAFETENSORS.md) from the release fixtures, with the
fixture script's own writers (scripts/make_release_fixtures.py: its stand-in torch pickler,
its zip layout, its safetensors and shard writers). Run once by hand; outputs committed.

    python3 fuzz/make_weight_seeds.py

Tensors: the smallest ones of the fixtures (tests/fixtures/release), names and values as
there, so the seeds stay a few kB each. The harnesses' input layouts (fuzz_pth.c,
fuzz_st_index.c): a first byte that picks how a .pth is made (0 the file itself; 1, 2, 3
data.pkl and the storages separated by #PIECE#, packed stored, aligned, deflated), and an
index followed by its shards separated by #PIECE#.
"""
import collections
import io
import json
import os
import pickle
import struct
import sys
import tempfile
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import make_release_fixtures as fx  # noqa: E402

FIXTURES = os.path.join(ROOT, "tests", "fixtures", "release")
PIECE = b"#PIECE#"


def safetensors_tensors(path):
    """(name, shape, float values) of an F32 or BF16 safetensors file."""
    raw = open(path, "rb").read()
    n = struct.unpack("<Q", raw[:8])[0]
    header, data = json.loads(raw[8:8 + n]), raw[8 + n:]
    out = []
    for name, t in header.items():
        if name == "__metadata__":
            continue
        lo, hi = t["data_offsets"]
        if t["dtype"] == "F32":
            vals = list(struct.unpack(f"<{(hi - lo) // 4}f", data[lo:hi]))
        else:
            vals = [struct.unpack("<f", struct.pack("<I", h << 16))[0]
                    for h in struct.unpack(f"<{(hi - lo) // 2}H", data[lo:hi])]
        out.append((name, t["shape"], vals))
    return out


def smallest(tensors, k):
    return sorted(tensors, key=lambda t: (len(t[2]), t[0]))[:k]


def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fx.write_atomic(path, data)


# ---- .pth ---------------------------------------------------------------------------------

class View(fx.Tensor):
    """A tensor with its own offset and strides (a view of a shared storage)."""

    def __init__(self, storage, shape, stride, offset=0):
        super().__init__(storage, shape)
        self.stride, self.offset = tuple(stride), offset

    def __reduce_ex__(self, protocol):
        rebuild = sys.modules["torch._utils"]._rebuild_tensor_v2
        return rebuild, (self.storage, self.offset, self.shape, self.stride, False, collections.OrderedDict())


class Parameter:
    """Pickles as torch.nn.Parameter does: _rebuild_parameter(tensor, requires_grad, hooks)."""

    def __init__(self, tensor):
        self.tensor = tensor

    def __reduce_ex__(self, protocol):
        return sys.modules["torch._utils"]._rebuild_parameter, (self.tensor, True, collections.OrderedDict())


def stand_in_torch():
    """The fixture script's stand-in modules, plus every storage class and _rebuild_parameter."""
    torch = fx.stand_in_torch()
    for storage in ("DoubleStorage", "HalfStorage", "LongStorage", "IntStorage", "ShortStorage", "CharStorage",
                    "ByteStorage", "BoolStorage"):
        setattr(torch, storage, type(storage, (), {"__module__": "torch"}))

    def _rebuild_parameter(*args):
        raise RuntimeError("a stand-in: the seeds are only written")

    _rebuild_parameter.__module__, _rebuild_parameter.__qualname__ = "torch._utils", "_rebuild_parameter"
    torch._utils._rebuild_parameter = _rebuild_parameter
    return torch


class Storage(fx.Storage):
    def __init__(self, key, raw, kind, size):
        super().__init__(key, raw)
        self.kind, self.size = kind, size


def pickle_with(torch, state, protocol):
    class Pickler(pickle.Pickler):
        def persistent_id(self, obj):
            if isinstance(obj, Storage):
                return ("storage", getattr(torch, obj.kind), obj.key, "cpu", len(obj.raw) // obj.size)
            return None

    buf = io.BytesIO()
    Pickler(buf, protocol=protocol).dump(state)
    return buf.getvalue()


def state_dicts(torch, vae):
    """(seed name, data.pkl, storages) of a few state dicts: F32 VAE tensors as torch.save
    writes them (protocol 2 and 4), every other dtype, and views, offsets and a parameter."""
    out = []
    storages = [Storage(str(i), fx.f32_bytes(v), "FloatStorage", 4) for i, (_, _, v) in enumerate(vae)]
    state = collections.OrderedDict((name, fx.Tensor(storages[i], shape)) for i, (name, shape, _) in enumerate(vae))
    state._metadata = collections.OrderedDict([("", {"version": 1})])
    for protocol in (2, 4):
        out.append((f"vae-f32-p{protocol}", pickle_with(torch, state, protocol), storages))
    values = [v for _, _, vals in vae for v in vals][:6]  # the smallest tensors hold fewer
    kinds = [("HalfStorage", 2, lambda v: struct.pack(f"<{len(v)}e", *v)),
             ("BFloat16Storage", 2, fx.bf16_bytes),
             ("DoubleStorage", 8, lambda v: struct.pack(f"<{len(v)}d", *v)),
             ("LongStorage", 8, lambda v: struct.pack(f"<{len(v)}q", *range(len(v)))),
             ("IntStorage", 4, lambda v: struct.pack(f"<{len(v)}i", *range(len(v)))),
             ("ShortStorage", 2, lambda v: struct.pack(f"<{len(v)}h", *range(len(v)))),
             ("CharStorage", 1, lambda v: bytes(range(len(v)))),
             ("ByteStorage", 1, lambda v: bytes(range(len(v)))),
             ("BoolStorage", 1, lambda v: bytes([1, 0] * (len(v) // 2)))]
    storages = [Storage(str(i), pack(values), kind, size) for i, (kind, size, pack) in enumerate(kinds)]
    state = collections.OrderedDict((f"t.{kind}", fx.Tensor(s, [2, 3])) for s, (kind, _, _) in zip(storages, kinds))
    out.append(("dtypes-p2", pickle_with(torch, state, 2), storages))
    shared = Storage("0", fx.f32_bytes(values), "FloatStorage", 4)
    state = collections.OrderedDict([
        ("whole", fx.Tensor(shared, [2, 3])),
        ("transposed", View(shared, [3, 2], [1, 3])),
        ("row", View(shared, [3], [1], offset=3)),
        ("broadcast", View(shared, [4, 3], [0, 1])),
        ("empty", View(shared, [0, 3], [3, 1])),
        ("weight", Parameter(fx.Tensor(shared, [6]))),
    ])
    out.append(("views-p4", pickle_with(torch, state, 4), [shared]))
    return out


def records_of(archive, pkl, storages):
    records = [(f"{archive}/data.pkl", pkl), (f"{archive}/byteorder", b"little")]
    records += [(f"{archive}/data/{s.key}", s.raw) for s in sorted(storages, key=lambda s: s.key)]
    return records + [(f"{archive}/version", b"3\n")]


def zip64_records(records):
    """A stored zip whose central records and end record are all in their ZIP64 forms
    (sizes and offsets 0xffffffff, the values in extra field 1), as for files past 4 GiB."""
    out, central = bytearray(), bytearray()
    for name, data in records:
        name_b, crc, offset = name.encode(), zlib.crc32(data), len(out)
        out += struct.pack("<IHHHHHIIIHH", 0x04034B50, 45, 0, 0, 0, 0, crc, len(data), len(data), len(name_b), 0)
        out += name_b + data
        extra = struct.pack("<HHQQQ", 1, 24, len(data), len(data), offset)
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 45, 45, 0, 0, 0, 0, crc, 0xFFFFFFFF, 0xFFFFFFFF,
                               len(name_b), len(extra), 0, 0, 0, 0, 0xFFFFFFFF) + name_b + extra
    directory = len(out)
    out += central
    zip64_end = len(out)
    out += struct.pack("<IQHHIIQQQQ", 0x06064B50, 44, 45, 45, 0, 0, len(records), len(records), len(central),
                       directory)
    out += struct.pack("<IIQI", 0x07064B50, 0, zip64_end, 1)
    out += struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, 0xFFFF, 0xFFFF, 0xFFFFFFFF, 0xFFFFFFFF, 0)
    return bytes(out)


def deflated_records(records):
    """The same entries deflated, as another zip tool would re-pack a checkpoint."""
    import zipfile
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in records:
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, data)
    return buf.getvalue()


def pth_seeds(out):
    torch = stand_in_torch()
    vae = smallest(safetensors_tensors(os.path.join(FIXTURES, "tiny_vae_f32.safetensors")), 4)
    t5 = open(os.path.join(FIXTURES, "tiny-vace-bf16", "models_t5_umt5-xxl-enc-bf16.pth"), "rb").read()
    write(os.path.join(out, "umt5-bf16-fixture"), b"\0" + t5)  # the fixture itself, 18 kB
    for name, pkl, storages in state_dicts(torch, vae):
        records = records_of("archive", pkl, storages)
        if name == "vae-f32-p2":
            write(os.path.join(out, "file-stored-aligned"), b"\0" + fx.zip_records(records))
            write(os.path.join(out, "file-deflated"), b"\0" + deflated_records(records))
            write(os.path.join(out, "file-zip64"), b"\0" + zip64_records(records))
        pieces = PIECE.join([pkl] + [s.raw for s in sorted(storages, key=lambda s: int(s.key))])
        for mode in (1, 2, 3):
            if mode == 1 or name in ("vae-f32-p2", "views-p4"):
                write(os.path.join(out, f"pickle-{name}-mode{mode}"), bytes([mode]) + pieces)


# ---- sharded safetensors ------------------------------------------------------------------

def shard_seeds(out):
    dit = smallest(safetensors_tensors(os.path.join(FIXTURES, "tiny_dit_f32.safetensors")), 6)
    with tempfile.TemporaryDirectory() as d:
        fx.write_shards(d, dit, n_shards=2)  # BF16, the fixture's layout and names
        files = sorted(f for f in os.listdir(d) if f.endswith(".safetensors"))
        index = open(os.path.join(d, "diffusion_pytorch_model.safetensors.index.json"), "rb").read()
        shards = [open(os.path.join(d, f), "rb").read() for f in files]
        write(os.path.join(out, "bf16-two-shards"), PIECE.join([index] + shards))
        for f in files:
            os.remove(os.path.join(d, f))
        fx.write_shards(d, dit[:3], n_shards=3)
        files = sorted(f for f in os.listdir(d) if f.endswith(".safetensors"))
        index = open(os.path.join(d, "diffusion_pytorch_model.safetensors.index.json"), "rb").read()
        shards = [open(os.path.join(d, f), "rb").read() for f in files]
        write(os.path.join(out, "bf16-three-shards"), PIECE.join([index] + shards))
        # F32 and F16 shards with metadata in both (the first shard's value wins)
        name = "diffusion_pytorch_model-00001-of-00002.safetensors"
        fx.write_safetensors(os.path.join(d, "a"), dit[:3], "F32", {"format": "pt", "shard": "1"})
        second = "diffusion_pytorch_model-00002-of-00002.safetensors"
        header, data = {"__metadata__": {"format": "pt", "extra": "2"}}, bytearray()
        for n, shape, vals in sorted(dit[3:], key=lambda t: t[0]):
            raw = struct.pack(f"<{len(vals)}e", *vals)
            header[n] = {"dtype": "F16", "shape": shape, "data_offsets": [len(data), len(data) + len(raw)]}
            data += raw
        text = json.dumps(header, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 8)
        weight_map = {t[0]: name for t in dit[:3]}
        weight_map.update({t[0]: second for t in dit[3:]})
        index = json.dumps({"metadata": {"total_size": 0}, "weight_map": weight_map}).encode()
        shards = [open(os.path.join(d, "a"), "rb").read(), struct.pack("<Q", len(text)) + text + bytes(data)]
        write(os.path.join(out, "f32-f16-metadata"), PIECE.join([index] + shards))
    # the fixture's own index alone (its shards are not given: the first one is missing)
    index = open(os.path.join(FIXTURES, "tiny-vace-bf16", "diffusion_pytorch_model.safetensors.index.json"), "rb").read()
    write(os.path.join(out, "fixture-index-alone"), index)


def main():
    corpus = os.path.join(ROOT, "fuzz", "corpus")
    pth_seeds(os.path.join(corpus, "pth"))
    shard_seeds(os.path.join(corpus, "st_index"))


if __name__ == "__main__":
    main()
