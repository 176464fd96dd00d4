#!/bin/bash
# gaussvid bench stream: usage errors, and a smoke run of each work (forward, restore, train)
# on the tiny preset with BF16 weights written to a scratch folder and streamed from it: the
# weights are kept in BF16, every block of the forward pass reports, the child's CPU time and
# peak resident set are printed, and the weight file is removed unless --keep (the Wan runs
# and their numbers are in docs/BENCHMARKS.md); with --lora-rank, a random LoRA in the GaussVid
# release's naming fused by model merge first.
# Usage: bash bench_stream.sh /path/to/gaussvid
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup bench-stream "$1"

"$G" bench --help | grep -q "stream"
check_rc "bench --help lists stream" $?
expect 2 "no --dir" -- "$G" bench stream --preset tiny
expect 2 "unknown work" -- "$G" bench stream --preset tiny --dir "$T/w" --work nope
expect 1 "unknown preset" -- "$G" bench stream --preset nonesuch --dir "$T/w"
one_line "nonesuch"

small=(--preset tiny --dir "$T/w" --height 32 --width 32)
expect 0 "forward" -- "$G" bench stream "${small[@]}" --work forward
has "tiny: 49 linear weights kept in BF16"
has "block 4/4:"
has "bench stream: tiny forward:"
has "peak resident set"
check "the weight file is removed" bash -c "! ls '$T/w'/*.safetensors 2>/dev/null"

expect 0 "restore, keeping the file" -- "$G" bench stream "${small[@]}" --work restore --keep
has "sampler: released, 10 Euler steps"
has "DiT evaluation 1 (sigma 0.5556)"
has "DiT evaluation 10 (sigma 0.0926)"
has "read from disk"
has "VAE decode"
check "the weight file is kept" test -f "$T/w/bench-stream-tiny-bf16.safetensors"

expect 0 "train, reusing the file" -- "$G" bench stream "${small[@]}" --work train --keep
has "BF16 base frozen"
has "AdamW step"
check "no file written again" bash -c "! grep -q 'wrote ' '$T/out'"

# With a random rank-4 LoRA in the GaussVid release's naming: written, fused by model merge
# (timed), the work run on the fused file, every file removed.
expect 0 "forward with a fused LoRA" -- "$G" bench stream "${small[@]}" --work forward --lora-rank 4
has "rank-4 LoRA"
has "bench stream: model merge (rank 4, bf16):"
has "tiny: 49 linear weights kept in BF16"
has "bench stream: tiny forward:"
check "the weight files are removed" bash -c "! ls '$T/w'/*lora* '$T/w'/*fused* 2>/dev/null"

cli_finish
