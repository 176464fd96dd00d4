#!/bin/bash
# Makes a folder laid out as `gaussvid reconstruct` writes it (docs/REPORT.md), from real
# models and renders, with gaussvid commands only, so that `gaussvid report` can be developed
# and tested without the whole pipeline. It is a stand-in, and says so in metrics.json: the
# "restored" frames are the renders of a 3DGS trained 2x longer, the "refined" model one
# trained 3x longer (no restorer runs).
#
# Usage: bash tests/report/make_fixture.sh GAUSSVID SCENE OUT INTERVAL ITERS [smooth K]
#   held-out (default): renders, metrics against the scene's images for every held-out frame
#   smooth K:           K frames along a path through the training views, no ground truth
# Call it once per interval with the same OUT: metrics.json lists every OUT/nN/run.json.
set -euo pipefail
G=${1:?usage: make_fixture.sh GAUSSVID SCENE OUT INTERVAL ITERS [smooth K]}
SCENE=$(cd "${2:?scene folder}" && pwd)
OUT=${3:?output folder}
N=${4:?interval}
ITERS=${5:?iterations}
PATH_KIND=${6:-held-out}
K=${7:-0}
RUN=$OUT/n$N
mkdir -p "$RUN/frames"
Q=(--quiet --threads 2)

now() { date +%s.%N; }
secs() { echo "$1 $2" | awk '{printf "%.3f", $2 - $1}'; }
stages=()
stage() { stages+=("{\"name\": \"$1\", \"seconds\": $(secs "$2" "$(now)")}"); }

t=$(now)
"$G" splat train --scene "$SCENE" --interval "$N" --iters "$ITERS" --out "$RUN/sparse.ply" "${Q[@]}"
stage train "$t"
"$G" splat export "$RUN/sparse.ply" --out "$RUN/sparse.splat" --quiet >/dev/null

t=$(now)
for m in restored refined; do
    k=2; [ $m = refined ] && k=3
    "$G" splat train --scene "$SCENE" --interval "$N" --iters $((k * ITERS)) --out "$RUN/$m.ply" "${Q[@]}"
done
"$G" splat export "$RUN/refined.ply" --out "$RUN/refined.splat" --quiet >/dev/null
stage refine "$t"

# Renders: frame_%05d.png by the scene's frame index; on a smooth path by the path's index.
t=$(now)
for m in sparse restored refined; do
    dir=render; [ $m != sparse ] && dir=$m
    if [ "$PATH_KIND" = smooth ]; then
        "$G" splat render --model "$RUN/$m.ply" --scene "$SCENE" --frames train --interval "$N" \
            --path "$K" --out "$RUN/frames/tmp" "${Q[@]}"
        mkdir -p "$RUN/frames/$dir"
        for f in "$RUN"/frames/tmp/path_*.png; do
            i=$(basename "$f" .png); i=$((10#${i#path_}))
            mv "$f" "$RUN/frames/$dir/$(printf 'frame_%05d.png' "$i")"
        done
        rmdir "$RUN/frames/tmp"
    else
        "$G" splat render --model "$RUN/$m.ply" --scene "$SCENE" --frames held-out --interval "$N" \
            --out "$RUN/frames/$dir" "${Q[@]}"
    fi
done
stage render "$t"
rm "$RUN/restored.ply"

# metrics M.png GT.png: {"psnr": .., "ssim": .., "lpips": null} as `gaussvid metrics` prints them.
metrics() {
    "$G" metrics "$1" "$2" --json | sed -E 's/.*"psnr":([^,]*),"ssim":([^,]*),.*/{"psnr": \1, "ssim": \2, "lpips": null}/'
}
train=$(seq -s ', ' 0 "$N" $(($(ls "$SCENE/images" | wc -l) - 1)))
frames=()
t=$(now)
for f in "$RUN"/frames/render/frame_*.png; do
    name=$(basename "$f")
    i=${name#frame_}; i=$((10#${i%.png}))
    rel=n$N/frames
    if [ "$PATH_KIND" = smooth ]; then
        gt=null; ms=null; mr=null; mf=null
    else
        gt=\"$SCENE/images/$name\"
        ms=$(metrics "$f" "$SCENE/images/$name")
        mr=$(metrics "$RUN/frames/restored/$name" "$SCENE/images/$name")
        mf=$(metrics "$RUN/frames/refined/$name" "$SCENE/images/$name")
    fi
    frames+=("{\"frame\": $i, \"images\": {\"render\": \"$rel/render/$name\", \"restored\": \"$rel/restored/$name\", \"refined\": \"$rel/refined/$name\", \"ground_truth\": $gt}, \"sparse\": $ms, \"restored\": $mr, \"refined\": $mf}")
done
stage evaluate "$t"

join() { local IFS=,; echo "$*"; }
# The means of one model's per-frame numbers (awk over the frame objects).
mean_of() {
    printf '%s\n' "${frames[@]}" | awk -v key="\"$1\": {\"psnr\": " '
        { i = index($0, key); if (!i) next; s = substr($0, i + length(key)); split(s, a, /[,}]/)
          p += a[1]; sub(/^[^:]*: /, "", a[2]); q += a[2]; n++ }
        END { printf "{\"psnr\": %.6f, \"ssim\": %.6f, \"lpips\": null, \"frames\": %d}", p / n, q / n, n }'
}
if [ "$PATH_KIND" = smooth ]; then means=null
else means="{\"sparse\": $(mean_of sparse), \"restored\": $(mean_of restored), \"refined\": $(mean_of refined)}"
fi
count() { head -c 400 "$1" | sed -n 's/^element vertex //p'; }
cat >"$RUN/run.json" <<EOF
    {
      "interval": $N,
      "train_frames": [$train],
      "path": "$PATH_KIND",
      "gaussians": {"sparse": $(count "$RUN/sparse.ply"), "refined": $(count "$RUN/refined.ply")},
      "frames": [
        $(join "${frames[@]}")
      ],
      "means": $means,
      "stages": [$(join "${stages[@]}")]
    }
EOF

# metrics.json: every run made so far in OUT (one call of this script per interval).
first=$(ls "$RUN"/frames/render/*.png | head -1)
size=$("$G" metrics "$first" "$first" --json)
runs=()
for r in $(ls -d "$OUT"/n*/run.json | sort -V); do runs+=("$(cat "$r")"); done
cat >"$OUT/metrics.json.tmp" <<EOF
{
  "format": "gaussvid-reconstruct-1",
  "scene": "$(basename "$SCENE")",
  "scene_dir": "$SCENE",
  "width": $(sed -n 's/.*"width":\([0-9]*\).*/\1/p' <<<"$size"),
  "height": $(sed -n 's/.*"height":\([0-9]*\).*/\1/p' <<<"$size"),
  "restorer": {"checkpoint": "fixture: a 3DGS trained 2x longer stands in for the restorer", "kind": "cross-scene", "gate": null},
  "runs": [
$(join "${runs[@]}")
  ]
}
EOF
mv "$OUT/metrics.json.tmp" "$OUT/metrics.json"
