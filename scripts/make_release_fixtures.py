#!/usr/bin/env python3
"""Writes the tiny fixtures in the layouts Wan2.1-VACE is published in (issue 24).

    python3 scripts/make_release_fixtures.py build/gaussvid tests/fixtures/release

How they are made (Python 3 standard library only: no torch, no numpy, no safetensors):

  * The tensor names and shapes are those of the `tiny` preset (configs/tiny.json) without
    camera encoder or LoRA (`--variant camera=none,lora=0`), i.e. what a published
    Wan2.1-VACE release holds at tiny size, as listed by
    `gaussvid model inspect --config tiny --variant camera=none,lora=0 --list --json`.
  * Values: stand-ins for pretrained weights, drawn with Python's `random.Random` seeded by
    the tensor's name (so each tensor's values depend on nothing else): matrices and
    convolution kernels U(+-sqrt(3 / fan_in)), modulation tables and biases N(0, 0.1^2),
    norm gains 1 + N(0, 0.1^2); rounded to float32 once. The same values are written in
    every layout.
  * tiny_dit_f32.safetensors: DiT + VACE, F32, one file (Wan2.1-VACE-1.3B's layout).
  * tiny-vace-bf16/diffusion_pytorch_model-0000{1,2}-of-00002.safetensors and
    tiny-vace-bf16/diffusion_pytorch_model.safetensors.index.json: the same tensors in BF16
    (round to nearest even from the float32 bits, done here independently of the C code),
    split into two shards at half the bytes in the module order, with the huggingface index
    (Wan2.1-VACE-14B's layout).
  * tiny_vae_f32.safetensors and tiny-vace-bf16/Wan2.1_VAE.pth: the VAE, F32, as
    safetensors and as a PyTorch zip checkpoint written the way torch.save writes one: the
    state dict is an OrderedDict with a `_metadata` attribute, pickled by the standard
    library's pickler at protocol 2 with torch.save's persistent ids
    ('storage', torch.FloatStorage, key, 'cpu', numel); `torch` and `torch._utils` are
    stand-in modules (empty, never called) so the pickler can name the globals
    torch._utils._rebuild_tensor_v2 and torch.FloatStorage; the zip holds
    Wan2.1_VAE/data.pkl, Wan2.1_VAE/byteorder, Wan2.1_VAE/data/<key> (stored, each
    aligned to 64 bytes with an "FB" padding extra field as PyTorch's writer does) and
    Wan2.1_VAE/version.

  * tiny-vace-bf16/models_t5_umt5-xxl-enc-bf16.pth: a tiny umT5 encoder (Wan's T5Encoder
    names, vocab 64, dim 16, 2 heads, FFN 24, 2 layers, 32 buckets) with BF16 storages, as
    the published text encoder.
  * tiny-vace-bf16/google/umt5-xxl/spiece.model: a 64-piece SentencePiece unigram model
    trained by Debian's `spm_train` (package sentencepiece, one thread) on the sentences in
    TOKENIZER_CORPUS below, with umT5's special ids (pad 0, </s> 1, unk 2, no <s>); and
    tokenizer_cases.json: texts with the ids `spm_encode --output_format=id` gives for their
    whitespace-cleaned form, plus </s>, as Wan's tokenizer returns them.

Run once; the outputs are committed (about 2 MB). Re-running gives the same bytes.
"""
import collections
import io
import json
import math
import os
import pickle
import random
import struct
import subprocess
import sys
import types
import zlib


def tensor_list(gaussvid):
    out = subprocess.run([gaussvid, "model", "inspect", "--config", "tiny", "--variant", "camera=none,lora=0",
                          "--list", "--json"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)["tensor_list"]


TOKENIZER_CORPUS = [
    "Remove degradation and restore clean video.",
    "Restore the clean video from the degraded render.",
    "A sparse view reconstruction leaves floaters and blur in novel views.",
    "The restorer removes floaters, blur and broken structure.",
    "Clean anchors at both ends of the clip guide the restoration.",
    "Remove noise, distortion and low quality from the video.",
]
TOKENIZER_CASES = ["Remove degradation and restore clean video.", "  restore   clean\tvideo\n", "",
                   "floaters and blur"]


def write_tokenizer(release, out):
    folder = os.path.join(release, "google", "umt5-xxl")
    os.makedirs(folder, exist_ok=True)
    corpus, prefix = os.path.join(folder, "corpus.txt"), os.path.join(folder, "spiece")
    with open(corpus, "w") as f:
        f.write("\n".join(TOKENIZER_CORPUS * 4) + "\n")
    # relative paths: the model records its trainer's arguments, which must not name this machine
    subprocess.run(["spm_train", "--input=corpus.txt", "--model_prefix=spiece", "--vocab_size=64",
                    "--model_type=unigram", "--character_coverage=1.0", "--pad_id=0", "--eos_id=1", "--unk_id=2",
                    "--bos_id=-1", "--num_threads=1"], check=True, capture_output=True, cwd=folder)
    os.remove(corpus)
    os.remove(prefix + ".vocab")
    cases = []
    for text in TOKENIZER_CASES:
        clean = " ".join(text.split())
        ids = subprocess.run(["spm_encode", f"--model={prefix}.model", "--output_format=id"], input=clean + "\n",
                             check=True, capture_output=True, text=True).stdout.split()
        cases.append({"text": text, "ids": [int(i) for i in ids] + [1]})
    text = "[\n" + ",\n".join(json.dumps(c) for c in cases) + "\n]\n"
    write_atomic(os.path.join(out, "tokenizer_cases.json"), text.encode())


def tiny_umt5():
    """Wan's T5Encoder names (wan/modules/t5.py, umt5_xxl: per-layer relative positions) at
    vocab 64, dim 16, 2 heads of 8, FFN 24, 2 layers, 32 buckets."""
    vocab, dim, ffn, heads, layers, buckets = 64, 16, 24, 2, 2, 32
    out = [("token_embedding.weight", [vocab, dim])]
    for i in range(layers):
        b = f"blocks.{i}."
        out += [(b + "norm1.weight", [dim])] + [(b + f"attn.{w}.weight", [dim, dim]) for w in "qkvo"]
        out += [(b + "norm2.weight", [dim]), (b + "ffn.gate.0.weight", [ffn, dim]), (b + "ffn.fc1.weight", [ffn, dim]),
                (b + "ffn.fc2.weight", [dim, ffn]), (b + "pos_embedding.embedding.weight", [buckets, heads])]
    return out + [("norm.weight", [dim])]


def values_of(name, shape):
    """Stand-in pretrained values, seeded by the name alone, as float32."""
    rng = random.Random("gaussvid-release-fixture:" + name)
    n = math.prod(shape)
    gain = name.endswith((".norm_q.weight", ".norm_k.weight", ".norm3.weight", ".gamma", ".norm1.weight",
                          ".norm2.weight")) or name == "norm.weight"
    if len(shape) >= 2 and "modulation" not in name and not gain:
        bound = math.sqrt(3.0 / (n // shape[0]))
        vals = [rng.uniform(-bound, bound) for _ in range(n)]
    else:
        vals = [(1.0 if gain else 0.0) + rng.gauss(0.0, 0.1) for _ in range(n)]
    return list(struct.unpack(f"<{n}f", struct.pack(f"<{n}f", *vals)))


def f32_bytes(vals):
    return struct.pack(f"<{len(vals)}f", *vals)


def bf16_bytes(vals):
    """Round to nearest, ties to even, from the float32 bits (no NaNs occur here)."""
    bits = struct.unpack(f"<{len(vals)}I", f32_bytes(vals))
    return struct.pack(f"<{len(vals)}H", *[((u + 0x7FFF + ((u >> 16) & 1)) >> 16) & 0xFFFF for u in bits])


def write_atomic(path, data):
    tmp = f"{path}.tmp.{os.getpid()}"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def write_safetensors(path, tensors, dtype, metadata):
    """tensors: (name, shape, values); the reference writer's layout for one dtype."""
    header, data = {"__metadata__": metadata}, bytearray()
    for name, shape, vals in sorted(tensors, key=lambda t: t[0].encode()):
        raw = f32_bytes(vals) if dtype == "F32" else bf16_bytes(vals)
        header[name] = {"dtype": dtype, "shape": shape, "data_offsets": [len(data), len(data) + len(raw)]}
        data += raw
    text = json.dumps(header, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 8)
    write_atomic(path, struct.pack("<Q", len(text)) + text + bytes(data))
    return len(data)


def write_shards(folder, tensors, n_shards=2):
    """The huggingface sharding: tensors in order, a new shard when half the bytes are used."""
    total = sum(2 * math.prod(shape) for _, shape, _ in tensors)
    shards, used = [[]], 0
    for t in tensors:
        size = 2 * math.prod(t[1])
        if used + size > total / n_shards and shards[-1] and len(shards) < n_shards:
            shards.append([])
            used = 0
        shards[-1].append(t)
        used += size
    weight_map = {}
    for i, shard in enumerate(shards):
        name = f"diffusion_pytorch_model-{i + 1:05d}-of-{len(shards):05d}.safetensors"
        write_safetensors(os.path.join(folder, name), shard, "BF16", {"format": "pt"})
        weight_map.update({t[0]: name for t in shard})
    index = {"metadata": {"total_size": total}, "weight_map": dict(sorted(weight_map.items()))}
    write_atomic(os.path.join(folder, "diffusion_pytorch_model.safetensors.index.json"),
                 (json.dumps(index, indent=2, sort_keys=True) + "\n").encode())


# ---- torch.save's layout, without torch ---------------------------------------------------

def stand_in_torch():
    """Empty modules named torch and torch._utils holding the two globals a state dict names,
    so that the standard pickler writes them by those names. Nothing here is ever called."""
    torch, utils = types.ModuleType("torch"), types.ModuleType("torch._utils")

    def _rebuild_tensor_v2(*args):
        raise RuntimeError("a stand-in: the fixtures are only written")

    _rebuild_tensor_v2.__module__, _rebuild_tensor_v2.__qualname__ = "torch._utils", "_rebuild_tensor_v2"
    utils._rebuild_tensor_v2, torch._utils = _rebuild_tensor_v2, utils
    for storage in ("FloatStorage", "BFloat16Storage"):
        setattr(torch, storage, type(storage, (), {"__module__": "torch"}))
    sys.modules["torch"], sys.modules["torch._utils"] = torch, utils
    return torch


class Storage:
    def __init__(self, key, raw):
        self.key, self.raw = key, raw


class Tensor:
    """Pickles as torch.Tensor does: _rebuild_tensor_v2(storage, offset, size, stride,
    requires_grad, backward_hooks)."""

    def __init__(self, storage, shape):
        self.storage, self.shape = storage, tuple(shape)

    def __reduce_ex__(self, protocol):
        stride, step = [], 1
        for size in reversed(self.shape):
            stride.insert(0, step)
            step *= size
        rebuild = sys.modules["torch._utils"]._rebuild_tensor_v2
        return rebuild, (self.storage, 0, self.shape, tuple(stride), False, collections.OrderedDict())


def pickle_state_dict(torch, tensors, bf16):
    storages, state = [], collections.OrderedDict()
    for name, shape, vals in tensors:
        storage = Storage(str(len(storages)), bf16_bytes(vals) if bf16 else f32_bytes(vals))
        storages.append(storage)
        state[name] = Tensor(storage, shape)
    # torch's state_dict() carries the modules' versions as an attribute (pickled by BUILD)
    state._metadata = collections.OrderedDict([("", {"version": 1}), ("encoder", {"version": 1}),
                                               ("decoder", {"version": 1})])

    class Pickler(pickle.Pickler):
        def persistent_id(self, obj):
            if isinstance(obj, Storage):
                if bf16:
                    return ("storage", torch.BFloat16Storage, obj.key, "cpu", len(obj.raw) // 2)
                return ("storage", torch.FloatStorage, obj.key, "cpu", len(obj.raw) // 4)
            return None

    buf = io.BytesIO()
    Pickler(buf, protocol=2).dump(state)
    return buf.getvalue(), storages


def zip_records(records):
    """A zip of stored records, each record's data aligned to 64 bytes by an "FB" extra
    field in its local header (PyTorch's writer pads the same way)."""
    out, central = bytearray(), bytearray()
    for name, data in records:
        name_b, crc, offset = name.encode(), zlib.crc32(data), len(out)
        pad = -(offset + 30 + len(name_b) + 4) % 64
        extra = struct.pack("<HH", 0x4246, pad) + b"Z" * pad
        out += struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0, 0, 0, 0, crc, len(data), len(data), len(name_b),
                           len(extra)) + name_b + extra + data
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, 0, 0, 0, crc, len(data), len(data),
                               len(name_b), 0, 0, 0, 0, 0, offset) + name_b
    eocd = struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, len(records), len(records), len(central), len(out), 0)
    return bytes(out + central + eocd)


def write_pth(path, tensors, bf16=False):
    torch = stand_in_torch()
    data_pkl, storages = pickle_state_dict(torch, tensors, bf16)
    archive = os.path.splitext(os.path.basename(path))[0]
    records = [(f"{archive}/data.pkl", data_pkl), (f"{archive}/byteorder", b"little")]
    records += [(f"{archive}/data/{s.key}", s.raw) for s in sorted(storages, key=lambda s: s.key)]
    records += [(f"{archive}/version", b"3\n")]
    write_atomic(path, zip_records(records))


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: make_release_fixtures.py GAUSSVID_BINARY OUT_DIR")
    gaussvid, out = sys.argv[1:]
    release = os.path.join(out, "tiny-vace-bf16")
    os.makedirs(release, exist_ok=True)
    dit, vae = [], []
    for t in tensor_list(gaussvid):
        entry = (t["name"], t["shape"], values_of(t["name"], t["shape"]))
        (vae if t["module"].startswith("vae") else dit).append(entry)
    write_safetensors(os.path.join(out, "tiny_dit_f32.safetensors"), dit, "F32", {"format": "pt"})
    write_shards(release, dit)
    write_safetensors(os.path.join(out, "tiny_vae_f32.safetensors"), vae, "F32", {"format": "pt"})
    write_pth(os.path.join(release, "Wan2.1_VAE.pth"), vae)
    t5 = [(name, shape, values_of(name, shape)) for name, shape in tiny_umt5()]
    write_pth(os.path.join(release, "models_t5_umt5-xxl-enc-bf16.pth"), t5, bf16=True)
    write_tokenizer(release, out)
    print(f"{len(dit)} DiT + VACE tensors, {len(vae)} VAE tensors written under {out}")


if __name__ == "__main__":
    main()
