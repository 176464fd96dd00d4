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
wc -l $D/*.dict
