#!/bin/bash
# gaussvid pretrain / train: exit codes (0 ok, 1 failure, 2 usage), the files a run writes, an
# interrupted run resumed bit for bit (the tensor data of the two files compared byte by byte),
# the ablation flags reaching the run, and bad inputs (no manifest, another network, a corrupt
# or foreign checkpoint, another run's checkpoint) failing with one line.
# Fixtures: two tiny synthesised scenes, a dataset built with a few 3DGS iterations, the tiny
# preset's VAE trained for two steps.
# Usage: bash train.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup train "$1"

# data_bytes FILE: the tensor data of a safetensors file (everything after the header), so two
# files whose metadata differ (times) can be compared tensor for tensor.
data_bytes() {
    local n
    n=$(od -An -tu8 -N8 "$1" | tr -d ' ')
    tail -c +$((9 + n)) "$1"
}
same_data() { cmp -s <(data_bytes "$1") <(data_bytes "$2"); }
differ() { ! same_data "$1" "$2"; }
# meta FILE KEY: one metadata value, from `st inspect --json`.
meta() { "$G" st inspect --json "$1" | tr ',' '\n' | grep -F "\"$2\":" | head -1; }

cd "$T" || exit 1
expect 0 "synth a" -- "$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out A --quiet
expect 0 "synth b" -- "$G" scene synth --seed 4 --frames 14 --size 32x32 --samples 1 --out B --quiet
expect 0 "dataset" -- "$G" dataset build --scenes A B --eval-scenes B --intervals 6,8 --iters 20 --clips-per-run 2 \
    --seed 5 --out D --quiet --threads 1
expect 0 "vae" -- "$G" vae train --config tiny --scenes A --steps 2 --crop 32x32 --stats-clips 2 --out vae.safetensors --quiet

# Help and usage errors.
expect 0 "pretrain help" -- "$G" pretrain --help
has "usage: gaussvid pretrain"
expect 0 "train help" -- "$G" train --help
has "--no-progressive-loss"
expect 0 "listed" -- "$G" help
has "pretrain"
expect 2 "pretrain without --out" -- "$G" pretrain --clips D --vae vae.safetensors --config tiny
expect 2 "pretrain without --vae" -- "$G" pretrain --clips D --config tiny --out x.safetensors
expect 2 "pretrain zero steps" -- "$G" pretrain --clips D --vae vae.safetensors --config tiny --steps 0 --out x.safetensors
expect 2 "pretrain bad variant" -- "$G" pretrain --clips D --vae vae.safetensors --config tiny --variant camera=sideways --out x.safetensors
one_line "sideways"
expect 2 "train without --base" -- "$G" train --clips D --out x.safetensors
expect 2 "train negative seed" -- "$G" train --clips D --base b --out x.safetensors --seed -2

# Pretraining: straight, and interrupted after 2 of 4 steps then resumed.
PRE=(--clips D --config tiny --vae vae.safetensors --steps 4 --batch 2 --checkpoint-every 1 --seed 1 --quiet)
expect 0 "pretrain" -- "$G" pretrain "${PRE[@]}" --out base.safetensors --log pre.tsv
has "base.safetensors: base tiny pretrained for 4 steps"
exists base.safetensors
exists base.safetensors.ckpt
exists D/latents_*_both.safetensors
check "log has a header and 4 steps" test "$(wc -l <pre.tsv)" -eq 5
check "base kind" grep -qE '"kind":[[:space:]]*"base"' <("$G" st inspect --json base.safetensors)
expect 0 "pretrain, interrupted" -- "$G" pretrain "${PRE[@]}" --out base2.safetensors --stop-after 2
has "pretrained to step 2 of 4"
check "no final file before the end" test ! -e base2.safetensors
expect 0 "pretrain, resumed" -- "$G" pretrain "${PRE[@]}" --out base2.safetensors --resume
check "resumed pretraining is bit-exact" same_data base.safetensors base2.safetensors
check "resumed pretraining records the same loss average" test "$(meta base.safetensors loss)" = "$(meta base2.safetensors loss)"
check "moments bit-exact too" same_data base.safetensors.ckpt base2.safetensors.ckpt
expect 2 "render context above 1" -- "$G" pretrain "${PRE[@]}" --out x.safetensors --render-context 1.5
one_line "render-context"
expect 0 "pretrain with renders in the context" -- "$G" pretrain "${PRE[@]}" --out rc.safetensors --render-context 1
check "render context recorded" grep -q "render_context=1" <(meta rc.safetensors training)
check "renders in the context train other weights" differ base.safetensors rc.safetensors
expect 0 "pretrain on windows" -- "$G" pretrain "${PRE[@]}" --out pcrop.safetensors --crop 1x1
check "pretraining crop recorded" grep -q "crop=1x1" <(meta pcrop.safetensors training)
check "pretraining on windows trains other weights" differ base.safetensors pcrop.safetensors
expect 2 "pretrain bad crop" -- "$G" pretrain "${PRE[@]}" --out x.safetensors --crop 0x2
one_line "rows x columns"

# Fine-tuning: straight and resumed, with the curriculum and the progressive loss on (S_w 1).
FT=(--clips D --base base.safetensors --steps 4 --batch 2 --latent-warmup 1 --checkpoint-every 2 --quiet)
expect 0 "train" -- "$G" train "${FT[@]}" --out ft.safetensors
has "ft.safetensors: tiny fine-tuned for 4 steps"
check "finetune kind" grep -qE '"kind":[[:space:]]*"finetune"' <("$G" st inspect --json ft.safetensors)
check "holds LoRA" grep -q "lora_B.weight" <("$G" st inspect ft.safetensors)
expect 0 "train, interrupted" -- "$G" train "${FT[@]}" --out ft2.safetensors --stop-after 1
expect 0 "train, resumed" -- "$G" train "${FT[@]}" --out ft2.safetensors --resume
check "resumed fine-tuning is bit-exact" same_data ft.safetensors ft2.safetensors
# The training scenes recorded (docs/TRAINING.md): the train split's (A; B is the eval split),
# and a fine-tuning on other clips (B's alone) adds them to its base's.
check "base records its training scene" test "$(meta base.safetensors scenes | tr -d " \t")" = '"scenes":"A"'
check "fine-tuning records it too" test "$(meta ft.safetensors scenes | tr -d " \t")" = '"scenes":"A"'
expect 0 "dataset of B" -- "$G" dataset build --scenes B --intervals 6 --iters 20 --clips-per-run 1 --seed 5 --out DB \
    --quiet --threads 1
expect 0 "train on B from a base of A" -- "$G" train --clips DB --base base.safetensors --steps 1 --batch 1 --quiet \
    --out ftb.safetensors
check "the base's scenes and its own" grep -qx "  scenes: A,B" <("$G" st inspect ftb.safetensors)
check "resumed fine-tuning records the same loss average" test "$(meta ft.safetensors loss)" = "$(meta ft2.safetensors loss)"
expect 1 "resume with other options" -- "$G" train "${FT[@]}" --out ft2.safetensors --resume --lr 3e-4
one_line "written with other training options"

# The learning-rate schedule: constant by default (recorded as before), a linear decay to 0
# logged step by step (lr (S - s) / S at 0-based step s), recorded, other weights, resumed.
check "constant schedule recorded as before" grep -q "min_lr=0.0001 warmup=0 cosine=0" <(meta ft.safetensors training)
expect 2 "unknown schedule" -- "$G" train "${FT[@]}" --out x.safetensors --lr-schedule step
one_line "expected constant, cosine or linear"
expect 0 "linear decay" -- "$G" train "${FT[@]}" --out lin.safetensors --lr-schedule linear --log lin.tsv
check "linear decay logged" test "$(cut -f3 lin.tsv | tr '\n' ' ')" = "lr 0.0001 7.5e-05 5e-05 2.5e-05 "
check "linear decay recorded" grep -q "min_lr=0 warmup=0 schedule=linear" <(meta lin.safetensors training)
check "linear decay trains other weights" differ ft.safetensors lin.safetensors
expect 0 "linear decay, interrupted" -- "$G" train "${FT[@]}" --out lin2.safetensors --lr-schedule linear --stop-after 2
expect 0 "linear decay, resumed" -- "$G" train "${FT[@]}" --out lin2.safetensors --lr-schedule linear --resume
check "resumed linear decay is bit-exact" same_data lin.safetensors lin2.safetensors
expect 0 "cosine decay" -- "$G" train "${FT[@]}" --out cos.safetensors --lr-schedule cosine --log cos.tsv
check "cosine decay logged" test "$(cut -f3 cos.tsv | tr '\n' ' ')" = "lr 0.0001 8.54e-05 5e-05 1.46e-05 "

# Validation on the eval split (scene B, n = 6 and 8) at steps 0, 2 and 4 leaves the run alone.
expect 2 "val log without clips" -- "$G" train "${FT[@]}" --out x.safetensors --val-log v.tsv
one_line "need --val-clips"
expect 0 "train with validation" -- "$G" train "${FT[@]}" --out val.safetensors --val-clips D --val-log val.tsv
check "validation leaves the weights bit-exact" same_data ft.safetensors val.safetensors
check "validation log: header and 3 rows at each of steps 0, 2, 4" test "$(wc -l <val.tsv)" -eq 10
check "validation rows per n and all" test "$(cut -f2 val.tsv | sort | uniq -c | tr -s ' ' | tr '\n' ,)" = " 3 6, 3 8, 3 all, 1 n,"

# Windows of the clips (tiny preset: a grid of 2x2 tokens): recorded, other weights, resumed
# bit for bit; a window as large as the grid is the whole clip, the same weights.
expect 2 "bad crop" -- "$G" train "${FT[@]}" --out x.safetensors --crop 2by2
one_line "rows x columns"
expect 0 "train on windows" -- "$G" train "${FT[@]}" --out crop.safetensors --crop 1x2
check "crop recorded" grep -q "crop=1x2" <(meta crop.safetensors training)
check "windows train other weights" differ ft.safetensors crop.safetensors
expect 0 "train on windows, interrupted" -- "$G" train "${FT[@]}" --out crop2.safetensors --crop 1x2 --stop-after 1
expect 0 "train on windows, resumed" -- "$G" train "${FT[@]}" --out crop2.safetensors --crop 1x2 --resume
check "resumed training on windows is bit-exact" same_data crop.safetensors crop2.safetensors
expect 0 "window of the whole grid" -- "$G" train "${FT[@]}" --out whole.safetensors --crop 2x5
check "a window of the whole grid trains the weights of no window" same_data ft.safetensors whole.safetensors

# Each clip's loss relative to its identity's: recorded, other weights.
expect 0 "relative loss" -- "$G" train "${FT[@]}" --out rel.safetensors --relative-loss
check "relative loss recorded" grep -q "relative_loss=1" <(meta rel.safetensors training)
check "relative loss trains other weights" differ ft.safetensors rel.safetensors

# Each ablation flag reaches the run and changes the trained weights.
expect 0 "shuffle" -- "$G" train "${FT[@]}" --out shuffle.safetensors --no-curriculum
check "curriculum off recorded" grep -q "curriculum=0" <(meta shuffle.safetensors training)
check "shuffle trains other weights" differ ft.safetensors shuffle.safetensors
expect 0 "no progressive loss" -- "$G" train "${FT[@]}" --out noprog.safetensors --no-progressive-loss
check "progressive off recorded" grep -q "progressive=0" <(meta noprog.safetensors training)
check "no progressive loss trains other weights" differ ft.safetensors noprog.safetensors
for v in camera=none camera=early camera=monolithic anchors=first anchors=none per-frame; do
    expect 0 "variant $v" -- "$G" train "${FT[@]}" --variant "$v" --out "v_$v.safetensors"
done
check "camera none has no camera encoder" test "$("$G" st inspect v_camera=none.safetensors | grep -c camera_encoder)" -eq 0
check "monolithic has its single conv" grep -q "camera_encoder.conv.weight" <("$G" st inspect v_camera=monolithic.safetensors)
check "per-frame recorded" grep -qE 'per_frame[^,}]*true' <("$G" st inspect --json v_per-frame.safetensors)

# Bad inputs: exit 1 and one line naming the problem.
mkdir -p empty
expect 1 "no manifest" -- "$G" pretrain --clips empty --config tiny --vae vae.safetensors --out x.safetensors --quiet
one_line "no manifest.json"
expect 1 "missing VAE" -- "$G" pretrain --clips D --config tiny --vae nothere.safetensors --out x.safetensors --quiet
one_line "nothere.safetensors"
expect 1 "config mismatch" -- "$G" train "${FT[@]}" --config small --out x.safetensors
one_line "another network"
head -c 3000 ft.safetensors >cut.safetensors
expect 1 "corrupt base" -- "$G" train "${FT[@]}" --base cut.safetensors --out x.safetensors
one_line "cut.safetensors"
expect 1 "not a checkpoint" -- "$G" train "${FT[@]}" --base vae.safetensors --out x.safetensors
one_line "not a gaussvid checkpoint"
cp ft.safetensors.ckpt y.safetensors.ckpt
head -c 5000 ft.safetensors.ckpt >y.safetensors.ckpt
expect 1 "corrupt resume checkpoint" -- "$G" train "${FT[@]}" --out y.safetensors --resume
one_line "y.safetensors.ckpt"
check "nothing half-written" test ! -e x.safetensors -a ! -e y.safetensors

# The throughput benchmark's smoke run (tiny preset, 32x32 clips).
expect 0 "bench train help" -- "$G" bench train --help
has "clips per second"
expect 0 "bench train quick" -- "$G" bench train --quick --preset tiny --height 32 --width 32 --json
has '"run": "fine-tune"'
has '"max_rss_mib"'
has '"seconds_per_clip_cached"'
expect 2 "bench train bad size" -- "$G" bench train --height 0
cli_finish
