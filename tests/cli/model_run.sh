#!/bin/bash
# gaussvid model run --part dit: weights and inputs written here byte by byte (F32 zeros, the
# tensor list from `model inspect --list`), the named outputs and their shapes, weights split
# over two files, and bad inputs: unknown input names, missing weights, a camera-less variant
# given cameras, usage errors. (Values are checked by tests/test_model_run.c.)
# Usage: bash model_run.sh /path/to/gaussvid   ($GV_TMP: scratch folder)
set -u
GV=$(realpath "$1")
DIR="${GV_TMP:-/tmp/gaussvid-cli-model-run}"
rm -rf "$DIR" && mkdir -p "$DIR" && cd "$DIR" || exit 1
passed=0
failed=0

check() { # check "description" condition-exit-status
    if [ "$2" -eq 0 ]; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: $1"; fi
}

le64() { # the 8-byte little-endian form of $1
    local i out=""
    for i in 0 1 2 3 4 5 6 7; do out+=$(printf '\\x%02x' $((($1 >> (8 * i)) & 255))); done
    printf "$out"
}

zeros_file() { # zeros_file FILE "NAME D0,D1,..." ...: a safetensors file of F32 zeros
    local file="$1" header="{" off=0 spec name shape numel d
    shift
    for spec in "$@"; do
        name=${spec% *}
        shape=${spec#* }
        numel=1
        IFS=, read -ra dims <<< "$shape"
        for d in "${dims[@]}"; do numel=$((numel * d)); done
        [ "$header" = "{" ] || header+=","
        header+="\"$name\":{\"dtype\":\"F32\",\"shape\":[$shape],\"data_offsets\":[$off,$((off + numel * 4))]}"
        off=$((off + numel * 4))
    done
    header+="}"
    { le64 ${#header}; printf '%s' "$header"; head -c $off /dev/zero; } > "$file"
}

tensor_specs() { # tensor_specs CONFIG [VARIANT] [MODULE-REGEX]: "name d0,d1" of the DiT's tensors
    "$GV" model inspect --config "$1" ${2:+--variant "$2"} --list |
        awk -v keep="${3:-.}" '/^[A-Za-z_0-9.]+ \[/ && $3 !~ /^vae_/ && $3 ~ keep { s = $2; gsub(/[\[\]]/, "", s); print $1 " " s }'
}

mapfile -t all < <(tensor_specs tiny)
[ ${#all[@]} -gt 100 ]
check "tiny lists its tensors (${#all[@]})" $?
zeros_file w.safetensors "${all[@]}"
zeros_file in.safetensors "latent 4,2,4,4" "timestep 1" "text 4,16" "vace_context 72,2,4,4" "plucker 6,8,32,32"

out=$("$GV" model run --config tiny --weights w.safetensors --inputs in.safetensors --out out.safetensors 2>&1)
check "run exits 0 ($out)" $?
listing=$("$GV" st inspect out.safetensors 2>&1)
echo "$listing" | grep -q "velocity  *F32  *\[1, 4, 2, 4, 4\]"
check "velocity [1, 4, 2, 4, 4]" $?
echo "$listing" | grep -q "camera_tokens  *F32  *\[1, 8, 32\]"
check "camera_tokens [1, 8, 32]" $?
echo "$listing" | grep -q "part: dit"
check "metadata names the part" $?

# base and adapters in two files
mapfile -t base < <(tensor_specs tiny "" '^(patch_embedding|time_embedding|text_embedding|blocks|head|vace)$')
mapfile -t adapters < <(tensor_specs tiny "" '^(camera|lora)$')
[ $((${#base[@]} + ${#adapters[@]})) -eq ${#all[@]} ]
check "base + adapters = all tensors" $?
zeros_file base.safetensors "${base[@]}"
zeros_file adapters.safetensors "${adapters[@]}"
"$GV" model run --config tiny --weights base.safetensors,adapters.safetensors --inputs in.safetensors --out two.safetensors --quiet
check "weights from two files" $?
cmp -s out.safetensors two.safetensors
check "same output from one file or two" $?

# a variant without cameras and LoRA loads the base alone, and refuses camera inputs
zeros_file in-nocam.safetensors "latent 4,2,4,4" "timestep 1" "text 4,16"
"$GV" model run --config tiny --variant camera=none,lora=0 --weights base.safetensors --inputs in-nocam.safetensors --out nocam.safetensors --quiet
check "camera=none,lora=0 runs on the base" $?
out=$("$GV" model run --config tiny --variant camera=none,lora=0 --weights base.safetensors --inputs in.safetensors --out x.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "takes no cameras"
check "camera=none given cameras: exit 1 ($out)" $?

# bad inputs: exit 1 with the file and the problem named, no output written
zeros_file bad-name.safetensors "latent 4,2,4,4" "timestep 1" "text 4,16" "latents 4,2,4,4"
out=$("$GV" model run --config tiny --weights w.safetensors --inputs bad-name.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "bad-name.safetensors: unknown input latents" && [ ! -e bad.safetensors ]
check "unknown input name: exit 1 ($out)" $?
zeros_file no-t.safetensors "latent 4,2,4,4" "text 4,16"
out=$("$GV" model run --config tiny --weights w.safetensors --inputs no-t.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "timestep"
check "missing timestep: exit 1 ($out)" $?
zeros_file bad-shape.safetensors "latent 4,2,4,5" "timestep 1" "text 4,16"
out=$("$GV" model run --config tiny --variant camera=none,lora=0 --weights base.safetensors --inputs bad-shape.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "patch"
check "latent off the patch grid: exit 1 ($out)" $?
out=$("$GV" model run --config tiny --weights base.safetensors --inputs in.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "missing (camera_encoder\|missing (blocks.0.camera_modulation\|lora_A"
check "adapters missing: exit 1 naming them ($out)" $?
[ ! -e bad.safetensors ]
check "no output after failures" $?

# a NaN in the weights: model inspect says they do not load (exit 1) and model run refuses them,
# each naming the tensor and the file (the first tensor's first value is patched to a NaN)
cp w.safetensors nan.safetensors
hlen=$(od -An -t u8 -N 8 nan.safetensors | tr -d ' ')
printf '\x00\x00\xc0\x7f' | dd of=nan.safetensors bs=1 seek=$((8 + hlen)) conv=notrunc status=none
out=$("$GV" model inspect --config tiny --parts dit,vace,camera,lora --weights nan.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "non-finite: 1" && echo "$out" | grep -q "the weights load: no"
check "inspect: a NaN means the weights do not load" $?
out=$("$GV" model run --config tiny --weights nan.safetensors --inputs in.safetensors --out bad.safetensors 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "nan.safetensors: .*element 0 is nan" && [ ! -e bad.safetensors ]
check "run: a NaN is refused naming the file and the tensor ($out)" $?
"$GV" model inspect --config tiny --parts dit,vace,camera,lora --weights w.safetensors | grep -q "non-finite: 0"
check "inspect: finite weights have no non-finite tensor" $?

# usage errors: exit 2
"$GV" model run --config tiny --weights w.safetensors --inputs in.safetensors --out x.safetensors --part vae-warp 2>/dev/null
[ $? -eq 2 ]
check "unknown part: exit 2" $?
"$GV" model run --config tiny --weights w.safetensors --inputs in.safetensors --out x.safetensors --variant camera=sideways 2>/dev/null
[ $? -eq 2 ]
check "bad variant: exit 2" $?
"$GV" model run --config tiny --weights w.safetensors --inputs in.safetensors 2>/dev/null
[ $? -eq 2 ]
check "missing --out: exit 2" $?
"$GV" model run --help | grep -q "velocity"
check "--help describes the outputs" $?

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
