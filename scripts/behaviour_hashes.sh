#!/usr/bin/env bash
# Hashes what one gaussvid build does on a tiny pipeline, so two builds can be compared by
# diffing their lists (docs/LAYERS.md, "How the move was checked" and "How issue 40 was
# checked"). Runs the pipeline from an empty folder, one thread, and writes OUTDIR/hashes.txt:
#   rc   N  cmd:NAME          the command's exit code (a flag a build lacks shows here)
#   HASH    stdout:NAME       its standard output, clock values masked
#   HASH    file:PATH         every file the pipeline wrote, clock values masked
#   HASH    data:PATH         a safetensors file's tensor part alone (header entries + bytes)
#   HASH    help:CMD          'gaussvid CMD --help' of every command and subcommand it lists
# Masked (only what a clock decides): JSON values (and safetensors metadata values) whose key
# contains 'seconds'; the 'seconds' and 'clips_per_s' columns of .tsv logs; 'N s', 'N clips/s'
# and 'N/s' in printed lines, and the 's/run' column of dataset stats' table. OUTDIR/work keeps
# the files, OUTDIR/log each command's output and help text. A few minutes on one core.
#
# Usage: scripts/behaviour_hashes.sh GAUSSVID_BINARY OUTDIR
# Environment: GV_SPLAT_TRAIN_FLAGS   extra flags for 'splat train' (e.g. '--densify reference'
#              to run a build whose default is lean with the older default)
set -u
if [ $# -ne 2 ]; then
    echo "usage: $0 GAUSSVID_BINARY OUTDIR" >&2
    exit 2
fi
G=$(realpath "$1") || exit 2
[ -x "$G" ] || { echo "$1: not an executable" >&2; exit 2; }
OUT=$(realpath -m "$2")
if [ -e "$OUT/work" ]; then
    echo "$OUT/work: exists; the pipeline starts from an empty folder" >&2
    exit 2
fi
mkdir -p "$OUT/work" "$OUT/log" || exit 1
W=$OUT/work
H=$OUT/hashes.txt
: >"$H"
export OMP_WAIT_POLICY=passive OPENBLAS_CORETYPE=Haswell
read -r -a SPLAT_FLAGS <<<"${GV_SPLAT_TRAIN_FLAGS:-}"

# mask_lines: in printed text, 'N s', 'N clips/s' and 'N/s' become '# s' etc., a JSON value
# whose key contains 'seconds' becomes "#", and so does the last column of a table headed 's/run'
# (dataset stats).
mask_lines() {
    awk 'index($0, "s/run") { table = 1; print; next }
         table && NF == 0 { table = 0 }
         table { sub(/[0-9.]+[ \t]*$/, "#") }
         { print }' |
        sed -E -e 's/("[^"]*seconds[^"]*"[[:space:]]*:[[:space:]]*)-?[0-9][0-9.eE+-]*/\1"#"/g' \
            -e 's/[0-9]+(\.[0-9]+)?( ?)(s|clips\/s|\/s)\b/#\2\3/g'
}

# hash_files DIR: 'HASH file:PATH' for every file under DIR (path order), clock values masked,
# and 'HASH data:PATH' for a safetensors file's tensor part (its header without the metadata,
# then the tensor bytes). One process for all files: a process per file took minutes.
hash_files() {
    python3 - "$1" <<'PY'
import hashlib, json, os, re, struct, sys
top = sys.argv[1]
# "...seconds...": NUMBER in JSON; "...seconds...": "STRING" in safetensors metadata.
seconds_number = re.compile(rb'("(?:[^"\\]|\\.)*seconds(?:[^"\\]|\\.)*"\s*:\s*)-?[0-9][0-9.eE+-]*')
seconds_string = re.compile(rb'("[^"]*seconds[^"]*"\s*:\s*)"(?:[^"\\]|\\.)*"')

def safetensors_header_size(b):
    if len(b) < 10 or b[8:9] != b"{":
        return None
    n = struct.unpack("<Q", b[:8])[0]
    return n if n <= len(b) - 8 else None

def masked_tsv(raw):
    lines = raw.split(b"\n")
    clock = [i for i, c in enumerate(lines[0].split(b"\t")) if c in (b"seconds", b"clips_per_s")]
    out = [lines[0]]
    for line in lines[1:]:
        f = line.split(b"\t")
        for i in clock:
            if i < len(f):
                f[i] = b"#"
        out.append(b"\t".join(f))
    return b"\n".join(out)

def sha(b):
    return hashlib.sha256(b).hexdigest()

paths = []
for root, _, files in os.walk(top):
    paths += [os.path.relpath(os.path.join(root, f), top) for f in files]
for path in sorted(paths, key=lambda p: p.encode()):
    raw = open(os.path.join(top, path), "rb").read()
    n = safetensors_header_size(raw)
    if path.endswith(".json"):
        print(sha(seconds_number.sub(rb'\1"#"', raw)), "file:" + path)
    elif path.endswith(".tsv"):
        print(sha(masked_tsv(raw)), "file:" + path)
    elif n is not None:
        # Without the length and the padding spaces, which change with the masked values.
        header = raw[8:8 + n]
        print(sha(seconds_string.sub(rb'\1"#"', header).rstrip(b" ") + raw[8 + n:]), "file:" + path)
        tensors = json.loads(header)
        tensors.pop("__metadata__", None)
        print(sha(json.dumps(tensors, sort_keys=True).encode() + raw[8 + n:]), "data:" + path)
    else:
        print(sha(raw), "file:" + path)
PY
}

hash_of() { sha256sum | cut -d' ' -f1; }

# run NAME ARGS...: gaussvid ARGS in the work folder; records its exit code and stdout hash.
run() {
    local name=$1 rc
    shift
    (cd "$W" && "$G" "$@" >"$OUT/log/$name.out" 2>"$OUT/log/$name.err")
    rc=$?
    printf 'rc %d cmd:%s\n' "$rc" "$name" >>"$H"
    printf '%s stdout:%s\n' "$(mask_lines <"$OUT/log/$name.out" | hash_of)" "$name" >>"$H"
}

# LPIPS weights of AlexNet's shape (docs/LPIPS.md), BF16 from a fixed pattern: eval --lpips and
# metrics --lpips need some, and the pipeline has no network access.
write_lpips() {
    python3 - "$1" <<'PY'
import json, struct, sys
shapes = [("net.slice1.0.weight", [64, 3, 11, 11]), ("net.slice1.0.bias", [64]),
          ("net.slice2.3.weight", [192, 64, 5, 5]), ("net.slice2.3.bias", [192]),
          ("net.slice3.6.weight", [384, 192, 3, 3]), ("net.slice3.6.bias", [384]),
          ("net.slice4.8.weight", [256, 384, 3, 3]), ("net.slice4.8.bias", [256]),
          ("net.slice5.10.weight", [256, 256, 3, 3]), ("net.slice5.10.bias", [256])]
shapes += [("lin%d.model.1.weight" % i, [1, c, 1, 1])
           for i, c in enumerate([64, 192, 384, 256, 256])]
pattern = [0.0498, -0.0299, 0.02, 0.04, -0.0498, 0.01, -0.02, 0.0299, -0.01, 0.0449, -0.04, 0.015,
           0.025]
def bf16(x):
    return struct.pack("<f", x)[2:]
header, blobs, off = {}, [], 0
for name, shape in shapes:
    count = 1
    for d in shape:
        count *= d
    vals = [1.0] * count if name.startswith("lin") else [pattern[i % 13] for i in range(count)]
    blob = b"".join(bf16(v) for v in vals)
    header[name] = {"dtype": "BF16", "shape": shape, "data_offsets": [off, off + len(blob)]}
    blobs.append(blob)
    off += len(blob)
h = json.dumps(header, separators=(",", ":")).encode()
h += b" " * (-len(h) % 8)
open(sys.argv[1], "wb").write(struct.pack("<Q", len(h)) + h + b"".join(blobs))
PY
}

# The pipeline of docs/LAYERS.md (issue 22), every command with --threads 1.
T=(--threads 1)
run synth_A scene synth --seed 3 --frames 14 --size 32x32 --samples 1 --out A --quiet "${T[@]}"
run synth_B scene synth --seed 4 --frames 14 --size 32x32 --samples 1 --out B --quiet "${T[@]}"
run scene_info scene info A --interval 6 --json "${T[@]}"
run dataset_build dataset build --scenes A B --eval-scenes B --intervals 6,8 --iters 20 --clips-per-run 2 \
    --seed 5 --out D --quiet "${T[@]}"
run dataset_stats_runs_json dataset stats D --runs --json "${T[@]}"
run dataset_stats dataset stats D "${T[@]}"
run dataset_show dataset show D/clips/A_n06_000.safetensors --out sheet.png "${T[@]}"

run splat_train splat train --scene A --interval 6 --iters 30 --out a6.ply --quiet "${SPLAT_FLAGS[@]}" \
    "${T[@]}"
# Beyond issue 22's list: 700 iterations reach the densification steps (from iteration 500),
# which 30 do not, so a change of density control shows.
run splat_train_densify splat train --scene A --interval 6 --iters 700 --out a6_700.ply --quiet \
    "${SPLAT_FLAGS[@]}" "${T[@]}"
run splat_eval splat eval --model a6.ply --scene A --interval 6 --json a6_eval.json "${T[@]}"
run splat_render splat render --model a6.ply --scene A --interval 6 --out render --depth --opacity \
    --quiet "${T[@]}"
run splat_export splat export a6.ply --out a6.splat "${T[@]}"

run vae_train vae train --config tiny --scenes A --steps 2 --crop 32x32 --stats-clips 2 --out vae.safetensors \
    --quiet "${T[@]}"
PRE=(--clips D --config tiny --vae vae.safetensors --steps 4 --batch 2 --checkpoint-every 1 --seed 1
     --quiet "${T[@]}")
run pretrain pretrain "${PRE[@]}" --out base.safetensors --log pre.tsv
run pretrain_stop pretrain "${PRE[@]}" --out base2.safetensors --log pre2.tsv --stop-after 2
run pretrain_resume pretrain "${PRE[@]}" --out base2.safetensors --log pre2.tsv --resume
FT=(--clips D --base base.safetensors --steps 4 --batch 2 --latent-warmup 1 --checkpoint-every 2
    --quiet "${T[@]}")
run train train "${FT[@]}" --out ft.safetensors --log ft.tsv
run train_stop train "${FT[@]}" --out ft2.safetensors --log ft2.tsv --stop-after 1
run train_resume train "${FT[@]}" --out ft2.safetensors --log ft2.tsv --resume
run train_val train "${FT[@]}" --out val.safetensors --log val_train.tsv --val-clips D \
    --val-log val.tsv

run restore restore --ckpt ft.safetensors --clips D --split eval --out R --save-clips --quiet \
    "${T[@]}"
run restore_clip restore --ckpt ft.safetensors --clip D/clips/B_n06_000.safetensors --out R1 --quiet \
    "${T[@]}"
EV=(--ckpt ft.safetensors --clips D --quiet "${T[@]}")
run eval eval "${EV[@]}" --json eval.json
run eval_identity eval "${EV[@]}" --identity --json eval_identity.json
run eval_released eval "${EV[@]}" --sampler released --compose decoded --json eval_released.json
(cd "$W" && write_lpips alex.safetensors)
run eval_lpips eval "${EV[@]}" --lpips alex.safetensors --json eval_lpips.json

run vae_eval vae eval --weights vae.safetensors --scenes B --json --quiet "${T[@]}"
run vae_residual vae residual --weights vae.safetensors D --json --quiet "${T[@]}"
run metrics metrics A/images/frame_00003.png B/images/frame_00003.png --json "${T[@]}"
run metrics_lpips metrics A/images/frame_00003.png B/images/frame_00003.png --lpips alex.safetensors \
    "${T[@]}"

# Every file in the work folder, by path.
hash_files "$W" >>"$H"

# subcommands_of TEXT: the names listed under 'commands:' or 'subcommands:' in a help text.
subcommands_of() {
    awk '/^(sub)?commands:/ { on = 1; next } on && /^  [a-z]/ { print $1; next } on && !/^  / { on = 0 }'
}
# The help text of every command and subcommand the build lists.
for c in $("$G" help 2>/dev/null | subcommands_of); do
    case $c in help | version) continue ;; esac
    text=$("$G" "$c" --help 2>&1)
    printf '%s help:%s\n' "$(printf '%s\n' "$text" | hash_of)" "$c" >>"$H"
    printf '%s\n' "$text" >"$OUT/log/help_$c.txt"
    # A subcommand of a command that does work itself is named in its text ('gaussvid
    # metrics consistency DIR'), not listed.
    subs=$( (printf '%s\n' "$text" | subcommands_of
             printf '%s\n' "$text" | grep -oE "'gaussvid $c [a-z]+" | cut -d' ' -f3) |
        LC_ALL=C sort -u)
    for s in $subs; do
        printf '%s help:%s %s\n' "$("$G" "$c" "$s" --help 2>&1 | hash_of)" "$c" "$s" >>"$H"
        "$G" "$c" "$s" --help >"$OUT/log/help_${c}_$s.txt" 2>&1
    done
done
echo "$H: $(wc -l <"$H") lines"
