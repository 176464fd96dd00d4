#!/bin/bash
# The released models found from anywhere (issue 41; docs/RECONSTRUCT.md "Where the models are
# found"): reconstruct with the default restorer run from another folder finds it beside the
# program (the source tree's models/), installed (`cmake --install`: PREFIX/bin and
# PREFIX/share/gaussvid) and in $GAUSSVID_MODELS, which comes first; a checkpoint copied alone
# finds its VAE in the model folders; with none of them the error is one line naming every
# place looked and --ckpt. The scene: 13 frames of 16x16, n = 6 (two clips to restore).
# Usage: bash models.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup models "$1"
G=$(realpath "$G")
BUILD=$(dirname "$G")
MODELS="$(cd "$(dirname "$0")/../../models" && pwd)"
cd "$T" || exit 1
ckpt_used() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['restorer']['checkpoint'])" "$1"; }

expect 0 "synth" -- "$G" scene synth --seed 3 --frames 13 --size 16x16 --samples 1 --out "$T/S" --quiet
# (restored with the model as it is: 3 training views are too few to adapt it, and the point is
# that the network found is the one that runs)
RC=(--scene "$T/S" --interval 6 --iters 30 --refine-iters 10 --threads 2 --restore-with checkpoint --stop-after restore)
mkdir -p elsewhere && cd elsewhere || exit 1

# 1. beside the program: build/gaussvid finds the source tree's models/
if [ "$(realpath "$BUILD/../models")" = "$MODELS" ]; then
    expect 0 "beside the program" -- env -u GAUSSVID_MODELS "$G" reconstruct "${RC[@]}" --out R1
    check "the source tree's model" test "$(ckpt_used R1/metrics.json)" = "$MODELS/gaussvid-small.safetensors"
    check "two clips restored" test "$(ls R1/n6/frames/restored | wc -l)" -eq 10
else
    echo "models.sh: $G is not in a build folder of the source tree: 'beside the program' not tested"
fi

# 2. installed: the program in PREFIX/bin, the models in PREFIX/share/gaussvid
expect 0 "install" -- cmake --install "$BUILD" --prefix "$T/inst"
exists "$T/inst/bin/gaussvid"
exists "$T/inst/share/gaussvid/gaussvid-small.safetensors"
exists "$T/inst/share/gaussvid/vae.safetensors"
expect 0 "installed" -- env -u GAUSSVID_MODELS "$T/inst/bin/gaussvid" reconstruct "${RC[@]}" --out R2
check "the installed model" test "$(ckpt_used R2/metrics.json)" = "$T/inst/share/gaussvid/gaussvid-small.safetensors"

# 3. $GAUSSVID_MODELS comes first (a list like PATH: a missing folder is passed over)
mkdir -p "$T/mine" && cp "$MODELS/gaussvid-small.safetensors" "$MODELS/vae.safetensors" "$T/mine/"
expect 0 "GAUSSVID_MODELS" -- env GAUSSVID_MODELS="$T/none:$T/mine" "$T/inst/bin/gaussvid" reconstruct "${RC[@]}" --out R3
check "the model of GAUSSVID_MODELS" test "$(ckpt_used R3/metrics.json)" = "$T/mine/gaussvid-small.safetensors"
check "same restored frames as installed" cmp -s R2/n6/frames/restored/frame_00003.png R3/n6/frames/restored/frame_00003.png

# 4. a checkpoint copied alone: its VAE is not beside it, the model folders have it
mkdir -p "$T/alone" && cp "$MODELS/gaussvid-small.safetensors" "$T/alone/"
expect 0 "VAE from the model folders" -- env GAUSSVID_MODELS="$T/mine" "$T/inst/bin/gaussvid" reconstruct "${RC[@]}" \
    --ckpt "$T/alone/gaussvid-small.safetensors" --out R4

# 5. nowhere: a program alone, GAUSSVID_MODELS of no model (unless the machine has an install
# there): neither the default restorer nor the VAE of a checkpoint copied alone is found
mkdir -p "$T/lone/bin" && cp "$G" "$T/lone/bin/"
if [ ! -e /usr/local/share/gaussvid/gaussvid-small.safetensors ]; then
    expect 1 "no default model" -- env GAUSSVID_MODELS="$T/none" "$T/lone/bin/gaussvid" reconstruct "${RC[@]}" --out R6
    one_line "--ckpt"
    check "every place named" grep -qF "$T/none (GAUSSVID_MODELS), $T/lone/models (beside the program), $T/lone/share/gaussvid (installed)" "$T/err"
    check "nothing written" test ! -e R6
    expect 1 "VAE nowhere" -- env GAUSSVID_MODELS="$T/none" "$T/lone/bin/gaussvid" restore \
        --ckpt "$T/alone/gaussvid-small.safetensors" --clip R2/n6/clips/clip_0000.safetensors --out R5 --quiet
    one_line "model folders"
fi

cli_finish
