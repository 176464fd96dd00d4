#!/bin/bash
# gaussvid model run --part dit: weights and inputs written here byte by byte (F32 zeros, the
# tensor list from `model inspect --list`), the named outputs and their shapes, weights split
# over two files, and bad inputs: unknown input names, missing weights, a camera-less variant
# given cameras, usage errors. (Values are checked by tests/test_model_run.c.)
# Usage: bash model_run.sh /path/to/gaussvid   ($GV_TMP: scratch folder)
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup model-run "$1"
GV=$(realpath "$G")
DIR="$T"
cd "$DIR" || exit 1

tensor_specs() { # tensor_specs CONFIG [VARIANT] [MODULE-REGEX]: "name d0,d1" of the DiT's tensors
    "$GV" model inspect --config "$1" ${2:+--variant "$2"} --list |
        awk -v keep="${3:-.}" '/^[A-Za-z_0-9.]+ \[/ && $3 !~ /^vae_/ && $3 ~ keep { s = $2; gsub(/[\[\]]/, "", s); print $1 " " s }'
}

mapfile -t all < <(tensor_specs tiny)
[ ${#all[@]} -gt 100 ]
check_rc "tiny lists its tensors (${#all[@]})" $?
st_zeros w.safetensors "${all[@]}"
st_zeros in.safetensors "latent 4,2,4,4" "timestep 1" "text 4,16" "vace_context 72,2,4,4" "plucker 6,8,32,32"

out=$("$GV" model run --config tiny --weights w.safetensors --inputs in.safetensors --out out.safetensors 2>&1)
check_rc "run exits 0 ($out)" $?
listing=$("$GV" st inspect out.safetensors 2>&1)
echo "$listing" | grep -q "velocity  *F32  *\[1, 4, 2, 4, 4\]"
check_rc "velocity [1, 4, 2, 4, 4]" $?
echo "$listing" | grep -q "camera_tokens  *F32  *\[1, 8, 32\]"
check_rc "camera_tokens [1, 8, 32]" $?
echo "$listing" | grep -q "part: dit"
check_rc "metadata names the part" $?

# base and adapters in two files
mapfile -t base < <(tensor_specs tiny "" '^(patch_embedding|time_embedding|text_embedding|blocks|head|vace)$')
mapfile -t adapters < <(tensor_specs tiny "" '^(camera|lora)$')
[ $((${#base[@]} + ${#adapters[@]})) -eq ${#all[@]} ]
check_rc "base + adapters = all tensors" $?
st_zeros base.safetensors "${base[@]}"
st_zeros adapters.safetensors "${adapters[@]}"
"$GV" model run --config tiny --weights base.safetensors,adapters.safetensors --inputs in.safetensors --out two.safetensors --quiet
check_rc "weights from two files" $?
cmp -s out.safetensors two.safetensors
check_rc "same output from one file or two" $?

# a variant without cameras and LoRA loads the base alone, and refuses camera inputs
st_zeros in-nocam.safetensors "latent 4,2,4,4" "timestep 1" "text 4,16"
"$GV" model run --config tiny --variant camera=none,lora=0 --weights base.safetensors --inputs in-nocam.safetensors --out nocam.safetensors --quiet
check_rc "camera=none,lora=0 runs on the base" $?
out=$("$GV" model run --config tiny --variant camera=none,lora=0 --weights base.safetensors --inputs in.safetensors --out x.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "takes no cameras"
check_rc "camera=none given cameras: exit 1 ($out)" $?

# bad inputs: exit 1 with the file and the problem named, no output written
st_zeros bad-name.safetensors "latent 4,2,4,4" "timestep 1" "text 4,16" "latents 4,2,4,4"
out=$("$GV" model run --config tiny --weights w.safetensors --inputs bad-name.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "bad-name.safetensors: unknown input latents" && [ ! -e bad.safetensors ]
check_rc "unknown input name: exit 1 ($out)" $?
st_zeros no-t.safetensors "latent 4,2,4,4" "text 4,16"
out=$("$GV" model run --config tiny --weights w.safetensors --inputs no-t.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "timestep"
check_rc "missing timestep: exit 1 ($out)" $?
st_zeros bad-shape.safetensors "latent 4,2,4,5" "timestep 1" "text 4,16"
out=$("$GV" model run --config tiny --variant camera=none,lora=0 --weights base.safetensors --inputs bad-shape.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "patch"
check_rc "latent off the patch grid: exit 1 ($out)" $?
out=$("$GV" model run --config tiny --weights base.safetensors --inputs in.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "missing (camera_encoder\|missing (blocks.0.camera_modulation\|lora_A"
check_rc "adapters missing: exit 1 naming them ($out)" $?
[ ! -e bad.safetensors ]
check_rc "no output after failures" $?

# a NaN in the weights: model inspect says they do not load (exit 1) and model run refuses them,
# each naming the tensor and the file (the first tensor's first value is patched to a NaN)
cp w.safetensors nan.safetensors
hlen=$(od -An -t u8 -N 8 nan.safetensors | tr -d ' ')
printf '\x00\x00\xc0\x7f' | dd of=nan.safetensors bs=1 seek=$((8 + hlen)) conv=notrunc status=none
out=$("$GV" model inspect --config tiny --parts dit,vace,camera,lora --weights nan.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "non-finite: 1" && echo "$out" | grep -q "the weights load: no"
check_rc "inspect: a NaN means the weights do not load" $?
out=$("$GV" model run --config tiny --weights nan.safetensors --inputs in.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "nan.safetensors: .*element 0 is nan" && [ ! -e bad.safetensors ]
check_rc "run: a NaN is refused naming the file and the tensor ($out)" $?
"$GV" model inspect --config tiny --parts dit,vace,camera,lora --weights w.safetensors | grep -q "non-finite: 0"
check_rc "inspect: finite weights have no non-finite tensor" $?

# usage errors: exit 2
"$GV" model run --config tiny --weights w.safetensors --inputs in.safetensors --out x.safetensors --part vae-warp 2>/dev/null
[ $? -eq 2 ]
check_rc "unknown part: exit 2" $?
"$GV" model run --config tiny --weights w.safetensors --inputs in.safetensors --out x.safetensors --variant camera=sideways 2>/dev/null
[ $? -eq 2 ]
check_rc "bad variant: exit 2" $?
"$GV" model run --config tiny --weights w.safetensors --inputs in.safetensors 2>/dev/null
[ $? -eq 2 ]
check_rc "missing --out: exit 2" $?
"$GV" model run --help | grep -q "velocity"
check_rc "--help describes the outputs" $?

cli_finish
