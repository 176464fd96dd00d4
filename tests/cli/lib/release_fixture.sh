# What the tests of the tiny release share (gaussvid_release.sh, model_import.sh): sourced
# after harness.sh's cli_setup, it sets
#   FIX  tests/fixtures/release (the committed tiny release), REL its BF16 folder
#   CFG  $T/tiny-stats.json: configs/tiny.json with latent statistics (the Wan presets carry
#        the published ones), which training requires of its VAE
# and defines
#   release_rooms CLIPS   two synthesised 32x32 rooms of 14 frames, A=$T/room-a and
#                         B=$T/room-b, and D=$T/data, their dataset at n = 6 (room-b the eval
#                         split) with CLIPS clips per run
FIX="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../fixtures/release" && pwd)"
REL="$FIX/tiny-vace-bf16"
CFG="$T/tiny-stats.json"
sed 's/"spatial_factor": 8/"spatial_factor": 8, "latent_mean": [0.1, -0.2, 0.3, 0.0], "latent_std": [1.5, 0.8, 1.2, 1.0]/' \
    "$(dirname "${BASH_SOURCE[0]}")/../../../configs/tiny.json" > "$CFG"
grep -q latent_mean "$CFG"
check_rc "config with statistics" $?

release_rooms() {
    A="$T/room-a"
    B="$T/room-b"
    D="$T/data"
    expect 0 "synth a" -- "$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out "$A" --quiet
    expect 0 "synth b" -- "$G" scene synth --seed 4 --frames 14 --size 32x32 --samples 1 --out "$B" --quiet
    expect 0 "dataset" -- "$G" dataset build --scenes "$A" "$B" --eval-scenes room-b --intervals 6 --iters 20 \
        --clips-per-run "$1" --seed 5 --out "$D" --quiet --threads 1
}
