#!/bin/bash
# Makes the libFuzzer dictionaries of fuzz/dict/ from the readers' own sources: every string
# literal that looks like a key (letters, digits, _ . -) of the files that read a format, plus
# the format's punctuation. Run by hand when a reader learns a key; the output is committed.
# Usage: bash fuzz/make_dicts.sh
set -euo pipefail
cd "$(dirname "$0")/.."
D=fuzz/dict

# literals FILE...: the key-like string literals of the files, one dictionary entry each.
literals() {
    grep -ohE '"[A-Za-z_][A-Za-z0-9_.-]{0,40}"' "$@" | sort -u | grep -vE '^"(%|\\)' || true
}
json_syntax() {
    printf '%s\n' '"{"' '"}"' '"["' '"]"' '":"' '","' '"\\\""' '"true"' '"false"' '"null"' '"-0"' \
        '"1e308"' '"-1e-308"' '"0.5"' '"4294967296"' '"9007199254740993"' '"NaN"' '"\\u0000"' '"\\ud800"'
}

{ json_syntax; literals src/io/transforms.c; } > $D/transforms.dict
{ json_syntax; literals src/model/config_json.c src/model/config_presets.c; } > $D/config.dict
{ json_syntax; literals src/data/manifest.c src/data/runs.c src/data/stats.c; } > $D/manifest.dict
{ json_syntax; literals src/report/metrics_read.c; } > $D/report.dict
# safetensors: the header's keys, every dtype, and the metadata keys of clips and checkpoints.
{ json_syntax; printf '%s\n' '"dtype"' '"shape"' '"data_offsets"' '"__metadata__"';
  literals src/io/safetensors_dtype.c; } > $D/safetensors.dict
{ cat $D/safetensors.dict; literals src/data/clip.c; } | sort -u > $D/clip.dict
{ cat $D/safetensors.dict; literals src/train/checkpoint.c src/train/checkpoint_state.c src/model/vae_io.c \
      src/model/config_json.c src/model/weight_names.c src/model/weight_names_vae.c; } | sort -u > $D/checkpoint.dict
# PLY: the header's keywords, types and the 3DGS property names.
{ printf '%s\n' '"ply"' '"format"' '"ascii"' '"binary_little_endian"' '"binary_big_endian"' '"1.0"' '"element"' \
      '"vertex"' '"face"' '"property"' '"list"' '"end_header"' '"comment"' '"obj_info"' '"\x0a"' '"\x0d\x0a"' \
      '"f_rest_44"' '"f_rest_9"' '"red"' '"green"' '"blue"' '"nan"' '"inf"' '"-1"' '"4294967295"';
  literals src/io/ply_header.c src/io/ply_gaussians.c src/io/ply_points.c; } | sort -u > $D/ply.dict
# COLMAP text: camera models and comment lines.
{ printf '%s\n' '"#"' '"\x0a"' '" "' '"-1"' '"nan"' '"1e400"';
  literals src/io/colmap.c src/io/colmap_text.c; } | sort -u > $D/colmap_text.dict
# PNG chunk names and JPEG markers.
{ for c in IHDR PLTE IDAT IEND tRNS gAMA cHRM sRGB iCCP sBIT tEXt zTXt iTXt bKGD pHYs sPLT hIST tIME eXIf; do
      printf '"%s"\n' "$c"; done
  printf '%s\n' '"\x89PNG\x0d\x0a\x1a\x0a"' '"\xff\xd8\xff"' '"\xff\xc0"' '"\xff\xc2"' '"\xff\xc4"' '"\xff\xda"' \
      '"\xff\xdb"' '"\xff\xdd"' '"\xff\xd9"' '"\xff\xe0"' '"\xff\xe1"' '"JFIF\x00"' '"Exif\x00\x00"' '"\xff\xff"'; } > $D/image.dict
# PyTorch zip checkpoints: pickle opcodes, the names a state dict's pickle holds (GLOBAL lines
# and strings), zip signatures and entry names, and the harness's piece separator.
{ for op in 80 95 2e 28 7d 29 4e 88 89 4a 4b 4d 8a 58 8c 8d 74 85 86 87 73 75 71 72 94 68 6a 63 93 51 52 62 69 6f; do
      printf '"\\x%s"\n' "$op"; done
  printf '%s\n' '"\x80\x02"' '"\x80\x04\x95"' '"collections\x0aOrderedDict\x0a"' '"torch._utils\x0a_rebuild_tensor_v2\x0a"' \
      '"torch._utils\x0a_rebuild_parameter\x0a"' '"torch\x0aFloatStorage\x0a"' '"torch\x0aBFloat16Storage\x0a"' \
      '"torch\x0aHalfStorage\x0a"' '"\x8c\x05torch"' '"\x8c\x0ctorch._utils"' '"X\x07\x00\x00\x00storage"' \
      '"\x8c\x03cpu"' '"\xff\xff\xff\xff"' '"\xff\xff"' '"\x00\x00\x00\x00\x00\x00\x00\x40"' \
      '"PK\x03\x04"' '"PK\x01\x02"' '"PK\x05\x06"' '"PK\x06\x06"' '"PK\x06\x07"' '"\x01\x00\x18\x00"' \
      '"archive/"' '"data.pkl"' '"data/"' '"byteorder"' '"little"' '"big"' '"version"' '"#PIECE#"';
  literals src/pth/pickle.c | grep -vE '^"[A-Z0-9_]+"$'; } | sort -u > $D/pth.dict
# sharded safetensors: the index's keys and shard names, and the safetensors dictionary.
{ cat $D/safetensors.dict; printf '%s\n' '"weight_map"' '"metadata"' '"total_size"' '"#PIECE#"' '"../"' '"/"' \
      '"diffusion_pytorch_model-00001-of-00002.safetensors"' '"diffusion_pytorch_model-00002-of-00002.safetensors"' \
      '"diffusion_pytorch_model.safetensors.index.json"'; } | sort -u > $D/st_index.dict
wc -l $D/*.dict
