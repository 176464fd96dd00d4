#!/bin/bash
# gaussvid bench nn: help, usage errors, and the --quick smoke run in table and JSON form
# (one small shape; the full run and its numbers are in docs/BENCHMARKS.md).
# Usage: bash bench_nn.sh /path/to/gaussvid
set -u
GV="$1"
passed=0
failed=0

check() { # check "description" condition-exit-status
    if [ "$2" -eq 0 ]; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: $1"; fi
}

"$GV" bench --help >/dev/null 2>&1
check "bench --help exits 0" $?
"$GV" bench nn --help | grep -q -- "--json"
check "bench nn --help lists --json" $?
"$GV" bench nope >/dev/null 2>&1
check "unknown bench exits 2" $(($? == 2 ? 0 : 1))
"$GV" bench nn --nope >/dev/null 2>&1
check "unknown flag exits 2" $(($? == 2 ? 0 : 1))
"$GV" bench nn extra >/dev/null 2>&1
check "positional argument exits 2" $(($? == 2 ? 0 : 1))

table=$(OMP_NUM_THREADS=1 "$GV" bench nn --quick)
check "quick table runs" $?
echo "$table" | grep -q "linear fwd+bwd"
check "table has the linear section" $?
echo "$table" | grep -q "arena peak MB"
check "table has the block section" $?

json=$(OMP_NUM_THREADS=1 "$GV" bench nn --quick --json)
check "quick JSON runs" $?
# Two linear shapes (D->D and D->4D), each with both GFLOP/s figures as positive numbers.
n=$(echo "$json" | grep -c '"linear_gflops": [0-9]*\.[0-9], "sgemm_gflops": [0-9]*\.[0-9]')
check "JSON lists each linear shape with linear_gflops and sgemm_gflops ($n)" $((n == 2 ? 0 : 1))
echo "$json" | grep -q '"forward_backward_ms": [0-9]'
check "JSON has attention and block times" $?
echo "$json" | head -1 | grep -q '^{$' && echo "$json" | tail -1 | grep -q '^}$'
check "JSON is one object" $?

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
