#!/bin/bash
# gaussvid model import: the committed tiny release folders (tests/fixtures/release: BF16
# shards with an index + Wan2.1_VAE.pth; one F32 safetensors file) become a base checkpoint
# and VAE that model inspect checks, and that train (GaussVid fine-tuning) and restore take;
# the release files are also checked directly by model inspect; bad release folders fail
# with one line naming the file, and leave nothing written.
# Usage: bash model_import.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup model_import "$1"
source "$(dirname "$0")/lib/release_fixture.sh" # FIX, REL, CFG (the tiny config with latent statistics)

expect 0 "help" -- "$G" model import --help
has "usage: gaussvid model import"
expect 2 "no --from" -- "$G" model import --config "$CFG" --out "$T/x"

# The release files as published, checked against the config without importing.
expect 0 "inspect the release files" -- "$G" model inspect --config "$CFG" --variant camera=none,lora=0 --parts base \
    --weights "$REL/diffusion_pytorch_model.safetensors.index.json" --weights "$REL/Wan2.1_VAE.pth"

# The sharded BF16 release (Wan2.1-VACE-14B's layout), with the umT5 encoder and its tokenizer
# (whose text context needs a build with libsentencepiece).
OUT="$T/imported"
SPM=0
ldd "$G" | grep -q sentencepiece && SPM=1
TEXT_FLAG=()
[ "$SPM" -eq 1 ] || TEXT_FLAG=(--no-text)
expect 0 "import the BF16 shards" -- "$G" model import --from "$REL" --config "$CFG" --out "$OUT" --quiet "${TEXT_FLAG[@]}"
has "131 tensors, 75184 values (131 BF16)"
has "VAE 146 tensors, 203295 values"
exists "$OUT/base.safetensors"
exists "$OUT/vae.safetensors"
if [ "$SPM" -eq 1 ]; then
    has "is 4 tokens -> $OUT/text_context.safetensors" # tiny's text_len is 4: three pieces and </s>
    expect 0 "st inspect of the text context" -- "$G" st inspect "$OUT/text_context.safetensors"
    has "text_context"
    has "[4, 16]"
    has "prompt: Remove degradation and restore clean video."
    expect 1 "an encoder without its tokenizer" -- "$G" model import --from "$REL" --config "$CFG" --out "$T/o0" \
        --tokenizer "$T/none.model"
    one_line "none.model: cannot open"
else
    echo "built without libsentencepiece: text context checks skipped"
fi
[ -z "$(ls -A "$OUT" | grep -v -e '^base.safetensors$' -e '^vae.safetensors$' -e '^text_context.safetensors$')" ]
check_rc "nothing else left in the output folder" $?
expect 0 "the imported files load" -- "$G" model inspect --config "$CFG" --variant camera=none,lora=0 --parts base \
    --weights "$OUT/base.safetensors,$OUT/vae.safetensors"
expect 0 "st inspect of the base" -- "$G" st inspect "$OUT/base.safetensors"
has "BF16"
has "kind: base"

# The single-file F32 release (Wan2.1-VACE-1.3B's layout), with a config.json that agrees.
R32="$T/release-f32"
mkdir -p "$R32"
ln -s "$FIX/tiny_dit_f32.safetensors" "$R32/diffusion_pytorch_model.safetensors"
ln -s "$REL/Wan2.1_VAE.pth" "$R32/Wan2.1_VAE.pth"
printf '{"_class_name": "VaceWanModel", "dim": 32, "ffn_dim": 64, "num_heads": 2, "num_layers": 2, "vace_layers": [0, 1], "in_dim": 4}\n' \
    > "$R32/config.json"
expect 0 "import the F32 file" -- "$G" model import --from "$R32" --config "$CFG" --out "$T/imported32" --quiet
has "(131 F32)"
has "config.json: agrees with tiny"
has "no text context (no text encoder and tokenizer): the network gets zeros"

# Fine-tuning (LoRA + a fresh camera encoder) from the imported base, and restoring with the
# base (zero-shot) and with the fine-tuned checkpoint, on a small generated dataset.
release_rooms 2
expect 0 "train from the imported base" -- "$G" train --clips "$D" --base "$OUT/base.safetensors" --config "$CFG" \
    --steps 2 --batch 1 --out "$T/ft.safetensors" --quiet --threads 1
exists "$T/ft.safetensors"
expect 0 "restore with the imported base" -- "$G" restore --ckpt "$OUT/base.safetensors" --clips "$D" --split eval \
    --out "$T/restored-base" --quiet --threads 1
expect 0 "restore with the fine-tuned checkpoint" -- "$G" restore --ckpt "$T/ft.safetensors" --clips "$D" --split eval \
    --out "$T/restored-ft" --quiet --threads 1

# The import benchmark on a stand-in release of the tiny shapes (two shards and an index).
expect 0 "bench import" -- "$G" bench import --dir "$T/bench" --preset tiny --shards 2
has "model import:"
[ ! -e "$T/bench/release" ]
check_rc "bench import removes its files" $?

# Bad release folders: exit 1, one line naming the file; nothing written.
mkdir -p "$T/empty"
expect 1 "no files" -- "$G" model import --from "$T/empty" --config "$CFG" --out "$T/o1"
one_line "no DiT weights (diffusion_pytorch_model.safetensors.index.json or diffusion_pytorch_model.safetensors)"
expect 1 "another network" -- "$G" model import --from "$REL" --config small --out "$T/o2"
one_line "diffusion_pytorch_model.safetensors.index.json: the weights do not load"
BADCFG="$T/release-badcfg"
mkdir -p "$BADCFG"
ln -s "$FIX/tiny_dit_f32.safetensors" "$BADCFG/diffusion_pytorch_model.safetensors"
ln -s "$REL/Wan2.1_VAE.pth" "$BADCFG/Wan2.1_VAE.pth"
printf '{"dim": 64}\n' > "$BADCFG/config.json"
expect 1 "config.json disagrees" -- "$G" model import --from "$BADCFG" --config "$CFG" --out "$T/o3"
one_line "config.json: dim is 64, but the config tiny has 32"
CUT="$T/release-cut"
mkdir -p "$CUT"
ln -s "$FIX/tiny_dit_f32.safetensors" "$CUT/diffusion_pytorch_model.safetensors"
head -c 500000 "$REL/Wan2.1_VAE.pth" > "$CUT/Wan2.1_VAE.pth"
expect 1 "truncated VAE" -- "$G" model import --from "$CUT" --config "$CFG" --out "$T/o4"
one_line "Wan2.1_VAE.pth: no zip end-of-central-directory record (truncated file?)"
[ -z "$(ls -A "$T/o4" 2>/dev/null)" ]
check_rc "nothing written after a failure" $?
SHARD="$T/release-one-shard"
mkdir -p "$SHARD"
cp "$REL/diffusion_pytorch_model.safetensors.index.json" "$REL/diffusion_pytorch_model-00001-of-00002.safetensors" "$SHARD/"
ln -s "$REL/Wan2.1_VAE.pth" "$SHARD/Wan2.1_VAE.pth"
expect 1 "a missing shard" -- "$G" model import --from "$SHARD" --config "$CFG" --out "$T/o5"
one_line "diffusion_pytorch_model-00002-of-00002.safetensors: cannot open"

cli_finish
