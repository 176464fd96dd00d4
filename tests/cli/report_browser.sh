#!/bin/bash
# The report and the viewer in a browser (issue 23): headless Chromium opens report.html and
# viewer.html of a tiny reconstruction folder (tests/report/make_fixture.sh) from file://, and
# tests/report/browser_check.mjs checks, over the DevTools protocol, that there is no console
# error and no network request, that the table and the PSNR plot are on screen, that the
# viewer's canvas is not blank and that it changes when the path position moves and when the
# view is dragged. Skipped (77) without Debian's chromium or a Node with WebSocket (>= 20).
# Usage: bash report_browser.sh /path/to/gaussvid
source "$(dirname "$0")/lib/harness.sh"
cli_setup report_browser "$1"
here="$(cd "$(dirname "$0")/.." && pwd)"
chromium=$(command -v chromium || true)
if [ -z "$chromium" ]; then echo "chromium is not installed (apt-get install chromium): skipped"; exit 77; fi
if ! node --experimental-websocket -e 'if (typeof WebSocket !== "function") process.exit(1)' 2>/dev/null; then
    echo "node >= 20 with WebSocket is needed for the DevTools protocol: skipped"; exit 77
fi

"$G" scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out "$T/scene" --quiet
D="$T/run"
bash "$here/report/make_fixture.sh" "$G" "$T/scene" "$D" 6 30 > /dev/null 2>&1
check "fixture" test -s "$D/metrics.json"
expect 0 "report" -- "$G" report "$D" --quiet

browse() { # browse MODE FILE: the check's JSON line in $T/out, its messages in $T/err
    node --experimental-websocket "$here/report/browser_check.mjs" "$chromium" "$1" "$2" "$T/$1.png" >"$T/out" 2>"$T/err"
}
browse report "$D/report.html"
check_rc "report in Chromium: $(cat "$T/out" "$T/err")" $?
has '"table_visible":true'
has '"plot_visible":true'
has '"images_not_data":0'
browse viewer "$D/n6/viewer.html"
check_rc "viewer in Chromium: $(cat "$T/out" "$T/err")" $?
has '"state":"loaded"'
has '"failures":[]'
check "screenshots" test -s "$T/report.png" -a -s "$T/viewer.png"
cli_finish
