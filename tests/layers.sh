#!/bin/bash
# The modules' order (docs/LAYERS.md), written once: a file of a module may include the headers
# of its own module and of the modules below it, never of one above. Each line: a module and
# the modules right below it (what it may use, with everything below them). A module's public
# headers are include/gaussvid/MODULE/*.h, so a header's path names its owner. Fails naming
# every include that points up or sideways, every public header outside a module's folder,
# every src/ or include/gaussvid/ folder missing from the order, CBLAS outside src/nn/ and
# <mpi.h> outside src/core/dist.c.
# Usage: bash tests/layers.sh SOURCE_DIR
LAYERS='
core    : -
io      : core
pth     : io
scene   : io
synth   : scene
splat   : scene
nn      : core
model   : pth nn
data    : splat
train   : model data
restore : train
eval    : restore
report  : scene
pipeline: eval report
bench   : restore
cli     : pipeline bench synth
'
cd "${1:?usage: bash tests/layers.sh SOURCE_DIR}" || exit 1
declare -A below allowed
modules=()
while IFS=: read -r m under; do
    m=${m// /}
    [ -n "$m" ] || continue
    modules+=("$m")
    below[$m]=$(echo $under | tr -d -)
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
for f in include/gaussvid/*; do
    if [ -d "$f" ]; then
        [ -n "${allowed[$(basename "$f")]}" ] || bad "$f/ names no module"
    else
        bad "$f is in no module's folder: move it to include/gaussvid/MODULE/"
    fi
done

# module_of FILE: the module a source file or an included path belongs to.
module_of() {
    case $1 in
    include/gaussvid/*/*) local p=${1#include/gaussvid/}; echo "${p%%/*}" ;;
    gaussvid/*/*) local p=${1#gaussvid/}; echo "${p%%/*}" ;;
    gaussvid/*) ;;
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
# it, besides src/cli/runtime_env.c, which names the kernel OpenBLAS chose, and the benchmark of the engine
# against plain SGEMM.
for f in $(grep -rlE '#[[:space:]]*include[[:space:]]+<cblas.h>' src bench); do
    [[ $f == src/nn/* || $f == src/cli/runtime_env.c || $f == bench/bench_nn.c ]] || bad "$f includes <cblas.h>: use the tensor engine (gv_gemm, ops.h)"
done

# MPI is known to one file (docs/DISTRIBUTED.md): everything else asks dist.h.
for f in $(grep -rlE '#[[:space:]]*include[[:space:]]+<mpi.h>' src bench include tests); do
    [[ $f == src/core/dist.c ]] || bad "$f includes <mpi.h>: only src/core/dist.c does (use dist.h)"
done

echo "layers: $checked includes checked against ${#modules[@]} modules"
exit $failed
