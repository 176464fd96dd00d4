#!/usr/bin/env bash
# Installs gaussvid's build dependencies from Debian's packages. Idempotent: does nothing
# when everything is already there. Needs root for apt-get; otherwise says what to install.
set -euo pipefail

packages=(build-essential cmake pkg-config libopenblas-openmp-dev libpng-dev libjpeg-dev
          libcjson-dev zlib1g-dev libsentencepiece-dev
          openmpi-bin libopenmpi-dev)   # mpirun: data-parallel training (docs/DISTRIBUTED.md)
# `reconstruct` encodes its video with ffmpeg; `scene colmap` runs COLMAP (headless, on the CPU).
packages+=(ffmpeg colmap)
# `setup.sh fuzz`: the libFuzzer harnesses need clang, its sanitizer and libFuzzer runtimes
# and its OpenMP (fuzz/fuzz.cmake).
if [ "${1:-}" = fuzz ]; then packages+=(clang libclang-rt-dev libomp-dev); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

if [ "$(id -u)" -ne 0 ]; then
  echo "setup.sh: missing Debian packages: ${missing[*]}" >&2
  echo "setup.sh: install them with: sudo apt-get install ${missing[*]}" >&2
  exit 1
fi
echo "setup.sh: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
