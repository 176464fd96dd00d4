#!/usr/bin/env bash
# Installs gaussvid's build dependencies from Debian's packages, then vendors the browser
# viewer's JavaScript from npm (vendor_viewer below). Idempotent: does nothing when
# everything is already there. Needs root for apt-get; otherwise says what to install.
set -euo pipefail
cd "$(dirname "$0")/.."

# chromium: the browser check of the report and the viewer (tests/cli/report_browser.sh).
packages=(build-essential cmake pkg-config libopenblas-openmp-dev libpng-dev libjpeg-dev
          libcjson-dev zlib1g-dev libsentencepiece-dev chromium
          openmpi-bin libopenmpi-dev)   # mpirun: data-parallel training (docs/DISTRIBUTED.md)
# `reconstruct` encodes its video with ffmpeg; `scene colmap` runs COLMAP (headless, on the CPU).
packages+=(ffmpeg colmap)
# `setup.sh fuzz`: the libFuzzer harnesses need clang, its sanitizer and libFuzzer runtimes
# and its OpenMP (fuzz/fuzz.cmake).
if [ "${1:-}" = fuzz ]; then packages+=(clang libclang-rt-dev libomp-dev); fi

# The viewer (docs/REPORT.md): three.js and Spark at the exact versions of
# third_party/viewer/package-lock.json, installed with `npm ci` and bundled with esbuild into
# third_party/viewer/dist/viewer.js, which the build copies into the program. Only here is the
# network used; the build and the program never touch it. npm ci again when the lock file
# changed, the bundle again when the lock file or the viewer's code did.
vendor_viewer() {
  local v=third_party/viewer
  if [ ! -f $v/node_modules/.package-lock.json ] || [ $v/package-lock.json -nt $v/node_modules/.package-lock.json ]; then
    echo "setup.sh: vendoring the viewer's JavaScript (npm ci in $v)"
    (cd $v && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error)
  fi
  if [ ! -f $v/dist/viewer.js ] || [ $v/package-lock.json -nt $v/dist/viewer.js ] || [ $v/viewer.js -nt $v/dist/viewer.js ]; then
    (cd $v && npm run --silent bundle -- --log-level=warning)
  fi
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# npm comes with Debian's nodejs + npm, or with another nodejs package that includes it.
command -v npm >/dev/null || missing+=(nodejs npm)
if [ ${#missing[@]} -eq 0 ]; then
  vendor_viewer
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "setup.sh: missing Debian packages: ${missing[*]}" >&2
  echo "setup.sh: install them with: sudo apt-get install ${missing[*]}" >&2
  exit 1
fi
echo "setup.sh: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
vendor_viewer
