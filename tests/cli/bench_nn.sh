#!/bin/bash
# gaussvid bench nn: help, usage errors, and the --quick smoke run in table and JSON form
# (one small shape; the full run and its numbers are in docs/BENCHMARKS.md).
# Usage: bash bench_nn.sh /path/to/gaussvid
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup bench-nn "$1"

"$G" bench --help >/dev/null 2>&1
check_rc "bench --help exits 0" $?
"$G" bench nn --help | grep -q -- "--json"
check_rc "bench nn --help lists --json" $?
"$G" bench nope >/dev/null 2>&1
check_rc "unknown bench exits 2" $(($? == 2 ? 0 : 1))
"$G" bench nn --nope >/dev/null 2>&1
check_rc "unknown flag exits 2" $(($? == 2 ? 0 : 1))
"$G" bench nn extra >/dev/null 2>&1
check_rc "positional argument exits 2" $(($? == 2 ? 0 : 1))

table=$(OMP_NUM_THREADS=1 "$G" bench nn --quick)
check_rc "quick table runs" $?
echo "$table" | grep -q "linear fwd+bwd"
check_rc "table has the linear section" $?
echo "$table" | grep -q "arena peak MB"
check_rc "table has the block section" $?

json=$(OMP_NUM_THREADS=1 "$G" bench nn --quick --json)
check_rc "quick JSON runs" $?
# Two linear shapes (D->D and D->4D), each with both GFLOP/s figures as positive numbers.
n=$(echo "$json" | grep -c '"linear_gflops": [0-9]*\.[0-9], "sgemm_gflops": [0-9]*\.[0-9]')
check_rc "JSON lists each linear shape with linear_gflops and sgemm_gflops ($n)" $((n == 2 ? 0 : 1))
echo "$json" | grep -q '"forward_backward_ms": [0-9]'
check_rc "JSON has attention and block times" $?
echo "$json" | head -1 | grep -q '^{$' && echo "$json" | tail -1 | grep -q '^}$'
check_rc "JSON is one object" $?

cli_finish
