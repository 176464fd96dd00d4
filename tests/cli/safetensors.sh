#!/bin/bash
# gaussvid st inspect: listing (text and JSON), exit codes, and malformed files.
# Usage: bash safetensors.sh /path/to/gaussvid   ($GV_TMP: scratch folder)
# The files are written here byte by byte with printf, so the test does not depend on the
# library's writer or on any other tool.
set -u
source "$(dirname "$0")/lib/harness.sh"
cli_setup safetensors "$1"

make_st() { # make_st FILE HEADER DATA-printf-format [LENGTH]: a safetensors file
    { le64 "${4:-${#2}}"; printf '%s' "$2"; printf "$3"; } > "$1"
}

# A good file: two tensors listed out of name order, and metadata.
GOOD="$T/good.safetensors"
HEADER='{"__metadata__":{"step":"12","note":"hi there"},"w":{"dtype":"F32","shape":[2,2],"data_offsets":[0,16]},"ids":{"dtype":"U8","shape":[3],"data_offsets":[16,19]}}'
make_st "$GOOD" "$HEADER" '\x00\x00\x80\x3f\x00\x00\x00\x40\x00\x00\x40\x40\x00\x00\x80\x40\x01\x02\x03'

out=$("$G" st inspect "$GOOD" 2>&1)
check_rc "inspect exits 0 on a good file" $?
echo "$out" | grep -Eq '^  w +F32 +\[2, 2\] +16$'
check_rc "w listed with dtype, shape and bytes" $?
echo "$out" | grep -Eq '^  ids +U8 +\[3\] +3$'
check_rc "ids listed with dtype, shape and bytes" $?
echo "$out" | grep -q "total: 2 tensors, 7 elements, 19 bytes"
check_rc "totals" $?
echo "$out" | grep -q "header ${#HEADER}, data 19"
check_rc "header and data sizes" $?
echo "$out" | grep -q "  step: 12" && echo "$out" | grep -q "  note: hi there"
check_rc "metadata listed" $?
[ "$(echo "$out" | grep -n '^  ids' | cut -d: -f1)" -lt "$(echo "$out" | grep -n '^  w ' | cut -d: -f1)" ]
check_rc "tensors listed by name" $?

json=$("$G" st inspect "$GOOD" --json 2>&1)
check_rc "inspect --json exits 0" $?
echo "$json" | grep -Eq '"n_tensors":[[:space:]]*2'
check_rc "json tensor count" $?
echo "$json" | grep -Eq '"name":[[:space:]]*"w"' && echo "$json" | grep -Eq '"dtype":[[:space:]]*"F32"'
check_rc "json tensor name and dtype" $?
echo "$json" | grep -Eq '"step":[[:space:]]*"12"'
check_rc "json metadata" $?
echo "$json" | tr -d ' \t\n' | grep -q '"shape":\[2,2\],"data_offsets":\[0,16\],"bytes":16'
check_rc "json shape, offsets and bytes" $?

# A long metadata value is cut in the text listing and whole in the JSON.
LONG=$(printf 'x%.0s' $(seq 1 400))
make_st "$T/long.safetensors" "{\"__metadata__\":{\"config\":\"$LONG\"}}" ''
"$G" st inspect "$T/long.safetensors" | grep -q "(400 bytes; --json shows all)"
check_rc "long metadata value cut in text" $?
"$G" st inspect "$T/long.safetensors" --json | grep -q "$LONG"
check_rc "long metadata value whole in JSON" $?

# Malformed files: exit 1 and one line naming the file and the problem.
malformed() { # malformed NAME HEADER DATA NEEDLE [LENGTH]
    local f="$T/$1.safetensors" msg
    make_st "$f" "$2" "$3" "${5:-}"
    msg=$("$G" st inspect "$f" 2>&1 >/dev/null)
    local rc=$?
    [ $rc -eq 1 ] && echo "$msg" | grep -qF "$f" && echo "$msg" | grep -qF "$4" && [ "$(echo "$msg" | wc -l)" -eq 1 ]
    check_rc "$1: exit 1 with '$4' (got $rc: $msg)" $?
}
F32='{"dtype":"F32","shape":[1],"data_offsets"'
malformed overlap "{\"a\":$F32:[0,4]},\"b\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[2,10]}}" '%010d' "overlap"
malformed hole "{\"a\":$F32:[0,4]},\"b\":$F32:[8,12]}}" '%012d' "hole of 4 bytes"
malformed range "{\"a\":$F32:[0,4]}}" '\x00\x00' "run past the 2-byte data region"
malformed beyond '{}' '' "runs past the end" 4096
malformed absurd '{}' '' "beyond the format's limit" 4000000000
malformed json '{"a":' '' "not valid JSON"
malformed dtype '{"a":{"dtype":"Q8","shape":[1],"data_offsets":[0,1]}}' 'x' "unknown dtype Q8"
malformed meta '{"__metadata__":{"n":1}}' '' "metadata value of 'n' is not a string"

"$G" st inspect "$T/absent.safetensors" >/dev/null 2>&1
check_rc "missing file exits 1" $([ $? -eq 1 ]; echo $?)

# Usage: help exits 0, usage errors exit 2.
"$G" st --help | grep -q inspect
check_rc "st --help lists inspect" $?
"$G" st inspect --help | grep -q -- "--json"
check_rc "st inspect --help" $?
"$G" st inspect >/dev/null 2>&1
check_rc "missing FILE exits 2" $([ $? -eq 2 ]; echo $?)
"$G" st frobnicate >/dev/null 2>&1
check_rc "unknown subcommand exits 2" $([ $? -eq 2 ]; echo $?)
"$G" st inspect "$GOOD" --bogus >/dev/null 2>&1
check_rc "unknown flag exits 2" $([ $? -eq 2 ]; echo $?)

cli_finish
