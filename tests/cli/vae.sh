#!/bin/bash
# gaussvid vae train / vae eval / vae residual and model run --part vae-encode|vae-decode: a
# tiny VAE trained a few steps on a small synthesised scene, its files, resuming, evaluation
# (text and JSON), and usage and input errors.
# Usage: bash vae.sh /path/to/gaussvid   ($GV_TMP: scratch folder)
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup vae "$1"
GV="$G"
DIR="$T"

"$GV" scene synth --seed 3 --out "$DIR/room" --frames 10 --size 32x16 --samples 1 --quiet --threads 1
check_rc "synthesise a 10-frame 32x16 scene" $?
"$GV" scene synth --seed 4 --out "$DIR/other" --frames 6 --size 32x16 --samples 1 --quiet --threads 1
check_rc "synthesise a second scene" $?

# ---- help and usage errors ------------------------------------------------------------------
"$GV" vae --help | grep -q "train" && "$GV" vae --help | grep -q "eval" && "$GV" vae --help | grep -q "residual"
check_rc "group help lists train, eval and residual" $?
"$GV" vae train --help | grep -q -- "--scenes"
check_rc "train --help" $?
"$GV" vae train --out "$DIR/x.safetensors" >/dev/null 2>&1
[ $? -eq 2 ]
check_rc "train without --scenes is a usage error" $?
"$GV" vae train --scenes "$DIR/room" --out "$DIR/x.safetensors" --crop 16by16 >/dev/null 2>&1
[ $? -eq 2 ]
check_rc "a bad --crop is a usage error" $?
"$GV" vae train --scenes >/dev/null 2>&1
[ $? -eq 2 ]
check_rc "--scenes without a folder is a usage error" $?
err=$("$GV" vae train --config tiny --scenes "$DIR/missing" --out "$DIR/x.safetensors" --quiet 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "missing"
check_rc "a missing scene fails naming it ($err)" $?
err=$("$GV" vae train --config tiny --scenes "$DIR/room" --out "$DIR/x.safetensors" --crop 16x12 --quiet 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "spatial factor 8"
check_rc "a crop off the spatial factor fails ($err)" $?
[ ! -e "$DIR/x.safetensors" ]
check_rc "nothing written after a failure" $?

# ---- training, resuming ---------------------------------------------------------------------
args=(--config tiny --scenes "$DIR/room" --crop 16x16 --warmup 2 --stats-clips 2 --checkpoint-every 2 --threads 1 --quiet)
out=$("$GV" vae train "${args[@]}" --steps 6 --out "$DIR/vae.safetensors" --log "$DIR/log.tsv" 2>&1)
check_rc "train 6 steps ($out)" $?
[ -s "$DIR/vae.safetensors" ] && [ -s "$DIR/vae.safetensors.ckpt" ]
check_rc "weights and checkpoint written" $?
[ "$(wc -l < "$DIR/log.tsv")" -eq 7 ] && head -1 "$DIR/log.tsv" | grep -q "train_psnr"
check_rc "the log has a header and one line per step" $?
"$GV" st inspect "$DIR/vae.safetensors" | grep -q "latent_mean"
check_rc "the weights carry the latent statistics" $?
"$GV" model inspect --config tiny --parts vae --weights "$DIR/vae.safetensors" >/dev/null 2>&1
check_rc "model inspect accepts the weights as the tiny VAE" $?
"$GV" vae train "${args[@]}" --steps 6 --stop-after 4 --out "$DIR/part.safetensors" >/dev/null 2>&1 &&
    "$GV" vae train "${args[@]}" --steps 6 --resume --out "$DIR/part.safetensors" >/dev/null 2>&1
check_rc "stop at step 4, then resume to 6" $?
cmp -s "$DIR/vae.safetensors" "$DIR/part.safetensors"
check_rc "the resumed run's weights equal the uninterrupted run's, byte for byte" $?
err=$("$GV" vae train "${args[@]}" --steps 6 --resume --lr 1e-3 --out "$DIR/part.safetensors" 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "other training options"
check_rc "resuming with other options fails ($err)" $?

out=$("$GV" vae train "${args[@]}" --steps 2 --eval-scenes "$DIR/other" --eval-clips 1 --out "$DIR/ev.safetensors" \
    --log "$DIR/ev.tsv" 2>&1)
check_rc "train with held-out scenes and no --eval-every ($out)" $?
[ -z "$(sed -n 2p "$DIR/ev.tsv" | cut -f5)" ] && tail -1 "$DIR/ev.tsv" | cut -f5 | grep -Eq '^[0-9]+\.[0-9]{3}$'
check_rc "the held-out scenes are measured at the last step only" $?

# ---- evaluation -----------------------------------------------------------------------------
out=$("$GV" vae eval --weights "$DIR/vae.safetensors" --scenes "$DIR/other" "$DIR/room" --threads 1 2>&1)
check_rc "eval exits 0 ($out)" $?
echo "$out" | grep -q "other .* 1 clips *5 frames  PSNR" && echo "$out" | grep -q "^  all .* 3 clips  *15 frames"
check_rc "eval lists each scene and the total" $?
json=$("$GV" vae eval --weights "$DIR/vae.safetensors" --scenes "$DIR/other" --json --threads 1 2>/dev/null)
echo "$json" | grep -q '"psnr":' && echo "$json" | grep -q '"psnr_first":' && echo "$json" | tail -1 | grep -q '^}$'
check_rc "eval --json" $?
err=$("$GV" vae eval --weights "$DIR/vae.safetensors" --config small --scenes "$DIR/other" 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "not the weights of this VAE"
check_rc "weights of another config are refused ($err)" $?
err=$("$GV" vae eval --weights "$DIR/vae.safetensors" --scenes "$DIR/other" --frames 4 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "1 + k x 4"
check_rc "a clip length off the temporal factor fails ($err)" $?
printf 'not safetensors' > "$DIR/bad.safetensors"
err=$("$GV" vae eval --weights "$DIR/bad.safetensors" --scenes "$DIR/other" 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "bad.safetensors"
check_rc "a corrupt weights file fails naming it ($err)" $?

# ---- residual decoding on dataset clips -------------------------------------------------------
"$GV" dataset build --scenes "$DIR/room" --out "$DIR/data" --intervals 4 --iters 20 --clips-per-run 2 --threads 1 --quiet
check_rc "a dataset of 2 clips to score" $?
out=$("$GV" vae residual --weights "$DIR/vae.safetensors" "$DIR/data" --threads 1 --quiet 2>&1)
check_rc "vae residual exits 0 ($out)" $?
echo "$out" | grep -q "^  4  *2  *6 .* 0$" && echo "$out" | grep -q "^  all  *2  *6 .* 0$"
check_rc "one row per interval and the total, 3 frames per clip, residual with the latent unchanged exact" $?
render=$(echo "$out" | awk '$1 == "all" { print $4 }')
same=$(echo "$out" | awk '$1 == "all" { print $10 }')
[ -n "$render" ] && [ "$render" = "$same" ]
check_rc "residual with the latent unchanged has the render's PSNR ($render, $same)" $?
json=$("$GV" vae residual --weights "$DIR/vae.safetensors" "$DIR/data/clips/room_n04_000.safetensors" --json --threads 1 --quiet 2>/dev/null)
echo "$json" | grep -q '"max_abs_same":[[:space:]]*0' && echo "$json" | grep -q '"psnr_residual_target":' && echo "$json" | tail -1 | grep -q '^}$'
check_rc "vae residual --json on one clip file" $?
err=$("$GV" vae residual --weights "$DIR/vae.safetensors" "$DIR/bad.safetensors" --quiet 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "bad.safetensors"
check_rc "a corrupt clip file fails naming it ($err)" $?
err=$("$GV" vae residual --weights "$DIR/vae.safetensors" "$DIR/room" --quiet 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "no clip files"
check_rc "a folder without clips fails ($err)" $?
"$GV" vae residual --weights "$DIR/vae.safetensors" >/dev/null 2>&1
[ $? -eq 2 ]
check_rc "vae residual without clips is a usage error" $?

# ---- model run --part vae-encode / vae-decode ------------------------------------------------
st_zeros "$DIR/video.safetensors" "video 3,5,16,16"
out=$("$GV" model run --config tiny --weights "$DIR/vae.safetensors" --inputs "$DIR/video.safetensors" \
    --out "$DIR/enc.safetensors" --part vae-encode --quiet 2>&1)
check_rc "model run --part vae-encode ($out)" $?
list=$("$GV" st inspect "$DIR/enc.safetensors" 2>&1)
echo "$list" | grep -q "^  mean  *F32  *\[4, 2, 2, 2\]" && echo "$list" | grep -q "^  latent  *F32  *\[4, 2, 2, 2\]"
check_rc "encode writes mean and latent [4, 2, 2, 2]" $?
out=$("$GV" model run --config tiny --weights "$DIR/vae.safetensors" --inputs "$DIR/enc.safetensors" \
    --out "$DIR/dec.safetensors" --part vae-decode --quiet 2>&1)
check_rc "model run --part vae-decode ($out)" $?
"$GV" st inspect "$DIR/dec.safetensors" 2>&1 | grep -q "^  video  *F32  *\[3, 5, 16, 16\]"
check_rc "decode writes video [3, 5, 16, 16]" $?
st_zeros "$DIR/video4.safetensors" "video 1,3,4,16,16"
err=$("$GV" model run --config tiny --weights "$DIR/vae.safetensors" --inputs "$DIR/video4.safetensors" \
    --out "$DIR/x.safetensors" --part vae-encode 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "1 + k x 4"
check_rc "encoding 4 frames fails ($err)" $?
err=$("$GV" model run --config tiny --weights "$DIR/video.safetensors" --inputs "$DIR/video.safetensors" \
    --out "$DIR/x.safetensors" --part vae-encode 2>&1)
[ $? -eq 1 ] && echo "$err" | grep -q "no VAE tensors"
check_rc "weights without the VAE fail ($err)" $?

cli_finish
