#!/bin/bash
# gaussvid model inspect: parameter counts (checked against the reference's shape table),
# variants, the check of weight files (written here byte by byte: right, missing,
# mis-shaped, unexpected and duplicated tensors; several files), JSON and usage errors.
# Usage: bash model.sh /path/to/gaussvid   ($GV_TMP: scratch folder)
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup model "$1"

module_params() { # module_params OUTPUT MODULE: the parameter column of a module line
    echo "$1" | awk -v m="$2" '$1 == m && NF >= 3 { print $3; exit }'
}

# ---- counts -----------------------------------------------------------------------------
out=$("$G" model inspect --config tiny 2>&1)
check_rc "inspect tiny exits 0 ($out)" $?
for m in patch_embedding time_embedding text_embedding blocks head vace vae_encoder vae_decoder camera lora total; do
    [ -n "$(module_params "$out" $m)" ]
    check_rc "tiny lists module $m" $?
done
trainable=$(echo "$out" | sed -n 's/^trainable in fine-tuning (LoRA + camera): \([0-9]*\) .*/\1/p')
[ -n "$trainable" ] && [ "$trainable" -eq $(($(module_params "$out" camera) + $(module_params "$out" lora))) ]
check_rc "trainable = camera + LoRA ($trainable)" $?
total=$(module_params "$out" total)
frozen=$(echo "$out" | sed -n 's/^frozen (DiT, VACE, VAE): \([0-9]*\)$/\1/p')
[ "$frozen" -eq $((total - trainable)) ]
check_rc "frozen = total - trainable" $?

# Wan2.1-VACE-1.3B against the reference's table (section 2.8): D 1536, F 8960, 30 blocks,
# 15 VACE blocks; the base only (no camera encoder, no LoRA).
D=1536 F=8960
block=$((6 * D + 2 * (4 * (D * D + D) + 2 * D) + 2 * D + (F * D + F) + (D * F + D)))
out=$("$G" model inspect --config wan2.1-vace-1.3b --variant camera=none,lora=0 2>&1)
check_rc "inspect wan2.1-vace-1.3b exits 0" $?
[ "$(module_params "$out" blocks)" = $((30 * block)) ]
check_rc "1.3B blocks = 30 x $block" $?
[ "$(module_params "$out" patch_embedding)" = $((D * 16 * 4 + D)) ]
check_rc "1.3B patch embedding" $?
[ "$(module_params "$out" text_embedding)" = $((D * 4096 + D + D * D + D)) ]
check_rc "1.3B text embedding" $?
[ "$(module_params "$out" time_embedding)" = $((D * 256 + D + D * D + D + 6 * D * D + 6 * D)) ]
check_rc "1.3B time embedding and projection" $?
[ "$(module_params "$out" vace)" = $((D * 96 * 4 + D + 15 * (block + D * D + D) + D * D + D)) ]
check_rc "1.3B VACE" $?
echo "$out" | grep -q "^trainable in fine-tuning (LoRA + camera): 0 (0.000%)$"
check_rc "1.3B base: nothing trainable" $?

# The 14B preset's default variant: camera encoder with the authors' sizes and rank-32 LoRA.
out=$("$G" model inspect --config wan2.1-vace-14b 2>&1)
check_rc "inspect wan2.1-vace-14b exits 0" $?
echo "$out" | grep -q "camera: decomposed, 128 channels per stream, gate 256, proj 5120, kernel 4x16x16, gamma 0.1"
check_rc "14B camera line" $?
[ "$(module_params "$out" blocks)" = $((40 * (6 * 5120 + 2 * (4 * (5120 * 5120 + 5120) + 2 * 5120) + 2 * 5120 + 2 * 13824 * 5120 + 13824 + 5120))) ]
check_rc "14B blocks" $?

out=$("$G" model inspect --config small 2>&1)
echo "$out" | grep -q "^clip 5x144x256: latent 5x36x64, 720 video + 720 camera tokens$"
check_rc "small clip tokens" $?
out=$("$G" model inspect --config small --frames 9 --height 288 --width 512 --variant none 2>&1)
echo "$out" | grep -q "^clip 9x288x512: latent 9x72x128, 5184 video + 0 camera tokens$"
check_rc "small clip tokens for another clip, no camera" $?

# ---- weight files -----------------------------------------------------------------------
# tiny's camera part by hand: C 4, G 8, P 32, D 32, kernel (4, 16, 16), 2 blocks.
CAMERA=(
    "camera_encoder.conv_m.weight 4,3,4,16,16" "camera_encoder.conv_m.bias 4"
    "camera_encoder.conv_d.weight 4,3,4,16,16" "camera_encoder.conv_d.bias 4"
    "camera_encoder.gate_d2m.0.weight 8,4" "camera_encoder.gate_d2m.0.bias 8"
    "camera_encoder.gate_d2m.2.weight 4,8" "camera_encoder.gate_d2m.2.bias 4"
    "camera_encoder.gate_m2d.0.weight 8,4" "camera_encoder.gate_m2d.0.bias 8"
    "camera_encoder.gate_m2d.2.weight 4,8" "camera_encoder.gate_m2d.2.bias 4"
    "camera_encoder.proj.0.weight 32,8" "camera_encoder.proj.0.bias 32"
    "camera_encoder.proj.2.weight 32,32" "camera_encoder.proj.2.bias 32"
    "camera_encoder.norm.weight 32" "camera_encoder.norm.bias 32" "camera_encoder.gamma 1"
    "blocks.0.camera_modulation 1,6,32" "blocks.1.camera_modulation 1,6,32"
)
GOOD="$T/camera.safetensors"
st_zeros "$GOOD" "${CAMERA[@]}"
out=$("$G" model inspect --config tiny --weights "$GOOD" --parts camera 2>&1)
check_rc "the camera part loads (exit 0): $out" $?
echo "$out" | grep -q "^the weights load: yes$" && echo "$out" | grep -q "^expected from the checked parts: 21 tensors$"
check_rc "21 camera tensors expected and found" $?

# A few right, one missing (norm.bias), one mis-shaped (gamma [2]), one unexpected.
BAD="$T/camera-bad.safetensors"
list=()
for spec in "${CAMERA[@]}"; do
    case "$spec" in
    "camera_encoder.norm.bias "*) ;;
    "camera_encoder.gamma "*) list+=("camera_encoder.gamma 2") ;;
    *) list+=("$spec") ;;
    esac
done
list+=("camera_encoder.extra.weight 3")
st_zeros "$BAD" "${list[@]}"
out=$("$G" model inspect --config tiny --weights "$BAD" --parts camera 2>&1)
[ $? -eq 1 ]
check_rc "a bad file exits 1" $?
echo "$out" | grep -q "^missing: 1$" && echo "$out" | grep -q "^  camera_encoder.norm.bias \[32\]$"
check_rc "the missing tensor is listed with its shape" $?
echo "$out" | grep -q "^unexpected: 1$" && echo "$out" | grep -qF "  camera_encoder.extra.weight (in $BAD)"
check_rc "the unexpected tensor is listed with its file" $?
echo "$out" | grep -q "^mis-shaped: 1$" && echo "$out" | grep -qF "  camera_encoder.gamma: expected [1], found [2] (in $BAD)"
check_rc "the mis-shaped tensor is listed with both shapes" $?
echo "$out" | grep -q "^the weights load: no$"
check_rc "the verdict says no" $?
json=$("$G" model inspect --config tiny --weights "$BAD" --parts camera --json 2>&1)
[ $? -eq 1 ]
check_rc "--json on a bad file exits 1" $?
echo "$json" | tr -d ' \t\n' | grep -q '"mis_shaped":\[{"name":"camera_encoder.gamma","file":"[^"]*","detail":"expected\[1\],found\[2\]"}\]'
check_rc "JSON lists the mis-shaped tensor" $?
echo "$json" | grep -Eq '"loads":[[:space:]]*false'
check_rc "JSON verdict" $?

# All parts expected: everything but the 21 camera tensors is missing.
n_all=$("$G" model inspect --config tiny --list | awk 'NF == 4 && ($4 == "trainable" || $4 == "frozen")' | wc -l)
out=$("$G" model inspect --config tiny --weights "$GOOD" 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "^missing: $((n_all - 21))$" && echo "$out" | grep -q "^  \.\.\. and $((n_all - 21 - 10)) more$"
check_rc "all parts: $((n_all - 21)) missing, the first 10 shown" $?

# Several files: the flag repeated, comma-separated, --weights=; a name in two files.
st_zeros "$T/a.safetensors" "${CAMERA[@]:0:4}"
st_zeros "$T/b.safetensors" "${CAMERA[@]:4}"
"$G" model inspect --config tiny --weights "$T/a.safetensors" --weights "$T/b.safetensors" --parts camera >/dev/null 2>&1
check_rc "--weights repeated" $?
"$G" model inspect --config tiny --weights "$T/a.safetensors,$T/b.safetensors" --parts camera >/dev/null 2>&1
check_rc "--weights comma-separated" $?
"$G" model inspect --config tiny --parts camera --weights="$T/a.safetensors,$T/b.safetensors" >/dev/null 2>&1
check_rc "--weights=A,B" $?
out=$("$G" model inspect --config tiny --weights "$GOOD" --weights "$T/a.safetensors" --parts camera 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "^duplicated: 4$" && echo "$out" | grep -qF "camera_encoder.conv_m.weight: also in $GOOD"
check_rc "a tensor in two files is reported" $?

# The whole tiny model from its own --list, and with --variant none its camera part is
# unexpected.
mapfile -t FULL < <("$G" model inspect --config tiny --list | awk 'NF == 4 && ($4 == "trainable" || $4 == "frozen") { gsub(/[][]/, "", $2); print $1 " " $2 }')
[ "${#FULL[@]}" -eq "$n_all" ] && [ "$(printf '%s\n' "${FULL[@]}" | cut -d' ' -f1 | sort -u | wc -l)" -eq "$n_all" ]
check_rc "--list gives $n_all distinct names" $?
st_zeros "$T/tiny.safetensors" "${FULL[@]}"
out=$("$G" model inspect --config tiny --weights "$T/tiny.safetensors" 2>&1)
check_rc "the full tiny file loads" $?
echo "$out" | grep -q "^expected from the checked parts: $n_all tensors$"
check_rc "all $n_all tensors expected" $?
out=$("$G" model inspect --config tiny --variant camera=none --weights "$T/tiny.safetensors" 2>&1)
[ $? -eq 1 ] && echo "$out" | grep -q "^unexpected: 21$"
check_rc "camera=none: the camera tensors are unexpected" $?

# ---- usage and bad input ----------------------------------------------------------------
bad_use() { # bad_use CODE NEEDLE ARGS...: exit CODE and NEEDLE on stderr
    local code="$1" needle="$2" msg rc
    shift 2
    msg=$("$G" "$@" 2>&1 >/dev/null)
    rc=$?
    [ $rc -eq "$code" ] && echo "$msg" | grep -qF -- "$needle"
    check_rc "$* -> exit $code with '$needle' (got $rc: $msg)" $?
}
bad_use 2 "--config is required" model inspect
bad_use 2 "--weights needs a value" model inspect --config tiny --weights
bad_use 2 "\"text\" is not a part" model inspect --config tiny --parts dit,text
bad_use 2 "variant.camera: \"side\"" model inspect --config tiny --variant camera=side
bad_use 2 "1 + k x 4 frames" model inspect --config tiny --frames 4
bad_use 1 "nosuch: neither a model preset" model inspect --config nosuch
bad_use 1 "$T/missing.safetensors" model inspect --config tiny --weights "$T/missing.safetensors"
printf '{"dit": {"dim": 32}, "vae": {}, "colour": 1}' > "$T/bad.json"
bad_use 1 "$T/bad.json: colour: unknown key" model inspect --config "$T/bad.json"
bad_use 2 "unknown subcommand" model bogus
"$G" model inspect --help | grep -q -- "--weights FILE\[,FILE\]"
check_rc "help lists --weights" $?
"$G" model --help | grep -q "inspect"
check_rc "group help lists inspect" $?

cli_finish
