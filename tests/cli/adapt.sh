#!/bin/bash
# gaussvid adapt: a scene checkpoint from a scene's internal pairs (the adapters alone, the
# gate recorded); an interrupted adaptation resumed to the bytes of an uninterrupted one; a
# finished one not redone; pairs from each view left out alone (--subsets); bad inputs (too few training views, a base of another network or
# with a VAE that packs frames, a missing model) failing with one line and writing nothing.
# restore and eval with a scene checkpoint: a closed gate leaves the renders bit-identical
# and says so; an open gate restores.
# Fixtures: a tiny synthesised scene (18 frames of 32x32), the tiny preset with a VAE of
# temporal factor 1 (tiny1.json), its VAE and base trained for two steps.
# Usage: bash adapt.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup adapt "$1"

data_bytes() {
    local n
    n=$(od -An -tu8 -N8 "$1" | tr -d ' ')
    tail -c +$((9 + n)) "$1"
}
same_data() { cmp -s <(data_bytes "$1") <(data_bytes "$2"); }
meta() { "$G" st inspect --json "$1" | tr ',' '\n' | grep -F "\"$2\":" | head -1; }
files_differ() { ! cmp -s "$1" "$2"; }


cd "$T" || exit 1
tiny1_config tiny1.json
expect 0 "synth" -- "$G" scene synth --seed 3 --frames 18 --size 32x32 --samples 1 --out A --quiet
expect 0 "dataset" -- "$G" dataset build --scenes A --intervals 6 --iters 20 --clips-per-run 2 --seed 5 --out D \
    --quiet --threads 1
expect 0 "vae" -- "$G" vae train --config tiny1.json --scenes A --steps 2 --crop 32x32 --stats-clips 2 \
    --out vae.safetensors --quiet
expect 0 "base" -- "$G" pretrain --clips D --config tiny1.json --vae vae.safetensors --steps 2 --batch 2 \
    --out base.safetensors --quiet

# Help and usage errors.
expect 0 "help" -- "$G" adapt --help
has "usage: gaussvid adapt"
has "--gate-margin"
expect 0 "listed" -- "$G" help
has "adapt"
expect 2 "no scene" -- "$G" adapt --interval 3 --base base.safetensors --out x.safetensors
expect 2 "interval 1" -- "$G" adapt --scene A --interval 1 --base base.safetensors --out x.safetensors
expect 2 "unknown schedule" -- "$G" adapt --scene A --interval 3 --base base.safetensors --out x.safetensors \
    --lr-schedule step
one_line "expected constant, cosine or linear"

# 18 frames at n = 4: training views 0, 4, 8, 12, 16; three internal clips, the second held back.
AD=(--scene A --interval 4 --base base.safetensors --config tiny1.json --iters 20 --steps 4 --val-every 2 --threads 1)
expect 0 "adapt" -- "$G" adapt "${AD[@]}" --out a.safetensors
has "a.safetensors: A n=4: 2 internal clips trained on, 1 held back"
has "gate "
exists a.safetensors.work/pairs/manifest.json
exists a.safetensors.work/pairs/clips/A_n08_002.safetensors
exists a.safetensors.work/best.safetensors
check "validation at steps 0, 2, 4" test "$(grep -c all a.safetensors.work/val.tsv)" -eq 3
check "kind scene" grep -qE '"kind":[[:space:]]*"scene"' <("$G" st inspect --json a.safetensors)
check "gate recorded" grep -qE '"gate":[[:space:]]*"(open|closed)"' <("$G" st inspect --json a.safetensors)
check "base recorded" grep -q "base.safetensors" <(meta a.safetensors base)
check "two subsets recorded" grep -q '"2"' <(meta a.safetensors subsets)

# Each interior view left out alone (--subsets 99): one 3DGS run per interior view, K recorded
# in the pairs' folder and the scene checkpoint; fewer than two subsets is a usage error.
expect 2 "one subset" -- "$G" adapt "${AD[@]}" --subsets 1 --out k1.safetensors
one_line "--subsets and --hold-every K >= 2"
expect 0 "adapt, each view alone" -- "$G" adapt "${AD[@]}" --subsets 99 --steps 2 --out k.safetensors
check "a run per interior view" grep -q "subset 3 of 3" "$T/err" "$T/out"
check "K in the pairs' manifest" grep -qE '"subsets":[[:space:]]*99' k.safetensors.work/pairs/manifest.json
check "K in the scene checkpoint" grep -q '"99"' <(meta k.safetensors subsets)
check "linear decay recorded" grep -q "schedule=linear" <(meta a.safetensors training)
check "holds LoRA" grep -q "lora_B.weight" <("$G" st inspect a.safetensors)
check "holds the camera encoder" grep -q "camera_encoder" <("$G" st inspect a.safetensors)
check "holds only the adapters" test "$("$G" st inspect a.safetensors | grep -cE 'patch_embedding|self_attn.q.weight|vace_blocks.0.after_proj.weight')" -eq 0
check "smaller than its base" test "$(stat -c %s a.safetensors)" -lt "$(stat -c %s base.safetensors)"
check "the internal clips are a dataset" "$G" dataset stats a.safetensors.work/pairs

# Done: not redone.
expect 0 "adapt again" -- "$G" adapt "${AD[@]}" --out a.safetensors
has "already adapted"

# Interrupted after step 2 (the pairs copied, as a resumed build finds them), then resumed:
# the adapters of the uninterrupted run, bit for bit.
mkdir -p b.work && cp -r a.safetensors.work/pairs b.work/
expect 0 "adapt, interrupted" -- "$G" adapt "${AD[@]}" --out b.safetensors --work b.work --stop-after 2
has "stopped at step 2 of 4"
check "nothing written before the end" test ! -e b.safetensors
expect 0 "adapt, resumed" -- "$G" adapt "${AD[@]}" --out b.safetensors --work b.work
check "resumed adaptation is bit-exact" same_data a.safetensors b.safetensors
check "resumed fine-tuning is bit-exact" same_data a.safetensors.work/train.safetensors b.work/train.safetensors
check "the same step kept" test "$(meta a.safetensors best_step)" = "$(meta b.safetensors best_step)"

# The gate: a margin no gain reaches closes it, a negative one opens it (the work reused).
expect 0 "gate closed" -- "$G" adapt "${AD[@]}" --out closed.safetensors --work b.work --gate-margin 1000
has "gate closed"
has "leave this scene's renders unchanged"
# One held-back frame is too little evidence for the default --gate-min-frames 2.
expect 0 "gate, too few frames" -- "$G" adapt "${AD[@]}" --out few.safetensors --work b.work --gate-margin -1000
has "gate closed"
has "too few held-back frames to trust"
check "the minimum recorded" test "$(meta few.safetensors gate_min_frames | grep -oE '[0-9]+')" = 2
expect 0 "gate open" -- "$G" adapt "${AD[@]}" --out open.safetensors --work b.work --gate-margin -1000 --gate-min-frames 1
has "gate open"
check "same adapters either way" same_data closed.safetensors open.safetensors
# The do-no-harm clips: built beside the pairs, measured by the gate, recorded.
has "their do-no-harm clips"
check "the do-no-harm clips are a dataset" "$G" dataset stats b.work/harm
check "their frames recorded" test "$(meta open.safetensors harm_frames | grep -oE '[0-9]+')" = 1
check "the loss allowed recorded" grep -q "0.05" <(meta open.safetensors harm_max_loss_db)
expect 2 "a negative loss allowed" -- "$G" adapt "${AD[@]}" --out x.safetensors --harm-max-loss -1
# Fine-tuned on them too: other training data, so another fine-tuning (not the b.work one).
expect 0 "adapt --harm-train" -- "$G" adapt "${AD[@]}" --out h.safetensors --work h.work --harm-train
check "trained with them" grep -qF "1 held back, each with its do-no-harm clip" "$T/err"
check "another trajectory than without them" files_differ a.safetensors.work/train.safetensors h.work/train.safetensors
expect 1 "a work folder of other data" -- "$G" adapt "${AD[@]}" --out h2.safetensors --work b.work --harm-train --steps 6

# restore and eval honour the gate, on the scene's renders at n = 4 (a dataset of scene A).
expect 0 "renders at n = 4" -- "$G" dataset build --scenes A --intervals 4 --iters 20 --clips-per-run 2 --seed 5 \
    --out R --quiet --threads 1
clips=(R/clips/*.safetensors)
check "two clips to restore" test "${#clips[@]}" -eq 2
expect 0 "restore, gate closed" -- "$G" restore --ckpt closed.safetensors --clips R --out kept --save-clips --quiet
has "gate closed"
has "the renders are left unchanged"
for c in "${clips[@]}"; do
    check "closed gate: $(basename "$c") unchanged, byte for byte" cmp -s "$c" "kept/$(basename "$c")"
done
expect 0 "eval, gate closed" -- "$G" eval --ckpt closed.safetensors --clips R --split all --json closed.json --quiet
has "left unchanged"
check "eval JSON names the gate" grep -qE '"gate":[[:space:]]*"closed"' closed.json
psnrs() { grep -oE '"psnr":[[:space:]]*[-0-9.e+]+' "$1" | head -2 | sed 's/.*://' | tr -d ' ' | uniq | wc -l; }
check "closed gate: restored PSNR = baseline PSNR" test "$(psnrs closed.json)" -eq 1
expect 0 "restore, gate open" -- "$G" restore --ckpt open.safetensors --clips R --out restored --save-clips --quiet
has "gate open"
has "the renders are restored"
check "open gate: the network restores" files_differ "${clips[0]}" "restored/$(basename "${clips[0]}")"
# One load (issue 40): the restore opens each weight file once: the scene checkpoint, its base
# (checksummed through that open) and the VAE the base names. Counted with strace when present.
if command -v strace >/dev/null && strace -f -e trace=openat -o /dev/null true 2>/dev/null; then
    strace -f -e trace=openat,open -o opens.log "$G" restore --ckpt open.safetensors --clips R --out once --quiet \
        >/dev/null 2>&1
    check "restore under strace" cmp -s "restored/$(basename "${clips[0]}" .safetensors)/f2.png" \
        "once/$(basename "${clips[0]}" .safetensors)/f2.png"
    for w in open.safetensors base.safetensors vae.safetensors; do
        n=$(grep -v ENOENT opens.log | grep -cE "(\"|/)$w\"")
        check "restore opens $w once (opened $n times)" test "$n" -eq 1
    done
else
    echo "skipped: no working strace to count the opens"
fi
# ... and its memory does not grow with the base's size: a base padded with 1 GiB (sparse) is
# checksummed through its mapping, a piece at a time. It is found beside the scene checkpoint
# (its name is not in this folder); its checksum is read off the refusal of the unpatched record.
mkdir -p big
python3 "$(dirname "$0")/lib/pad_checkpoint.py" pad base.safetensors big/padded.safetensors $((1 << 30))
python3 "$(dirname "$0")/lib/pad_checkpoint.py" meta open.safetensors big/open.safetensors base=padded.safetensors
expect 1 "the padded base is another file" -- "$G" restore --ckpt big/open.safetensors --clips R --out big/x --quiet
sum=$(grep -oE 'checksum fnv1a64:[0-9a-f]{16}' "$T/err" | head -1 | cut -d' ' -f2)
check "the refusal names the padded base's checksum" test -n "$sum"
python3 "$(dirname "$0")/lib/pad_checkpoint.py" meta open.safetensors big/open.safetensors base=padded.safetensors \
    "base_checksum=$sum"
if [ -x /usr/bin/time ]; then
    expect 0 "restore over a 1 GiB base" -- /usr/bin/time -f "peak %M kB" "$G" restore --ckpt big/open.safetensors \
        --clips R --out big/restored --quiet
    peak=$(grep -oE 'peak [0-9]+ kB' "$T/err" | cut -d' ' -f2)
    check "peak memory ${peak} kB, far below the base's 1 GiB" test "${peak:-999999999}" -lt 262144
    check "the same restoration" cmp -s "restored/$(basename "${clips[0]}" .safetensors)/f2.png" \
        "big/restored/$(basename "${clips[0]}" .safetensors)/f2.png"
else
    echo "skipped: no /usr/bin/time to read the peak memory"
fi
rm -rf big
expect 0 "restore one clip, gate closed" -- "$G" restore --ckpt closed.safetensors --clip "${clips[1]}" --out one --quiet
has "left unchanged"
# The gate's composition (unseen by default; its pairs carry coverage planes): recorded, and
# restore composes as the gate measured; another composition asked for is refused.
expect 0 "adapt, unseen composition" -- "$G" adapt "${AD[@]}" --out unseen.safetensors --work u.work \
    --gate-margin -1000 --gate-min-frames 1 --compose unseen
check "the composition recorded" grep -q '"unseen"' <(meta unseen.safetensors gate_compose)
has "not a test of the unseen composition"
check "the sampler line names it" grep -q "unseen composition" <("$G" st inspect --json unseen.safetensors)
expect 0 "restore, unseen composition" -- "$G" restore --ckpt unseen.safetensors --clips R --out ru --save-clips --quiet
has "unseen composition), so the renders are restored"
check "the unseen composition restores" files_differ "${clips[0]}" "ru/$(basename "${clips[0]}")"
expect 0 "adapt, residual composition" -- "$G" adapt "${AD[@]}" --out rescomp.safetensors --work u.work \
    --gate-margin -1000 --gate-min-frames 1 --compose residual
expect 0 "restore, residual composition" -- "$G" restore --ckpt rescomp.safetensors --clips R --out rr --save-clips --quiet
has "residual composition), so the renders are restored"
check "unseen composes otherwise than residual" files_differ "rr/$(basename "${clips[0]}")" "ru/$(basename "${clips[0]}")"
expect 1 "restore with another composition" -- "$G" restore --ckpt unseen.safetensors --clips R --out rx --compose residual --quiet
check "says why" grep -qF "its gate measured the unseen composition" "$T/err"
expect 2 "an unknown composition" -- "$G" adapt "${AD[@]}" --out x.safetensors --compose blend
# The step chosen by the held-back pairs' PSNR change: scored at every validation, the same
# trajectory as the latent choice (scoring never changes the network), and the kept step's
# score is the gate's own measurement of it.
mkdir -p e.work && cp -r a.safetensors.work/pairs a.safetensors.work/harm e.work/
expect 0 "adapt --early-stop psnr" -- "$G" adapt "${AD[@]}" --out e.safetensors --work e.work --early-stop psnr
check "scored at every validation" test "$(grep -c 'held-back PSNR change' "$T/err")" -eq 3
check "what chose the step recorded" grep -q "PSNR change" <(meta e.safetensors best_by)
has "kept (held-back PSNR change"
check "the same trajectory as the latent choice" same_data a.safetensors.work/train.safetensors e.work/train.safetensors
num() { meta "$1" "$2" | grep -oE '[-0-9.e+]+"?$' | tr -d '"'; }
check "the kept step's score is the gate's measurement" awk -v s="$(num e.safetensors val_gain_db)" \
    -v r="$(num e.safetensors gate_psnr_restored)" -v b="$(num e.safetensors gate_psnr_base)" \
    'BEGIN { if (s == "" || r == "" || b == "") exit 1; d = s - (r - b); exit !(d < 1e-6 && d > -1e-6) }'
expect 2 "an unknown early stop" -- "$G" adapt "${AD[@]}" --out x.safetensors --early-stop loss
# A scene checkpoint restores only its scene at its n: in a dataset with n = 4 and n = 6 it
# takes the two n = 4 clips; a clip file or a selection of another n is refused.
expect 0 "renders at n = 4 and 6" -- "$G" dataset build --scenes A --intervals 4,6 --iters 20 --clips-per-run 2 \
    --seed 5 --out R46 --quiet --threads 1
expect 0 "eval, scoped to n = 4" -- "$G" eval --ckpt open.safetensors --clips R46 --split all --json scoped.json --quiet
check "only the n = 4 clips" grep -qE '"clips":[[:space:]]*2[,}]' scoped.json
check "the JSON names the scene" grep -qE '"scene":[[:space:]]*"A"' scoped.json
check "no n = 6 row" test "$(grep -oE '"n":[[:space:]]*[0-9]+' scoped.json | sort -u | tr -d ' \t')" = '"n":4'
six=(R46/clips/A_n06_*.safetensors)
expect 1 "a clip of another n" -- "$G" restore --ckpt open.safetensors --clip "${six[0]}" --out other --quiet
one_line "a clip of A at n = 6, not of A at n = 4"
expect 1 "--interval of another n" -- "$G" eval --ckpt open.safetensors --clips R46 --interval 6 --quiet
one_line "adapted to A at n = 4, not to A at n = 6"

# The residual output (part of the default, given here alone): relearned from zero, so the step-0
# validation is the identity's loss exactly; the scene checkpoint holds the new head beside
# the adapters and restores through a network rebuilt for the variant over its base.
expect 0 "adapt, residual output" -- "$G" adapt "${AD[@]}" --variant residual --fresh-camera --out res.safetensors
step0=$(awk -F'\t' '$1 == 0 && $2 == "all" {print ($4 == $5)}' res.safetensors.work/val.tsv)
check "residual: step 0 validates at the identity" test "$step0" = 1
check "residual: the head is stored" grep -q '"head.head.weight"' <("$G" st inspect --json res.safetensors)
check "residual: the variant recorded" grep -q 'residual[^,]*true' <("$G" st inspect --json res.safetensors)
expect 0 "eval, residual scene checkpoint" -- "$G" eval --ckpt res.safetensors --clips R --split all --json res.json --quiet
check "residual: eval names the scene" grep -qE '"scene":[[:space:]]*"A"' res.json
expect 1 "resume with another variant" -- "$G" adapt "${AD[@]}" --variant base --out other.safetensors --work a.safetensors.work --quiet
one_line "another model config"

# Bad inputs: one line naming the problem, exit 1, nothing written.
expect 1 "too few training views" -- "$G" adapt "${AD[@]}" --interval 5 --out x.safetensors
one_line "need at least 5 (at least 21 frames)"
sed -e 's/"dim": 32/"dim": 48/' tiny1.json >wide.json
expect 1 "another network" -- "$G" adapt "${AD[@]}" --config wide.json --out x.safetensors
one_line "a checkpoint of another network"
expect 1 "missing model" -- "$G" adapt "${AD[@]}" --base nothere.safetensors --out x.safetensors
one_line "nothere.safetensors"
expect 0 "tiny vae" -- "$G" vae train --config tiny --scenes A --steps 1 --crop 32x32 --stats-clips 1 \
    --out vae4.safetensors --quiet
expect 0 "tiny base" -- "$G" pretrain --clips D --config tiny --vae vae4.safetensors --steps 1 --batch 1 \
    --out base4.safetensors --quiet
expect 1 "a VAE that packs frames" -- "$G" adapt "${AD[@]}" --config tiny --base base4.safetensors --out x.safetensors
one_line "temporal factor 1"
expect 1 "a scene checkpoint as base" -- "$G" adapt "${AD[@]}" --base a.safetensors --out x.safetensors
one_line "a scene checkpoint"
expect 1 "no scene" -- "$G" adapt "${AD[@]}" --scene nowhere --out x.safetensors
one_line "nowhere"
check "nothing half-written" test ! -e x.safetensors
cli_finish
