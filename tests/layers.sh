#!/bin/bash
# The modules' order (docs/LAYERS.md), written once: a file of a module may include the headers
# of its own module and of the modules below it, never of one above. Each line: a module, the
# modules right below it (what it may use, with everything below them), and its public headers
# in include/gaussvid/. Fails naming every include that points up or sideways, every public
# header no module owns, every src/ folder missing from the order, CBLAS outside src/nn/ and
# <mpi.h> outside src/core/dist.c.
# Usage: bash tests/layers.sh SOURCE_DIR
LAYERS='
core    : -           : core camera dist
io      : core        : image metrics gaussians ply colmap transforms safetensors npy json
pth     : io          : weight_files
scene   : io          : scene reproject scene_colmap
synth   : scene       : synth
splat   : scene       : splat splat_train render coverage
nn      : core        : tensor ops optim nn
model   : pth nn      : model_config dit vae plucker plucker_official weight_names umt5 release_lora
data    : splat       : dataset internal_pairs
train   : model data  : train condition checkpoint vae_train model_import scene_adapt
restore : train       : restore adapt
eval    : restore     : eval lpips consistency
report  : scene       : report
pipeline: eval report : pipeline
bench   : restore     : -
cli     : pipeline bench synth : -
'
cd "${1:?usage: bash tests/layers.sh SOURCE_DIR}" || exit 1
declare -A below owner allowed
modules=()
while IFS=: read -r m under headers; do
    m=${m// /}
    [ -n "$m" ] || continue
    modules+=("$m")
    below[$m]=$(echo $under | tr -d -)
    for h in $(echo $headers | tr -d -); do owner[gaussvid/$h.h]=$m; done
done <<<"$LAYERS"

# allowed[m]: m and, recursively, everything below it (modules are listed bottom up).
for m in "${modules[@]}"; do
    allowed[$m]=" $m "
    for u in ${below[$m]}; do allowed[$m]+="${allowed[$u]} "; done
done

failed=0
bad() { echo "layers: $*" >&2; failed=1; }
for d in src/*/; do
    d=$(basename "$d")
    [ -n "${allowed[$d]}" ] || bad "src/$d/ is in no layer: place it in tests/layers.sh"
done
for f in include/gaussvid/*.h; do
    [ -n "${owner[gaussvid/$(basename "$f")]}" ] || bad "$f belongs to no module: add it to tests/layers.sh"
done

# module_of FILE: the module a source file or an included path belongs to.
module_of() {
    case $1 in
    include/gaussvid/*) echo "${owner[gaussvid/${1#include/gaussvid/}]}" ;;
    gaussvid/*) echo "${owner[$1]}" ;;
    src/*) local p=${1#src/}; echo "${p%%/*}" ;;
    */*) echo "${1%%/*}" ;;
    esac
}

checked=0
while read -r f; do
    m=$(module_of "$f")
    [ -n "$m" ] || continue
    while IFS= read -r line; do
        inc=${line#*\"}
        inc=${inc%%\"*}
        [[ $inc == */* ]] || continue # a header beside the file (e.g. "bench.h")
        to=$(module_of "$inc")
        checked=$((checked + 1))
        if [ -z "$to" ]; then bad "$f includes $inc, which belongs to no module"
        elif [[ ${allowed[$m]} != *" $to "* ]]; then bad "$f ($m) includes $inc ($to): $to is not below $m"
        fi
    done < <(grep -E '^[[:space:]]*#[[:space:]]*include[[:space:]]+"' "$f")
done < <(find src bench include -name '*.[ch]' | sort)

# CBLAS is the tensor engine's (docs/ARCHITECTURE.md 10: GEMM behind a narrow interface): only src/nn/ calls
# it, besides main.c, which names the kernel OpenBLAS chose, and the benchmark of the engine
# against plain SGEMM.
for f in $(grep -rlE '#[[:space:]]*include[[:space:]]+<cblas.h>' src bench); do
    [[ $f == src/nn/* || $f == src/cli/main.c || $f == bench/bench_nn.c ]] || bad "$f includes <cblas.h>: use the tensor engine (gv_gemm, ops.h)"
done

# MPI is known to one file (docs/DISTRIBUTED.md): everything else asks dist.h.
for f in $(grep -rlE '#[[:space:]]*include[[:space:]]+<mpi.h>' src bench include tests); do
    [[ $f == src/core/dist.c ]] || bad "$f includes <mpi.h>: only src/core/dist.c does (use dist.h)"
done

echo "layers: $checked includes checked against ${#modules[@]} modules"
exit $failed
