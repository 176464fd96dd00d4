#!/bin/bash
# gaussvid report on a folder made by tests/report/make_fixture.sh from a tiny synthesised
# scene (real 3DGS models and renders, a held-out run and a smooth-path run): exit codes, the
# files written, the page self-contained, the viewer's model bytes exactly the .splat file's,
# and bad folders failing with one line that names the file and the key.
# Usage: bash report.sh /path/to/gaussvid
source "$(dirname "$0")/lib/harness.sh"
cli_setup report "$1"
fixture="$(dirname "$0")/../report/make_fixture.sh"

"$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out "$T/scene" --quiet
D="$T/run"
bash "$fixture" "$G" "$T/scene" "$D" 6 10 > /dev/null 2>&1
check "fixture: held-out run" test -s "$D/metrics.json"
bash "$fixture" "$G" "$T/scene" "$D" 4 10 smooth 5 > /dev/null 2>&1
check "fixture: smooth run" test -s "$D/n4/frames/render/frame_00004.png"

expect 0 "report" -- "$G" report "$D"
has "$D/report.html"
exists "$D/report.html"
exists "$D/n6/viewer.html"
exists "$D/n4/viewer.html"
check "no network address in the report" test -z "$(grep -ai 'http' "$D/report.html")"
check "no script in the report" test -z "$(grep -ai '<script' "$D/report.html")"
images=$(grep -o 'src="[^"]\{0,30\}' "$D/report.html" | wc -l)
embedded=$(grep -o 'src="data:image/png;base64,' "$D/report.html" | wc -l)
check "every image is embedded ($embedded of $images)" test "$images" -gt 0 -a "$images" -eq "$embedded"
check "the report links the viewers" grep -q 'href="n6/viewer.html"' "$D/report.html"
check "one plot: the held-out run" test "$(grep -o '<svg class="psnr-plot"' "$D/report.html" | wc -l)" -eq 1
check "the smooth run shows change maps" grep -q 'data-image="change-restored"' "$D/report.html"

# The viewer carries the refined model's bytes exactly.
sed -n 's/.*<script id="gv-model"[^>]*>\([^<]*\)<\/script>.*/\1/p' "$D/n6/viewer.html" | base64 -d > "$T/model.splat"
check "viewer: the model round-trips" cmp -s "$T/model.splat" "$D/n6/refined.splat"
check "viewer: no external script" test -z "$(grep -ao '<script src' "$D/n6/viewer.html")"

# Again: the same bytes (nothing depends on the clock).
cp "$D/report.html" "$T/first.html"
"$G" report "$D" --quiet > /dev/null
check "the same folder gives the same report" cmp -s "$D/report.html" "$T/first.html"

# Bad folders: one line naming the file and the key; the report before stays.
cp "$D/metrics.json" "$T/metrics.good"
sed 's/"interval": 6,/"interval": "six",/' "$T/metrics.good" > "$D/metrics.json"
expect 1 "malformed interval" -- "$G" report "$D"
one_line 'metrics.json: runs[1].interval: expected a number, found a string'
check "the report before stays" cmp -s "$D/report.html" "$T/first.html"
sed 's/"ssim": /"SSIM": /' "$T/metrics.good" > "$D/metrics.json"
expect 1 "a missing key" -- "$G" report "$D"
one_line '.sparse.ssim: missing'
# An empty render path (the fuzzer's was NUL bytes, which end a JSON string): refused, not read.
sed '0,/"render": "[^"]*"/s//"render": ""/' "$T/metrics.good" > "$D/metrics.json"
expect 1 "an empty render path" -- "$G" report "$D"
one_line '.images.render: expected a path, found ""'
head -c 200 "$T/metrics.good" > "$D/metrics.json"
expect 1 "truncated" -- "$G" report "$D"
one_line 'metrics.json: not valid JSON'
cp "$T/metrics.good" "$D/metrics.json"
worst=$(sed -n '/<section class="run" id="n6">/,$p' "$D/report.html" | grep -o '<figure class="strip" data-frame="[0-9]*"' | head -1 | grep -o '[0-9]*"$' | tr -d '"')
mv "$D/n6/frames/render/frame_$(printf %05d "$worst").png" "$T/"
expect 1 "a missing image" -- "$G" report "$D"
one_line "n6/frames/render/frame_$(printf %05d "$worst").png: image named in metrics.json does not exist"
rm "$D/metrics.json"
expect 1 "no metrics.json" -- "$G" report "$D"
one_line "metrics.json: missing"
expect 1 "no folder" -- "$G" report "$T/nowhere"
one_line "nowhere: no such folder"
expect 2 "no folder given" -- "$G" report
cli_finish
