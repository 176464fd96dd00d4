# The command-line tests' shared harness: sourced by tests/cli/*.sh, which ctest runs as
# `bash SCRIPT /path/to/gaussvid` with $GV_TMP a scratch folder (tests/tests.cmake).
#
#   cli_setup NAME PROG G = PROG, T = a fresh scratch folder, counters at zero
#   check DESC CMD...   counts CMD's success
#   check_rc DESC RC    counts an exit status computed by the caller (0 = success)
#   expect RC DESC -- CMD...
#                       runs CMD with stdout in $T/out and stderr in $T/err; counts whether
#                       it exited with RC
#   one_line NEEDLE     $T/err is exactly one line and mentions NEEDLE (the one-line failure
#                       every command promises)
#   has TEXT            $T/out contains TEXT
#   exists PATH         PATH exists
#   le64 N              prints the 8 little-endian bytes of N (safetensors headers)
#   tiny1_config FILE   writes configs/tiny.json with a VAE of temporal factor 1 (one frame
#                       per latent, as adapt's internal clips need) and counts it made
#   st_zeros FILE "NAME D0,D1,..." ...
#                       writes a safetensors file of F32 zeros with those tensors
#   cli_finish          prints "N passed, M failed" and returns non-zero on any failure

cli_setup() {
    G=${2:?usage: bash $1.sh /path/to/gaussvid}
    T=${GV_TMP:-/tmp/gaussvid-cli-$1}
    rm -rf "$T" && mkdir -p "$T" || exit 1
    passed=0
    failed=0
}

ok() { passed=$((passed + 1)); }
bad() { failed=$((failed + 1)); echo "FAILED: $*" >&2; }

check() {
    local what="$1"
    shift
    if "$@"; then ok; else bad "$what"; fi
}

check_rc() { if [ "$2" -eq 0 ]; then ok; else bad "$1"; fi; }

expect() {
    local code=$1 what=$2
    shift 3
    "$@" >"$T/out" 2>"$T/err"
    local rc=$?
    if [ "$rc" -eq "$code" ]; then ok; else bad "$what: exit $rc, expected $code: $(head -c 300 "$T/err")"; fi
}

one_line() {
    if [ "$(wc -l <"$T/err")" -eq 1 ] && grep -qF -- "$1" "$T/err"; then ok
    else bad "expected one line mentioning '$1', got: $(cat "$T/err")"; fi
}

has() { if grep -qF -- "$1" "$T/out"; then ok; else bad "output lacks '$1'"; fi; }
exists() { if [ -e "$1" ]; then ok; else bad "missing $1"; fi; }

le64() {
    local i out=""
    for i in 0 1 2 3 4 5 6 7; do out+=$(printf '\\x%02x' $((($1 >> (8 * i)) & 255))); done
    printf "$out"
}

st_zeros() {
    local file="$1" header="{" off=0 spec name shape numel d
    shift
    for spec in "$@"; do
        name=${spec% *}
        shape=${spec#* }
        numel=1
        IFS=, read -ra dims <<< "$shape"
        for d in "${dims[@]}"; do numel=$((numel * d)); done
        [ "$header" = "{" ] || header+=","
        header+="\"$name\":{\"dtype\":\"F32\",\"shape\":[$shape],\"data_offsets\":[$off,$((off + numel * 4))]}"
        off=$((off + numel * 4))
    done
    header+="}"
    { le64 ${#header}; printf '%s' "$header"; head -c $off /dev/zero; } > "$file"
}

tiny1_config() {
    local configs
    configs="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../../configs" && pwd)"
    sed -e 's/"temperal_downsample": \[false, true, true\]/"temperal_downsample": [false, false, false]/' \
        -e 's/"temporal_factor": 4/"temporal_factor": 1/' -e 's/"name": "tiny"/"name": "tiny1"/' \
        "$configs/tiny.json" >"$1"
    check "tiny1 config made" grep -q '"temporal_factor": 1' "$1"
}

cli_finish() {
    echo "$passed passed, $failed failed"
    [ "$failed" -eq 0 ]
}
