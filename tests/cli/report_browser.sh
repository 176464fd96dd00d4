#!/bin/bash
# The report and the viewer in a browser (issue 23): headless Chromium opens report.html and
# viewer.html of a tiny reconstruction folder (tests/report/make_fixture.sh) from file://, and
# tests/report/browser_check.mjs checks, over the DevTools protocol, that there is no console
# error and no network request, that the table and the PSNR plot are on screen, that the
# viewer's canvas is not blank and that it changes when the path position moves and when the
# view is dragged. Then Chromium alone (--screenshot, no DevTools client) opens viewer.html as
# a user's browser would: no uncaught error, and the screenshot, taken when the page's load
# event has fired, shows the model on at least 30% of the canvas (tests/report/png_unlike.c
# measures it). Skipped (77) without Debian's chromium, a Node with WebSocket (>= 20), or the
# viewer's JavaScript in the source tree (scripts/setup.sh makes it; CMakeLists.txt builds the
# program without the viewer when it is missing, and `gaussvid report` then writes no viewer).
# Usage: bash report_browser.sh /path/to/gaussvid /path/to/png_unlike
source "$(dirname "$0")/lib/harness.sh"
cli_setup report_browser "$1"
UNLIKE=${2:?usage: bash report_browser.sh /path/to/gaussvid /path/to/png_unlike}
here="$(cd "$(dirname "$0")/.." && pwd)"
chromium=$(command -v chromium || true)
if [ -z "$chromium" ]; then echo "chromium is not installed (apt-get install chromium): skipped"; exit 77; fi
if ! node --experimental-websocket -e 'if (typeof WebSocket !== "function") process.exit(1)' 2>/dev/null; then
    echo "node >= 20 with WebSocket is needed for the DevTools protocol: skipped"; exit 77
fi
if [ ! -s "$here/../third_party/viewer/dist/viewer.js" ]; then
    echo "third_party/viewer/dist/viewer.js is missing (scripts/setup.sh makes it): skipped"; exit 77
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

# Plain --screenshot: the page must not depend on how it was opened or on load timing. The
# scene is 32x32, so in a 320x500 window the canvas is the top 320x320 square (the controls
# take less than the 180 rows below it); its background is black.
"$chromium" --headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader --hide-scrollbars \
    --user-data-dir="$T/profile" --no-first-run --window-size=320,500 --enable-logging=stderr --v=0 \
    --screenshot="$T/plain.png" "file://$D/n6/viewer.html" >"$T/out" 2>"$T/err"
check_rc "chromium --screenshot: $(tail -3 "$T/err")" $?
if grep -q "Uncaught" "$T/err"; then bad "viewer under --screenshot: $(grep -m1 Uncaught "$T/err")"; else ok; fi
share=$("$UNLIKE" "$T/plain.png" 0 0 320 320 000000 8)
check_rc "png_unlike on the plain screenshot" $?
if awk -v s="$share" 'BEGIN { exit !(s >= 0.30) }'; then ok
else bad "the plain screenshot's canvas shows the model on $share of its pixels (at least 0.30 expected)"; fi
# The measure itself: the window's bottom row, below the controls, is the page's #111.
check "png_unlike: #111 is unlike black" test "$("$UNLIKE" "$T/plain.png" 0 499 320 1 000000 8)" = 1.0000
check "png_unlike: #111 is like #111" test "$("$UNLIKE" "$T/plain.png" 0 499 320 1 111111 0)" = 0.0000
cli_finish
