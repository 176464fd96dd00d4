#!/bin/bash
# Runs every libFuzzer harness of a fuzz build, one at a time, for a bounded time each, on
# the committed seeds of fuzz/corpus/NAME (regression inputs included: each runs first) and a
# working corpus in BUILD/fuzz-corpus/NAME that grows between runs (not committed). Fails on
# any crash, leak, sanitizer report, input taking more than FUZZ_CPU_LIMIT seconds of CPU
# (default 1; checked by the harness, fuzz/fuzz.h) or FUZZ_TIMEOUT seconds of wall time
# (default 30: the backstop for an input that never ends, generous because the two cores are
# shared), or allocation above FUZZ_MALLOC_MB (default 1024: a small file must not ask for
# more). Appends one line per harness to BUILD/fuzz-report.txt: executions, coverage,
# result. FUZZ_SEED fixes libFuzzer's random seed (`make test` sets it, so its short pass
# explores the same way each time).
# Usage: bash fuzz/run.sh BUILD SECONDS [NAME...]    (NAME: colmap_bin, ply, ...)
set -uo pipefail
BUILD=$(realpath "${1:?usage: bash fuzz/run.sh BUILD SECONDS [NAME...]}")
SECONDS_EACH=${2:?usage: bash fuzz/run.sh BUILD SECONDS [NAME...]}
shift 2
ROOT=$(cd "$(dirname "$0")/.." && pwd)
TIMEOUT=${FUZZ_TIMEOUT:-30}
export FUZZ_CPU_LIMIT=${FUZZ_CPU_LIMIT:-1}
MALLOC_MB=${FUZZ_MALLOC_MB:-1024}
names=("$@")
if [ ${#names[@]} -eq 0 ]; then
    for f in "$ROOT"/fuzz/fuzz_*.c; do n=$(basename "$f" .c); names+=("${n#fuzz_}"); done
fi
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive
mkdir -p "$BUILD/fuzz-artifacts" "$BUILD/fuzz-logs"
report="$BUILD/fuzz-report.txt"
failed=()
for name in "${names[@]}"; do
    exe="$BUILD/fuzz_$name"
    if [ ! -x "$exe" ]; then echo "fuzz: $exe is not built" >&2; failed+=("$name"); continue; fi
    seeds="$ROOT/fuzz/corpus/$name"
    work="$BUILD/fuzz-corpus/$name"
    mkdir -p "$work"
    seed=()
    [ -n "${FUZZ_SEED:-}" ] && seed=(-seed="$FUZZ_SEED")
    dict=()
    [ -f "$ROOT/fuzz/dict/$name.dict" ] && dict=(-dict="$ROOT/fuzz/dict/$name.dict")
    log="$BUILD/fuzz-logs/$name.log"
    nice -n 19 "$exe" -max_total_time="$SECONDS_EACH" -timeout="$TIMEOUT" -malloc_limit_mb="$MALLOC_MB" \
        -rss_limit_mb=2048 -print_final_stats=1 -close_fd_mask=1 "${seed[@]}" "${dict[@]}" \
        -artifact_prefix="$BUILD/fuzz-artifacts/$name-" "$work" "$seeds" > "$log" 2>&1
    rc=$?
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
    cov=$(grep -oE '(DONE|pulse|NEW|REDUCE|INITED) +cov: [0-9]+ ft: [0-9]+' "$log" | tail -1 | grep -oE 'cov: [0-9]+ ft: [0-9]+')
    result=ok
    if [ $rc -ne 0 ]; then
        result="FAILED (exit $rc; $(grep -m1 -E 'ERROR: |SUMMARY: |fuzz: |timeout|out-of-memory' "$log" | cut -c1-160))"
        failed+=("$name")
    fi
    line="$(date -u +%Y-%m-%dT%H:%MZ) $name ${SECONDS_EACH}s execs=${execs:-?} ${cov:-cov: ?} corpus=$(ls "$work" | wc -l) $result"
    echo "$line" | tee -a "$report"
done
if [ ${#failed[@]} -ne 0 ]; then
    echo "fuzz: failed: ${failed[*]} (logs in $BUILD/fuzz-logs, inputs in $BUILD/fuzz-artifacts)" >&2
    exit 1
fi
