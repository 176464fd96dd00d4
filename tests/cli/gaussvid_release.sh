#!/bin/bash
# The published GaussVid checkpoint (docs/GAUSSVID_RELEASE.md) on the committed tiny release
# (tests/fixtures/release) and on checkpoints in the release's naming written by
# test_release_lora --write-fixtures (rank-4 PEFT and kohya pairs, an alpha, distractors,
# decoder entries that replace, one of another shape, unknown names): model import --lora
# (the summary line, --list-keys with the three lists), model merge (bf16 and f32, with the
# VAE), restore with the fused base (which restores differently from the plain base), and
# eval --metric release, the official camera encoder (model run --part camera), and bad
# checkpoints failing with one line naming the key or the file, writing nothing.
# Usage: bash gaussvid_release.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup gaussvid_release "$1"
source "$(dirname "$0")/lib/release_fixture.sh"
WRITER="$(dirname "$G")/test_release_lora"
L="$T/lora"
mkdir -p "$L"
check "the checkpoints are written" "$WRITER" --write-fixtures "$L"

expect 0 "merge help" -- "$G" model merge --help
has "usage: gaussvid model merge"
expect 0 "import help names --lora" -- "$G" model import --help
has "--lora"

# Every key's fate, nothing written.
expect 0 "list the keys" -- "$G" model import --from "$REL" --config "$CFG" --lora "$L/good.safetensors" --list-keys
has "fused    pipe.dit.blocks.0.self_attn.q.lora_A.default.weight -> blocks.0.self_attn.q.weight"
has "fused    pipe.dit.blocks.1.self_attn.v.lora_up.weight -> blocks.1.self_attn.v.weight"
has "fused    pipe.vace.vace_blocks.0.self_attn.k.lora_B.default.weight -> vace_blocks.0.self_attn.k.weight"
has "replaced pipe.vae.model.decoder.conv1.weight -> decoder.conv1.weight"
has "skipped  pipe.vae.model.decoder.head.2.weight -> decoder.head.2.weight: another shape than the VAE tensor"
has "skipped  pipe.vae.model.decoder.no_such.weight -> decoder.no_such.weight: no such VAE tensor"
has "ignored  pipe.dit.blocks.1.self_attn.v.alpha: not a LoRA weight (no lora_B/lora_up)"
has "ignored  pipe.dit.blocks.0.self_attn.k.lora_A.default.weight: lora_A/lora_down without its lora_B/lora_up"
has "ignored  lr_scheduler.last_epoch: outside pipe.dit., pipe.vace. and pipe.vae.model.decoder."
check "one line per key (25) and the summary" test "$(wc -l < "$T/out")" -eq 26
check "14 fused, 2 replaced, 3 skipped, 6 ignored" test "$(grep -c '^fused ' "$T/out") $(grep -c '^replaced ' "$T/out") \
$(grep -c '^skipped ' "$T/out") $(grep -c '^ignored ' "$T/out")" = "14 2 3 6"
SUMMARY="7 modules fused (14 keys, rank 4), 2 decoder tensors replaced, 3 decoder entries skipped (2 unknown name, 1 other shape, 0 no VAE), 6 keys ignored (3 outside the prefixes, 2 not LoRA weights, 1 unpaired lora_A)"
has "good.safetensors: $SUMMARY"
expect 2 "--list-keys without --lora" -- "$G" model import --from "$REL" --config "$CFG" --list-keys

# The import with the checkpoint fused, and without.
expect 0 "import with the checkpoint" -- "$G" model import --from "$REL" --config "$CFG" --lora "$L/good.safetensors" \
    --out "$T/fused" --no-text --quiet
has "good.safetensors: $SUMMARY"
has "(131 BF16)"
expect 0 "import without" -- "$G" model import --from "$REL" --config "$CFG" --out "$T/plain" --no-text --quiet
expect 0 "the fused base records the checkpoint" -- "$G" st inspect "$T/fused/base.safetensors"
has "merged_lora: $L/good.safetensors"

# model merge at both precisions, with the VAE.
for P in bf16 f32; do
    expect 0 "merge $P" -- "$G" model merge --base "$FIX/tiny_dit_f32.safetensors" --lora "$L/good.safetensors" \
        --vae "$REL/Wan2.1_VAE.pth" --vae-out "$T/vae-$P.safetensors" --out "$T/merged-$P.safetensors" --precision "$P" --quiet
    has "good.safetensors: $SUMMARY"
    expect 0 "the $P merge loads as the tiny network" -- "$G" model inspect --config "$CFG" --variant camera=none,lora=0 \
        --parts base --weights "$T/merged-$P.safetensors,$T/vae-$P.safetensors"
done
expect 0 "st inspect bf16" -- "$G" st inspect "$T/merged-bf16.safetensors"
has "merge_precision: bf16"
expect 2 "merge without --out" -- "$G" model merge --base "$FIX/tiny_dit_f32.safetensors" --lora "$L/good.safetensors"
expect 2 "--vae without --vae-out" -- "$G" model merge --base "$FIX/tiny_dit_f32.safetensors" --lora "$L/good.safetensors" \
    --vae "$REL/Wan2.1_VAE.pth" --out "$T/x.safetensors"
expect 1 "a precision that is none" -- "$G" model merge --base "$FIX/tiny_dit_f32.safetensors" --lora "$L/good.safetensors" \
    --out "$T/x.safetensors" --precision fp8
one_line "--precision: 'fp8' is not bf16 or f32"

# Restoring with the fused base runs and gives other frames than the plain base.
release_rooms 1
for K in fused plain; do
    expect 0 "restore with the $K base" -- "$G" restore --ckpt "$T/$K/base.safetensors" --clips "$D" --split eval \
        --sampler released --compose decoded --out "$T/restored-$K" --quiet --threads 1
done
check "the fused base restores differently" test "$(cat "$T"/restored-fused/*/*.png 2>/dev/null | md5sum)" != \
    "$(cat "$T"/restored-plain/*/*.png 2>/dev/null | md5sum)"
check "restored frames written" test -n "$(ls "$T"/restored-fused/*/*.png 2>/dev/null)"

# The release's metric: scikit-image's PSNR and SSIM; the identity pipeline reproduces the
# baseline under it too.
expect 0 "eval with the release's metric" -- "$G" eval --ckpt "$T/fused/base.safetensors" --clips "$D" \
    --sampler released --compose decoded --metric release --quiet --threads 1 --json "$T/eval.json"
has "release metric"
check "the JSON names the metric" grep -qE '"metric":[[:space:]]*"release"' "$T/eval.json"
expect 0 "identity under the release's metric" -- "$G" eval --ckpt "$T/fused/base.safetensors" --clips "$D" --identity \
    --metric release --quiet --threads 1
has "identity check passed"
expect 2 "an unknown metric" -- "$G" eval --ckpt "$T/fused/base.safetensors" --clips "$D" --metric lpips

# The official camera encoder (not on the release's inference path), on the cameras and
# weights test_camera_official writes.
check "the camera files are written" "$(dirname "$G")/test_camera_official" --write-fixtures "$L"
expect 0 "model run --part camera" -- "$G" model run --part camera --config "$CFG" --weights "$L/camera_weights.safetensors" \
    --inputs "$L/camera_inputs.safetensors" --out "$T/camera_out.safetensors" --quiet
expect 0 "st inspect of the camera outputs" -- "$G" st inspect "$T/camera_out.safetensors"
has "[5, 32, 32, 6]"
has "[1, 6, 8, 32, 32]"
has "[1, 8, 32]"
expect 1 "outputs are not camera inputs" -- "$G" model run --part camera --config "$CFG" \
    --weights "$L/camera_weights.safetensors" --inputs "$T/camera_out.safetensors" --out "$T/x.safetensors"
one_line "unknown input plucker"
expect 1 "the wrong weights" -- "$G" model run --part camera --config "$CFG" --weights "$L/good.safetensors" \
    --inputs "$L/camera_inputs.safetensors" --out "$T/x.safetensors"
one_line "dxo_patch_embed.weight"

# Bad checkpoints: exit 1, one line naming the key or the file, nothing written.
bad_lora() {
    expect 1 "$1" -- "$G" model import --from "$REL" --config "$CFG" --lora "$L/$1.safetensors" --out "$T/o-$1" --no-text
    one_line "$2"
    check "nothing written for $1" test -z "$(ls -A "$T/o-$1" 2>/dev/null)"
    expect 1 "merge $1" -- "$G" model merge --base "$FIX/tiny_dit_f32.safetensors" --lora "$L/$1.safetensors" \
        --out "$T/m-$1.safetensors"
    one_line "$2"
    check "no merged file for $1" test ! -e "$T/m-$1.safetensors"
}
bad_lora missing_block "pipe.dit.blocks.5.self_attn.q.lora_B.default.weight: the DiT has no weight blocks.5.self_attn.q.weight"
bad_lora vace_under_dit "pipe.dit.vace_blocks.0.ffn.2.lora_B.default.weight: the DiT has no weight vace_blocks.0.ffn.2.weight"
bad_lora wrong_shape "wrong_shape.safetensors: pipe.dit.blocks.1.self_attn.o.lora_B.default.weight [32, 4] and its lora_A [4, 31] do not fit the base tensor blocks.1.self_attn.o.weight [32, 32]"
bad_lora b_without_a "pipe.dit.blocks.0.ffn.0.lora_B.default.weight has no partner pipe.dit.blocks.0.ffn.0.lora_A.default.weight"
bad_lora not_safetensors "not_safetensors.safetensors: header length"
bad_lora truncated "truncated.safetensors: tensor"
expect 1 "a missing checkpoint" -- "$G" model merge --base "$FIX/tiny_dit_f32.safetensors" --lora "$L/none.safetensors" \
    --out "$T/x.safetensors"
one_line "none.safetensors"

cli_finish
