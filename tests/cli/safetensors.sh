#!/bin/bash
# gaussvid st inspect: listing (text and JSON), exit codes, and malformed files.
# Usage: bash safetensors.sh /path/to/gaussvid   ($GV_TMP: scratch folder)
# The files are written here byte by byte with printf, so the test does not depend on the
# library's writer or on any other tool.
set -u
GV="$1"
DIR="${GV_TMP:-/tmp/gaussvid-cli-safetensors}"
rm -rf "$DIR" && mkdir -p "$DIR" || exit 1
passed=0
failed=0

check() { # check "description" condition-exit-status
    if [ "$2" -eq 0 ]; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAILED: $1"; fi
}

le64() { # the 8-byte little-endian form of $1
    local i out=""
    for i in 0 1 2 3 4 5 6 7; do out+=$(printf '\\x%02x' $((($1 >> (8 * i)) & 255))); done
    printf "$out"
}

make_st() { # make_st FILE HEADER DATA-printf-format [LENGTH]: a safetensors file
    { le64 "${4:-${#2}}"; printf '%s' "$2"; printf "$3"; } > "$1"
}

# A good file: two tensors listed out of name order, and metadata.
GOOD="$DIR/good.safetensors"
HEADER='{"__metadata__":{"step":"12","note":"hi there"},"w":{"dtype":"F32","shape":[2,2],"data_offsets":[0,16]},"ids":{"dtype":"U8","shape":[3],"data_offsets":[16,19]}}'
make_st "$GOOD" "$HEADER" '\x00\x00\x80\x3f\x00\x00\x00\x40\x00\x00\x40\x40\x00\x00\x80\x40\x01\x02\x03'

out=$("$GV" st inspect "$GOOD" 2>&1)
check "inspect exits 0 on a good file" $?
echo "$out" | grep -Eq '^  w +F32 +\[2, 2\] +16$'
check "w listed with dtype, shape and bytes" $?
echo "$out" | grep -Eq '^  ids +U8 +\[3\] +3$'
check "ids listed with dtype, shape and bytes" $?
echo "$out" | grep -q "total: 2 tensors, 7 elements, 19 bytes"
check "totals" $?
echo "$out" | grep -q "header ${#HEADER}, data 19"
check "header and data sizes" $?
echo "$out" | grep -q "  step: 12" && echo "$out" | grep -q "  note: hi there"
check "metadata listed" $?
[ "$(echo "$out" | grep -n '^  ids' | cut -d: -f1)" -lt "$(echo "$out" | grep -n '^  w ' | cut -d: -f1)" ]
check "tensors listed by name" $?

json=$("$GV" st inspect "$GOOD" --json 2>&1)
check "inspect --json exits 0" $?
echo "$json" | grep -Eq '"n_tensors":[[:space:]]*2'
check "json tensor count" $?
echo "$json" | grep -Eq '"name":[[:space:]]*"w"' && echo "$json" | grep -Eq '"dtype":[[:space:]]*"F32"'
check "json tensor name and dtype" $?
echo "$json" | grep -Eq '"step":[[:space:]]*"12"'
check "json metadata" $?
echo "$json" | tr -d ' \t\n' | grep -q '"shape":\[2,2\],"data_offsets":\[0,16\],"bytes":16'
check "json shape, offsets and bytes" $?

# A long metadata value is cut in the text listing and whole in the JSON.
LONG=$(printf 'x%.0s' $(seq 1 400))
make_st "$DIR/long.safetensors" "{\"__metadata__\":{\"config\":\"$LONG\"}}" ''
"$GV" st inspect "$DIR/long.safetensors" | grep -q "(400 bytes; --json shows all)"
check "long metadata value cut in text" $?
"$GV" st inspect "$DIR/long.safetensors" --json | grep -q "$LONG"
check "long metadata value whole in JSON" $?

# Malformed files: exit 1 and one line naming the file and the problem.
bad() { # bad NAME HEADER DATA NEEDLE [LENGTH]
    local f="$DIR/$1.safetensors" msg
    make_st "$f" "$2" "$3" "${5:-}"
    msg=$("$GV" st inspect "$f" 2>&1 >/dev/null)
    local rc=$?
    [ $rc -eq 1 ] && echo "$msg" | grep -qF "$f" && echo "$msg" | grep -qF "$4" && [ "$(echo "$msg" | wc -l)" -eq 1 ]
    check "$1: exit 1 with '$4' (got $rc: $msg)" $?
}
T='{"dtype":"F32","shape":[1],"data_offsets"'
bad overlap "{\"a\":$T:[0,4]},\"b\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[2,10]}}" '%010d' "overlap"
bad hole "{\"a\":$T:[0,4]},\"b\":$T:[8,12]}}" '%012d' "hole of 4 bytes"
bad range "{\"a\":$T:[0,4]}}" '\x00\x00' "run past the 2-byte data region"
bad beyond '{}' '' "runs past the end" 4096
bad absurd '{}' '' "beyond the format's limit" 4000000000
bad json '{"a":' '' "not valid JSON"
bad dtype '{"a":{"dtype":"Q8","shape":[1],"data_offsets":[0,1]}}' 'x' "unknown dtype Q8"
bad meta '{"__metadata__":{"n":1}}' '' "metadata value of 'n' is not a string"

"$GV" st inspect "$DIR/absent.safetensors" >/dev/null 2>&1
check "missing file exits 1" $([ $? -eq 1 ]; echo $?)

# Usage: help exits 0, usage errors exit 2.
"$GV" st --help | grep -q inspect
check "st --help lists inspect" $?
"$GV" st inspect --help | grep -q -- "--json"
check "st inspect --help" $?
"$GV" st inspect >/dev/null 2>&1
check "missing FILE exits 2" $([ $? -eq 2 ]; echo $?)
"$GV" st frobnicate >/dev/null 2>&1
check "unknown subcommand exits 2" $([ $? -eq 2 ]; echo $?)
"$GV" st inspect "$GOOD" --bogus >/dev/null 2>&1
check "unknown flag exits 2" $([ $? -eq 2 ]; echo $?)

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
