#!/bin/bash
# gaussvid reconstruct on a tiny synthesised scene (25 frames of 64x48, n = 6: 5 training views,
# 20 held-out frames in 8 clips) with a tiny restorer made here: every stage's files exist and
# read; metrics.json's numbers equal an independent recomputation (gaussvid metrics on the PNGs
# it names; the means of its frames); --stop-after stops; a rerun skips finished stages, redoes
# from a stage whose files are gone and refuses other inputs; the refinement's feedback path
# (restored frames replaced by the ground truth beat restored frames replaced by the renders);
# the smooth path of n = 1; the adapt stage; the gated default (a scene with too few views to
# adapt keeps the sparse model; a closed gate skips restoration and refinement); --no-restore;
# the presets and the flags over them; the restorer opened once by restore and not by refine
# (strace); bad input gives one line and a non-zero exit.
# Usage: bash reconstruct.sh /path/to/gaussvid   ($GV_TMP scratch)
source "$(dirname "$0")/lib/harness.sh"
cli_setup reconstruct "$1"

cd "$T" || exit 1
# A 1-frame-per-latent tiny network (as adapt.sh): --adapt needs it.
tiny1_config tiny1.json
expect 0 "synth" -- "$G" scene synth --seed 3 --frames 25 --size 64x48 --samples 1 --out S --quiet
expect 0 "dataset" -- "$G" dataset build --scenes S --intervals 6 --iters 20 --clips-per-run 2 --seed 5 --out D \
    --quiet --threads 1
expect 0 "vae" -- "$G" vae train --config tiny1.json --scenes S --steps 2 --crop 32x32 --stats-clips 2 \
    --out vae.safetensors --quiet
expect 0 "base" -- "$G" pretrain --clips D --config tiny1.json --vae vae.safetensors --steps 2 --batch 2 \
    --out base.safetensors --quiet

HAVE_FFMPEG=0
command -v ffmpeg >/dev/null && HAVE_FFMPEG=1
[ $HAVE_FFMPEG = 1 ] || echo "reconstruct.sh: ffmpeg is not installed (scripts/setup.sh): the video stage is not tested"
LAST=video
[ $HAVE_FFMPEG = 1 ] || LAST=evaluate
# RC0: the gated default; RC: today's ungated restoration with the checkpoint as it is, which
# most of the stage-by-stage checks below use (it restores without an adaptation first).
RC0=(--scene S --interval 6 --ckpt base.safetensors --iters 60 --refine-iters 40 --threads 2)
RC=("${RC0[@]}" --restore-with checkpoint)

# Help and usage errors.
expect 0 "help" -- "$G" reconstruct --help
has "usage: gaussvid reconstruct"
has "--stop-after"
has "--preset NAME"
has "--no-restore"
expect 0 "listed" -- "$G" help
has "reconstruct"
expect 2 "no scene" -- "$G" reconstruct --interval 6 --out X
expect 2 "bad interval" -- "$G" reconstruct --scene S --interval 6,x --out X
one_line "intervals '6,x': expected a number at 'x'"
expect 2 "interval 0" -- "$G" reconstruct --scene S --interval 0 --out X
one_line "interval 0: reconstruct takes n = 1 or 4 <= n <= 100000"
expect 2 "interval repeated" -- "$G" reconstruct --scene S --interval 4,6,4 --out X
one_line "intervals '4,6,4': 4 is listed twice"
expect 2 "interval 3" -- "$G" reconstruct "${RC[@]}" --interval 3 --out X
one_line "interval 3: reconstruct takes n = 1 or 4 <= n <= 100000 (a clip restores 3 held-out frames"
expect 1 "missing scene" -- "$G" reconstruct "${RC[@]}" --scene nowhere --out X
one_line "nowhere"
expect 1 "missing checkpoint" -- "$G" reconstruct "${RC[@]}" --ckpt none.safetensors --out X
one_line "none.safetensors: no such checkpoint"
expect 1 "not a checkpoint" -- "$G" reconstruct "${RC[@]}" --ckpt tiny1.json --out X
one_line "tiny1.json"
expect 1 "unknown stage" -- "$G" reconstruct "${RC[@]}" --stop-after paint --out X
one_line "--stop-after paint: not a stage"
expect 1 "no ffmpeg" -- "$G" reconstruct "${RC[@]}" --ffmpeg ./no-ffmpeg --out X
one_line "no-ffmpeg"
expect 1 "weight" -- "$G" reconstruct "${RC[@]}" --refine-weight 2 --out X
one_line "--refine-weight 2"
expect 2 "bad preset" -- "$G" reconstruct "${RC0[@]}" --preset turbo --out X
one_line "--preset turbo: expected fast, default or best"
expect 2 "bad mode" -- "$G" reconstruct "${RC0[@]}" --restore-with magic --out X
one_line "--restore-with magic: expected adapted, checkpoint or none"
expect 2 "two modes" -- "$G" reconstruct "${RC[@]}" --no-restore --out X
one_line "--no-restore and --restore-with checkpoint: choose one"
expect 2 "adapt and no restore" -- "$G" reconstruct "${RC0[@]}" --adapt --no-restore --out X
one_line "--adapt and --no-restore: choose one"
expect 1 "stop after restore without restoring" -- "$G" reconstruct "${RC0[@]}" --no-restore --stop-after restore --out X
one_line "--stop-after restore: --no-restore has no restore stage"
# The default path adapts the checkpoint: one it cannot adapt (another network than
# --adapt-config, small by default) is refused before any training.
expect 1 "a checkpoint the default path cannot adapt" -- "$G" reconstruct "${RC0[@]}" --out X
one_line "base.safetensors: a checkpoint of another network (tiny1"
check "the line names the way out" grep -qF -- "--restore-with checkpoint restores with it as it is" "$T/err"
check "nothing written on bad input" test ! -e X

# The presets: the first line names the preset and the settings it resulted in (printed
# before the scene is read, so a missing scene shows them without training).
first_line() { head -n 1 "$T/out"; }
expect 1 "preset fast" -- "$G" reconstruct --scene nowhere --interval 6 --out X --preset fast
check "fast: lean with DropGaussian and the decay from 1/4 of the size, 3000 iterations, no restoration" test "$(first_line)" = \
    "reconstruct, preset fast: 3000 sparse iterations (base dropgaussian,decay, lean density control, from 1/4 of the size), no restoration (the sparse model only)"
expect 1 "preset default" -- "$G" reconstruct --scene nowhere --interval 6 --out X
# (the default restorer by the absolute path it was found at: the source tree's models/)
check "default: lean 3DGS with DropGaussian and the decay from 1/4 of the size, the gated path" test "$(first_line | sed 's| /[^ ]*/models/| models/|')" = "reconstruct, \
preset default: 8000 sparse iterations (base dropgaussian,decay, lean density control, from 1/4 of the size), models/gaussvid-small.safetensors adapted to the \
scene (300 steps) where it has the views for it, its gate deciding restoration and refinement (1000 iterations at weight 0.3)"
expect 1 "preset best" -- "$G" reconstruct --scene nowhere --interval 6 --out X --preset best --ckpt c.st
check "best: 15000 iterations, the gated path" test "$(first_line)" = "reconstruct, preset best: 15000 sparse \
iterations (base 3dgs, reference density control), c.st adapted to the scene (300 steps) where it has the views for it, its gate \
deciding restoration and refinement (1000 iterations at weight 0.3)"
expect 1 "flags over the preset" -- "$G" reconstruct --scene nowhere --interval 6 --out X --preset fast --iters 77 \
    --densify reference --restore-with checkpoint --ckpt c.st --refine-iters 5
check "every flag wins over fast" test "$(first_line)" = "reconstruct, preset fast: 77 sparse iterations (base dropgaussian,decay, \
reference density control, from 1/4 of the size), restoration with c.st as it is (ungated), refinement 5 iterations at weight 0.3"
expect 1 "mcmc" -- "$G" reconstruct --scene nowhere --interval 6 --out X --densify mcmc --no-restore
check "with mcmc the base is plain 3DGS" test "$(first_line)" = \
    "reconstruct, preset default: 8000 sparse iterations (base 3dgs, mcmc density control, from 1/4 of the size), no restoration (the sparse model only)"
expect 1 "full size" -- "$G" reconstruct --scene nowhere --interval 6 --out X --resolution-schedule 1 --no-restore
check "--resolution-schedule 1: full size throughout" test "$(first_line)" = \
    "reconstruct, preset default: 8000 sparse iterations (base dropgaussian,decay, lean density control), no restoration (the sparse model only)"
expect 2 "bad schedule" -- "$G" reconstruct --scene nowhere --interval 6 --out X --resolution-schedule 3
one_line "--resolution-schedule 3: expected 1 (full size throughout), 2, 4 or 8"
check "nothing written for a missing scene" test ! -e X

# Stage by stage: --stop-after stops, the next run continues.
stages() { python3 -c "import json,sys; print(' '.join(s['name'] for s in json.load(open('$1'))['runs'][0]['stages']))"; }
expect 0 "stop after train" -- "$G" reconstruct "${RC[@]}" --out R --stop-after train
exists R/n6/sparse.ply
exists R/n6/sparse.splat
check "no renders yet" test ! -e R/n6/frames/render
check "train recorded" test "$(stages R/metrics.json)" = "train"
has "n=6 train:"
# base.safetensors was pretrained on D, the clips of S: its numbers on S are not unseen-scene numbers.
check "S was in the restorer's training set: one warning" \
    test "$(grep -c "warning: scene 'S' was in the restorer's training set" "$T/err")" -eq 1
check "metrics.json records what the restorer was trained on" python3 -c "
import json; assert json.load(open('R/metrics.json'))['restorer']['training_scenes'] == 'S'"
cp R/n6/sparse.ply sparse_first.ply
expect 0 "stop after render" -- "$G" reconstruct "${RC[@]}" --out R --stop-after render
check "train skipped" grep -q "n=6 train: done before, skipped" "$T/err"
check "the sparse model kept" cmp -s R/n6/sparse.ply sparse_first.ply
check "train, render" test "$(stages R/metrics.json)" = "train render"
check "20 renders" test "$(ls R/n6/frames/render | wc -l)" -eq 20
done_stages="train render"
i=2
for st in restore refine evaluate video; do
    [ $st = video ] && [ $HAVE_FFMPEG = 0 ] && break
    expect 0 "stop after $st" -- "$G" reconstruct "${RC[@]}" --out R --stop-after $st
    check "$i stages skipped before $st" test "$(grep -c 'done before, skipped' "$T/err")" -eq $i
    done_stages="$done_stages $st"
    check "stages recorded up to $st" test "$(stages R/metrics.json)" = "$done_stages"
    cat "$T/out" >>all_out
    i=$((i + 1))
done
cp all_out "$T/out"
has "n=6 restore: 8 clips restored"
check "the clips carry their coverage plane" grep -q '"coverage"' <("$G" st inspect --json R/n6/clips/clip_0000.safetensors)
has "n=6 evaluate: PSNR sparse"
for d in render restored refined; do
    check "20 $d frames" test "$(ls R/n6/frames/$d | wc -l)" -eq 20
done
check "the renders read" "$G" metrics R/n6/frames/render/frame_00001.png R/n6/frames/restored/frame_00001.png
check "the refined model reads" "$G" splat export R/n6/refined.ply --out refined_copy.splat
check "refined.splat is that model" cmp -s refined_copy.splat R/n6/refined.splat
if [ $HAVE_FFMPEG = 1 ]; then
    exists R/n6/flythrough.mp4
    exists R/report.html
    check "the report warns that S was trained on" grep -q "the scene S was in the restorer's training set" R/report.html
    # the summary at the end: the means of metrics.json, in words, and where the files are
    has "n = 6, 20 held-out frames between the training views:"
    has "against the sparse renders the restored frames are"
    has "3D consistency (each frame warped into its neighbours by the model's depth, masked PSNR): sparse"
    has "  report       R/report.html"
    has "  viewer       R/n6/viewer.html"
    has "  video        R/n6/flythrough.mp4"
    check "the summary's table is metrics.json's means" python3 -c "
import json, re, sys
means = json.load(open('R/metrics.json'))['runs'][0]['means']
text = open('all_out').read()
for label, kind in (('sparse 3DGS', 'sparse'), ('restored', 'restored'), ('refined 3DGS', 'refined')):
    m = re.search(r'^  %s +([0-9.]+) +([0-9.]+)\$' % label, text, re.M)
    assert m and m.group(1) == '%.2f' % means[kind]['psnr'] and m.group(2) == '%.4f' % means[kind]['ssim'], (label, m)"
    # a fly-through of 8 frames per gap through the 5 training views (4 x 8 + 1), then the 20 held-out frames
    check "the video is 33 + 20 frames of 192x48" test "$(ffprobe -v error -count_frames -select_streams v:0 \
        -show_entries stream=nb_read_frames,width,height -of csv=p=0 R/n6/flythrough.mp4)" = "192,48,53"
    has "a fly-through of 33 frames through the 5 training views (sparse | refined | nearest photo), then the 20 held-out frames"
    check "the report lists the worst frames by name" grep -q '<table class="worst">' R/report.html
fi

# metrics.json against an independent recomputation.
cat >check_metrics.py <<'PY'
import json, subprocess, sys
gv, root = sys.argv[1], sys.argv[2]
doc = json.load(open(root + "/metrics.json"))
assert doc["format"] == "gaussvid-reconstruct-1" and doc["scene"] == "S", "header"
assert (doc["width"], doc["height"]) == (64, 48), "size"
assert doc["restorer"]["kind"] == "cross-scene" and doc["restorer"]["gate"] is None, "restorer"
run = doc["runs"][0]
assert run["interval"] == 6 and run["path"] == "held-out" and run["train_frames"] == [0, 6, 12, 18, 24], "plan"
frames = [f["frame"] for f in run["frames"]]
assert frames == [i for i in range(1, 24) if i % 6], "frames %s" % frames
# named after the photos: the scene's image names (frame_%05d.png for a synthesised scene)
assert all(f["name"] == "frame_%05d.png" % f["frame"] and f["images"]["render"] == "n6/frames/render/frame_%05d.png" % f["frame"]
           for f in run["frames"]), "names"
assert run["gaussians"]["sparse"] > 0 and run["gaussians"]["refined"] == run["gaussians"]["sparse"], "counts"
sums = {"sparse": [0, 0], "restored": [0, 0], "refined": [0, 0]}
for f in run["frames"]:
    truth = f["images"]["ground_truth"]
    for kind, image in (("sparse", "render"), ("restored", "restored"), ("refined", "refined")):
        out = subprocess.run([gv, "metrics", root + "/" + f["images"][image], truth, "--json"],
                             capture_output=True, text=True, check=True).stdout
        m = json.loads(out)
        assert abs(m["psnr"] - f[kind]["psnr"]) < 1e-9, (f["frame"], kind, m, f[kind])
        assert abs(m["ssim"] - f[kind]["ssim"]) < 1e-9, (f["frame"], kind, m, f[kind])
        assert f[kind]["lpips"] is None
        sums[kind][0] += m["psnr"]; sums[kind][1] += m["ssim"]
for kind, (p, s) in sums.items():
    mean = run["means"][kind]
    assert mean["frames"] == 20 and abs(mean["psnr"] - p / 20) < 1e-9 and abs(mean["ssim"] - s / 20) < 1e-9, kind
# every held-out frame is between two training views here: the two means agree
assert abs(run["all_held_out"]["sparse"]["psnr"] - run["means"]["sparse"]["psnr"]) < 1e-9, "all held-out"
names = [s["name"] for s in run["stages"]]
assert names[:5] == ["train", "render", "restore", "refine", "evaluate"], names
assert all(s["seconds"] >= 0 and s["cpu_seconds"] >= 0 and s["summary"] for s in run["stages"]), "stage records"
PY
check "metrics.json equals its recomputation" python3 check_metrics.py "$G" R

# Resume: everything finished is skipped; other inputs are refused; lost files redo their stage.
cp R/metrics.json metrics_first.json
expect 0 "rerun" -- "$G" reconstruct "${RC[@]}" --out R --stop-after $LAST
check "every stage skipped" test "$(grep -c 'done before, skipped' "$T/err")" -eq $([ $HAVE_FFMPEG = 1 ] && echo 6 || echo 5)
check "metrics.json unchanged" cmp -s R/metrics.json metrics_first.json
# Other refinement options: the stages before the refinement are kept, it and the later ones redone.
cp -r R R2
expect 0 "other refinement" -- "$G" reconstruct "${RC[@]}" --refine-iters 41 --out R2 --stop-after $LAST
check "train, render, restore kept" test "$(grep -c 'done before, skipped' "$T/err")" -eq 3
check "the refinement redone" grep -q "n=6 refine: made before with refine_iters 40, now 41: done again" "$T/err"
check "refine recorded with its inputs" python3 -c "
import json; r = json.load(open('R2/metrics.json'))['runs'][0]
s = {s['name']: s for s in r['stages']}
assert s['refine']['inputs'] == {'refine_iters': 41, 'refine_weight': 0.3}, s['refine']
assert s['train']['inputs'] == {'iters': 60, 'densify': 'lean', 'regularize': 'dropgaussian,decay', 'resolution_schedule': 4, 'seed': 0, 'downscale': 1}, s['train']
assert r['inputs']['refine_iters'] == 41"
# Another density control trains again (and so every later stage).
expect 0 "other density control" -- "$G" reconstruct "${RC[@]}" --densify reference --out R2 --stop-after train
check "the training redone" grep -q 'n=6 train: made before with densify "lean", now "reference": done again' "$T/err"
# Another base too.
expect 0 "other base" -- "$G" reconstruct "${RC[@]}" --densify reference --base dropgaussian --out R2 --stop-after train
check "the training redone for the base" \
    grep -q 'n=6 train: made before with regularize "dropgaussian,decay", now "dropgaussian": done again' "$T/err"
expect 2 "bad base" -- "$G" reconstruct "${RC[@]}" --base fsgs,turbo --out X
one_line "--base fsgs,turbo: expected 3dgs, corgs, fsgs, dropgaussian, segs, decay, binocular or a comma-separated list of the last six"
# A folder from before "densify", "regularize" and "resolution_schedule" were recorded was
# trained with the reference, no regulariser, at full size: kept for those settings.
cp -r R R3
python3 -c "
import json; d = json.load(open('R3/metrics.json'))
for run in d['runs']:
    for k in ('densify', 'regularize', 'resolution_schedule'): run['inputs'].pop(k)
    for s in run['stages']:
        for k in ('densify', 'regularize', 'resolution_schedule'): s['inputs'].pop(k, None)
json.dump(d, open('R3/metrics.json', 'w'))"
expect 0 "a folder from before densify" -- "$G" reconstruct "${RC[@]}" --densify reference --base 3dgs --out R3 \
    --resolution-schedule 1 --stop-after train
check "its training kept" grep -q "n=6 train: done before, skipped" "$T/err"
rm R/n6/frames/restored/frame_00013.png
cp R/n6/refined.ply refined_first.ply
expect 0 "a lost frame" -- "$G" reconstruct "${RC[@]}" --out R --stop-after $LAST
check "train and render skipped" test "$(grep -c 'done before, skipped' "$T/err")" -eq 2
has "n=6 restore:"
has "n=6 refine:"
exists R/n6/frames/restored/frame_00013.png
check "the same inputs give the same refined model" cmp -s R/n6/refined.ply refined_first.ply

# The feedback path: refinement on restored frames that are the ground truth beats refinement
# on restored frames that are the renders themselves (same iterations, weight 1).
ORC=("${RC[@]}" --refine-iters 150 --refine-weight 1 --stop-after restore)
expect 0 "oracle: up to restore" -- "$G" reconstruct "${ORC[@]}" --out O
expect 0 "identity: up to restore" -- "$G" reconstruct "${ORC[@]}" --out I
for f in O/n6/frames/restored/*.png; do cp "S/images/$(basename "$f")" "$f"; done
cp I/n6/frames/render/*.png I/n6/frames/restored/
expect 0 "oracle: refine" -- "$G" reconstruct "${ORC[@]}" --stop-after evaluate --out O
expect 0 "identity: refine" -- "$G" reconstruct "${ORC[@]}" --stop-after evaluate --out I
refined() { python3 -c "import json; print(json.load(open('$1'))['runs'][0]['means']['refined']['psnr'])"; }
check "ground truth fed back beats the renders fed back by 1 dB" \
    python3 -c "import sys; sys.exit(not $(refined O/metrics.json) > $(refined I/metrics.json) + 1)"

# 3D consistency: metrics.json's means are `metrics consistency`'s; restored frames that are the
# renders themselves are exactly as consistent as the renders; bad folders give one line.
expect 0 "consistency" -- "$G" metrics consistency R --json --threads 2
cp "$T/out" consistency.json
check "one summary line per run on stderr" test "$(grep -c '^n=6 consistency' "$T/err")" -eq 1
check "consistency: metrics.json's means, pairs per frame" python3 -c "
import json, math
c = json.load(open('consistency.json'))['runs'][0]; r = json.load(open('R/metrics.json'))['runs'][0]
assert c['interval'] == 6 and c['frames'] == 20
for k in ('sparse', 'restored', 'refined'):
    s = c[k]
    assert s['pairs'] == 38 and len(s['per_pair']) == 38 and 0 < s['scored'] <= 38, k
    assert abs(s['psnr'] - r['consistency'][k]['psnr']) < 1e-9, (k, s['psnr'], r['consistency'][k])
    scored = [p['psnr'] for p in s['per_pair'] if p['psnr'] is not None]
    assert len(scored) == s['scored'] and abs(sum(scored) / len(scored) - s['psnr']) < 1e-9, k
    assert all(0 < p['psnr'] <= 100 and 0 < p['coverage'] <= 1 for p in s['per_pair'] if p['psnr'] is not None), k
first = c['sparse']['per_pair'][:2]
assert [(p['from'], p['to']) for p in first] == [(1, 2), (2, 1)], first
assert c['sparse']['depth'] == c['restored']['depth'] == 'sparse.ply' and c['refined']['depth'] == 'refined.ply'"
expect 0 "consistency of renders as restored" -- "$G" metrics consistency I --threads 2
has "n=6 consistency"
check "restored = renders: the same consistency" python3 -c "
import json; c = json.load(open('I/metrics.json'))['runs'][0]['consistency']
assert c['restored']['psnr'] == c['sparse']['psnr'], c"
expect 1 "consistency: not a reconstruct folder" -- "$G" metrics consistency S
one_line "no metrics.json"
cp -r I I2
rm I2/n6/frames/refined/frame_00009.png
expect 1 "consistency: a missing frame" -- "$G" metrics consistency I2
one_line "frame_00009.png"
python3 -c "
import json; d = json.load(open('I/metrics.json')); d['runs'][0]['frames'].pop()
json.dump(d, open('I2/metrics.json', 'w'))"
expect 1 "consistency: frames that are not the plan's" -- "$G" metrics consistency I2
one_line "lists 19 frames but the scene's plan has 20"

# Photos named as a phone names them: the frames, metrics.json, the video and the report name
# them so (S's images renamed IMG_0001.JPG ..., PNG inside: images are read by signature).
cp -r S PH
for f in PH/images/frame_0*.png; do b=$(basename "$f" .png); mv "$f" "PH/images/IMG_${b#frame_0}.JPG"; done
sed -i -E 's/frame_0([0-9]{4})\.png/IMG_\1.JPG/g' PH/transforms.json PH/sparse/0/images.txt
expect 0 "photo names" -- "$G" reconstruct "${RC[@]}" --scene PH --refine-iters 5 --out PHR --stop-after $LAST
exists PHR/n6/frames/render/IMG_0001.png
exists PHR/n6/frames/restored/IMG_0023.png
check "metrics.json names the photos" python3 -c "
import json; r = json.load(open('PHR/metrics.json'))['runs'][0]
assert [f['name'] for f in r['frames']][:2] == ['IMG_0001.JPG', 'IMG_0002.JPG'], r['frames'][0]
assert r['frames'][0]['images']['refined'] == 'n6/frames/refined/IMG_0001.png'
assert r['frames'][0]['images']['ground_truth'].endswith('/PH/images/IMG_0001.JPG')"
expect 0 "photo names: consistency" -- "$G" metrics consistency PHR --threads 2
has "n=6 consistency"
if [ $HAVE_FFMPEG = 1 ]; then
    check "the report names the worst frames after the photos" grep -q '<tr data-frame="[0-9]*"><td>IMG_00[0-9][0-9].JPG</td>' PHR/report.html
fi

# n = 1 on 6 frames: every view trains; 5 clips restore a path of 15 frames without ground truth.
expect 0 "synth 6" -- "$G" scene synth --seed 4 --frames 6 --size 64x48 --samples 1 --out P --quiet
expect 0 "smooth path" -- "$G" reconstruct "${RC[@]}" --scene P --interval 1 --out PR --stop-after $LAST
check "P was not in the restorer's training set: no warning" test "$(grep -c "was in the restorer's training set" "$T/err")" -eq 0
check "15 path frames restored" test "$(ls PR/n1/frames/restored | wc -l)" -eq 15
exists PR/n1/frames/refined/frame_00004_to_frame_00005_3of4.png  # path frame 19, named after the photos around it
check "path metrics" python3 -c "
import json; r = json.load(open('PR/metrics.json'))['runs'][0]
assert r['path'] == 'smooth' and r['means'] is None and r['all_held_out'] is None
assert [f['frame'] for f in r['frames']] == [4 * k + j for k in range(5) for j in (1, 2, 3)]
assert all(f['images']['ground_truth'] is None and f['sparse'] is None for f in r['frames'])
assert r['frames'][0]['name'] == 'frame_00000_to_frame_00001_1of4', r['frames'][0]
assert r['frames'][0]['images']['restored'] == 'n1/frames/restored/frame_00000_to_frame_00001_1of4.png'"
if [ $HAVE_FFMPEG = 1 ]; then
    check "the path video is 5 x 8 + 1 fly-through and 15 path frames, render | restored" test "$(ffprobe -v error \
        -count_frames -select_streams v:0 -show_entries stream=nb_read_frames,width,height -of csv=p=0 \
        PR/n1/flythrough.mp4)" = "128,48,56"
    check "P's report names the training scenes without a warning" \
        test "$(grep -c "was in the restorer's training set" PR/report.html)" -eq 0 -a "$(grep -c "<th>trained on</th><td>S<" PR/report.html)" -eq 1
fi

# The gated default on the same path: every view trains, so adaptation cannot run and nothing
# is restored. The report then shows no restorer's changes and links the sparse model.
expect 0 "smooth path, gated default" -- "$G" reconstruct "${RC0[@]}" --scene P --interval 1 --out PG --stop-after $LAST
has "n=1 restore: skipped: adaptation cannot run here because every view trains (n = 1), so no view is left to pair with; the restored frames are the renders"
has "decided: Restoration mode adapted. Adaptation skipped: every view trains (n = 1), so no view is left to pair with. Restoration skipped"
if [ $HAVE_FFMPEG = 1 ]; then
    check "no 'Biggest changes' table when nothing was restored" test "$(grep -c "Biggest changes" PG/report.html)" -eq 0
    check "the strips say why they show the first and last frames" grep -q "(restoration was skipped)" PG/report.html
    check "the top-level restorer says adaptation is per n" grep -q "where it has the views for it: see each n" PG/report.html
    if [ -e PG/n1/viewer.html ]; then
        check "the viewer link names the sparse model" grep -q "Open the sparse model in the viewer" PG/report.html
    fi
fi

# --adapt: the scene checkpoint made in nN/ and restore uses it.
expect 0 "adapt" -- "$G" reconstruct "${RC0[@]}" --adapt --adapt-config tiny1.json --adapt-steps 2 --out A \
    --stop-after restore
has "n=6 adapt:"
exists A/n6/restorer.safetensors
check "restored with the scene checkpoint" python3 -c "
import json; r = json.load(open('A/metrics.json'))['runs'][0]
assert r['restorer']['kind'] == 'scene' and r['restorer']['gate'] in ('open', 'closed'), r['restorer']
assert r['restorer']['checkpoint'] == 'A/n6/restorer.safetensors'
assert [s['name'] for s in r['stages']] == ['train', 'render', 'adapt', 'restore']"
# A scene checkpoint as --ckpt: its gate decides, metrics.json says which.
expect 0 "a scene checkpoint" -- "$G" reconstruct "${RC[@]}" --ckpt A/n6/restorer.safetensors --out SC --stop-after restore
check "the scene checkpoint's gate recorded" python3 -c "
import json; d = json.load(open('SC/metrics.json')); r = d['runs'][0]['restorer']
assert d['restorer']['kind'] == 'scene' and d['restorer']['gate'] == r['gate'] and r['gate'] in ('open', 'closed')"
if grep -q "gate is closed" "$T/out"; then
    check "a closed gate keeps the renders" cmp -s SC/n6/frames/render/frame_00001.png SC/n6/frames/restored/frame_00001.png
fi
# ... to the end: the summary says the restorer was adapted and what its gate decided.
expect 0 "a scene checkpoint, to the end" -- "$G" reconstruct "${RC[@]}" --ckpt A/n6/restorer.safetensors --out SC
has "adapted to the scene where it has the views for it:"
has "decided: Restoration mode checkpoint. Adaptation skipped: --restore-with checkpoint. The gate is"
# One open of the restorer per reading (issue 40): the checks before the stages, then the restore
# stage (its weights only when its gate is open, as here); refine reads restore's decision from
# metrics.json, so a resumed refine opens it only for the checks. Counted with strace when present.
python3 "$(dirname "$0")/lib/pad_checkpoint.py" meta A/n6/restorer.safetensors open.safetensors gate=open
if command -v strace >/dev/null && strace -f -e trace=openat -o /dev/null true 2>/dev/null; then
    opens() { grep -v ENOENT opens.log | grep -cE "(\"|/)$1\""; }
    strace -f -e trace=openat,open -o opens.log "$G" reconstruct "${RC[@]}" --ckpt open.safetensors --out SO \
        --stop-after refine --quiet >/dev/null 2>&1
    check "restored and refined under strace" python3 -c "
import json; d = json.load(open('SO/metrics.json'))['runs'][0]['decisions']
assert d['gate'] == 'open' and d['restoration']['ran'] and d['refinement']['ran'], d"
    n=$(opens open.safetensors)
    check "the restorer opened for the checks and by restore alone (opened $n times)" test "$n" -eq 2
    strace -f -e trace=openat,open -o opens.log "$G" reconstruct "${RC[@]}" --ckpt open.safetensors --out SO \
        --stop-after refine --refine-iters 41 >"$T/out" 2>"$T/err"
    check "restore skipped" grep -q "n=6 restore: done before, skipped" "$T/err"
    has "n=6 refine: 41 iterations on 5 training views (weight 1) and 20 restored frames"
    n=$(opens open.safetensors)
    check "a resumed refine reads the decision, not the restorer (opened $n times)" test "$n" -eq 1
else
    echo "skipped: no working strace to count the opens"
    expect 0 "restore and refine, gate open" -- "$G" reconstruct "${RC[@]}" --ckpt open.safetensors --out SO \
        --stop-after refine
fi
# A metrics.json from before decisions were recorded: restore runs again to decide.
python3 -c "
import json; d = json.load(open('SO/metrics.json')); del d['runs'][0]['decisions']['restoration']
json.dump(d, open('SO/metrics.json', 'w'))"
expect 0 "no restoration decision recorded" -- "$G" reconstruct "${RC[@]}" --ckpt open.safetensors --out SO \
    --stop-after refine
check "restore redone" grep -q "n=6 restore: its decision is not recorded (an older metrics.json): done again" "$T/err"
has "n=6 refine: 40 iterations on 5 training views"
# --adapt to the end: the report's restorer is the base adapted per n, with one gate per n.
expect 0 "adapt, to the end" -- "$G" reconstruct "${RC0[@]}" --adapt --adapt-config tiny1.json --adapt-steps 2 --out A
check "the report: one gate per n" grep -q "one per n: see each interval" A/report.html
# The gate decides: closed, restore and refine are skipped (the renders and the sparse model
# pass through, bit for bit); open, both run. metrics.json, the summary and the report say which.
cat >check_gate.py <<'PY'
import filecmp, json, sys
root, n = sys.argv[1], int(sys.argv[2])
run = [r for r in json.load(open(root + "/metrics.json"))["runs"] if r["interval"] == n][0]
d, stages = run["decisions"], {s["name"]: s for s in run["stages"]}
assert d["restore_with"] == "adapted" and d["adaptation"] == {"ran": True, "why": None}, d
opened = d["gate"] == "open"
assert d["gate"] in ("open", "closed") and d["gate"] == run["restorer"]["gate"], d
assert d["restoration"]["ran"] == opened and d["refinement"]["ran"] == opened, d
frames = [f["frame"] for f in run["frames"]]
same = lambda a, b: all(filecmp.cmp("%s/n%d/frames/%s/frame_%05d.png" % (root, n, a, f),
                                    "%s/n%d/frames/%s/frame_%05d.png" % (root, n, b, f), shallow=False) for f in frames)
if not opened:
    assert d["restoration"]["why"].startswith("the gate is closed (held-back pairs "), d
    assert stages["restore"]["summary"].startswith("skipped: the gate is closed"), stages["restore"]
    assert stages["refine"]["summary"] == "skipped: nothing was restored; the refined model is the sparse model"
    assert d["refinement"]["why"] == "nothing was restored", d
    assert same("render", "restored") and same("render", "refined"), "the renders pass through"
    assert filecmp.cmp("%s/n%d/sparse.ply" % (root, n), "%s/n%d/refined.ply" % (root, n), shallow=False)
    assert run["gaussians"]["refined"] == run["gaussians"]["sparse"]
    m = run["means"]
    assert m["restored"]["psnr"] == m["sparse"]["psnr"] == m["refined"]["psnr"], m
else:
    assert "the gate is open" in stages["restore"]["summary"], stages["restore"]
    assert d["restoration"]["why"] is None and d["refinement"]["why"] is None, d
print(d["gate"])
PY
check "the gate's decision is kept" python3 check_gate.py A 6
has "decided: Restoration mode adapted. Adaptation ran. The gate is"
check "the report says what was decided" grep -q "<b>Decided:</b> Restoration mode adapted. Adaptation ran. The gate is" A/report.html

# The gated default where the scene has too few training views to adapt (n = 8: 4 views;
# the internal pairs need 5): the sparse model is kept, one line says why, no network runs.
expect 0 "too few views to adapt" -- "$G" reconstruct "${RC0[@]}" --interval 8 --out F --stop-after $LAST
has "n=8 restore: skipped: adaptation cannot run here because 25 frames give 4 training views at n = 8"
check "one stage line for it" test "$(grep -c "^n=8 .*adaptation cannot run here" "$T/out")" -eq 1
has "n=8 refine: skipped: nothing was restored; the refined model is the sparse model"
check "no adapt stage, no scene checkpoint" test ! -e F/n8/restorer.safetensors
check "the sparse model kept" python3 -c "
import filecmp, json
run = json.load(open('F/metrics.json'))['runs'][0]
d = run['decisions']
assert d['restore_with'] == 'adapted' and d['gate'] is None, d
assert not d['adaptation']['ran'] and d['adaptation']['why'].startswith('25 frames give 4 training views'), d
assert d['restoration'] == {'ran': False, 'why': 'adaptation cannot run here'}, d
assert d['refinement'] == {'ran': False, 'why': 'nothing was restored'}, d
assert not d['refinement']['ran'], d
assert [s['name'] for s in run['stages']] == ['train', 'render', 'restore', 'refine', 'evaluate'] + (['video'] if $HAVE_FFMPEG else [])
for f in run['frames']:
    for kind in ('restored', 'refined'):
        assert filecmp.cmp('F/' + f['images']['render'], 'F/' + f['images'][kind], shallow=False), (f, kind)
        assert f[kind] == f['sparse'], (f, kind)
assert filecmp.cmp('F/n8/sparse.ply', 'F/n8/refined.ply', shallow=False)
assert run['all_held_out']['refined'] == run['all_held_out']['sparse']"
has "decided: Restoration mode adapted. Adaptation skipped: 25 frames give 4 training views at n = 8 \
(frames 0, 8, ...); scene-internal pairs need at least 5 (at least 33 frames). Restoration skipped: adaptation cannot \
run here. The restored frames are the renders. Refinement skipped: nothing was restored. The refined model is the sparse model."

# --no-restore: the sparse model, its renders, evaluation, video and report; no restorer is
# needed (the checkpoint named does not exist) and no restored or refined frame is written.
expect 0 "no restore" -- "$G" reconstruct "${RC0[@]}" --no-restore --ckpt none.safetensors --out NR --stop-after $LAST
check "no restored or refined frames" test ! -e NR/n6/frames/restored -a ! -e NR/n6/frames/refined -a ! -e NR/n6/refined.ply
check "the same sparse model as the full path" cmp -s NR/n6/sparse.ply R/n6/sparse.ply
check "no-restore's metrics" python3 -c "
import json
d = json.load(open('NR/metrics.json')); run = d['runs'][0]; full = json.load(open('R/metrics.json'))['runs'][0]
assert d['restorer'] is None and run['inputs']['restore_with'] == 'none'
assert [s['name'] for s in run['stages']] == ['train', 'render', 'evaluate'] + (['video'] if $HAVE_FFMPEG else [])
assert all(run['decisions'][k] == {'ran': False, 'why': '--no-restore'} for k in ('adaptation', 'restoration', 'refinement'))
assert run['means']['restored'] is None and run['means']['refined'] is None and run['all_held_out']['refined'] is None
assert run['means']['sparse'] == full['means']['sparse'], (run['means'], full['means'])
for f in run['frames']:
    assert f['images']['restored'] is None and f['images']['refined'] is None and f['restored'] is None and f['refined'] is None"
has "decided: No restoration or refinement (--no-restore): the sparse model only."
if [ $HAVE_FFMPEG = 1 ]; then
    exists NR/report.html
    check "the report says it" grep -q "<b>Decided:</b> No restoration or refinement (--no-restore): the sparse model only.</p>" NR/report.html
    check "the no-restore video is 33 + 20 frames of sparse (render) | ground truth" test "$(ffprobe -v error \
        -count_frames -select_streams v:0 -show_entries stream=nb_read_frames,width,height -of csv=p=0 \
        NR/n6/flythrough.mp4)" = "128,48,53"
fi

# A restored folder switched to --no-restore: the sparse model is kept, and the restored
# frames, clips and refined model from before go with their stages' records.
cp -r R RN
exists RN/n6/clips/clip_0000.safetensors
expect 0 "switched to no restore" -- "$G" reconstruct "${RC0[@]}" --no-restore --out RN --stop-after $LAST
check "the sparse model not trained again" grep -q "n=6 train: done before, skipped" "$T/err"
check "the sparse model kept" cmp -s R/n6/sparse.ply RN/n6/sparse.ply
check "no refined model, restored frames or clips left" test ! -e RN/n6/refined.ply -a ! -e RN/n6/refined.splat \
    -a ! -e RN/n6/frames/restored -a ! -e RN/n6/frames/refined -a ! -e RN/n6/clips
check "the report links the sparse model" test "$(grep -c "Open the refined model" RN/report.html 2>/dev/null)" = 0

# A preset and a flag over it, recorded: fast (lean, no restoration) with 50 iterations.
expect 0 "fast with 50 iterations" -- "$G" reconstruct "${RC0[@]}" --preset fast --iters 50 --out FA --stop-after evaluate
check "the first line" test "$(first_line)" = \
    "reconstruct, preset fast: 50 sparse iterations (base dropgaussian,decay, lean density control, from 1/4 of the size), no restoration (the sparse model only)"
check "the preset and its settings recorded" python3 -c "
import json
d = json.load(open('FA/metrics.json')); i = d['runs'][0]['inputs']
assert d['preset'] == 'fast' and i['preset'] == 'fast', d
assert (i['iters'], i['densify'], i['restore_with']) == (50, 'lean', 'none'), i
assert d['runs'][0]['stages'][0]['summary'].endswith('50 iterations'), d['runs'][0]['stages'][0]"
expect 1 "stop after adapt, ungated" -- "$G" reconstruct "${RC[@]}" --out A --stop-after adapt
one_line "--stop-after adapt: the adapt stage runs only with --restore-with adapted (the default)"

cli_finish
