#!/bin/bash
# What --out can name besides a regular file (issue 25): a device is written into and stays a
# device (the report: `splat export m.ply --out /dev/null` as root made /dev/null a regular
# file), a FIFO is written into, a symbolic link is written through to its target and stays a
# link, a directory is refused with one line. Usage: bash outputs.sh /path/to/gaussvid
source "$(dirname "$0")/lib/harness.sh"
cli_setup outputs "$1"

# One Gaussian of SH degree 0 at the origin: 14 float32 LE, all zero but rot_0 = 1.
{
    printf 'ply\nformat binary_little_endian 1.0\nelement vertex 1\n'
    for p in x y z f_dc_0 f_dc_1 f_dc_2 opacity scale_0 scale_1 scale_2 rot_0 rot_1 rot_2 rot_3; do
        printf 'property float %s\n' "$p"
    done
    printf 'end_header\n'
    head -c 40 /dev/zero
    printf '\x00\x00\x80\x3f'
    head -c 12 /dev/zero
} > "$T/m.ply"
export_to() { expect "$1" "export --out $2" -- "$G" splat export "$T/m.ply" --out "$2"; }

# A device node made by mknod (root only), then /dev/null itself, only if the node survived.
node_ok=1
if [ "$(id -u)" -eq 0 ] && mknod "$T/null" c 1 3 2>/dev/null; then
    export_to 0 "$T/null"
    check "the mknod node is still a character device" test -c "$T/null"
    test -c "$T/null" || node_ok=0
fi
if [ "$node_ok" -eq 1 ]; then
    export_to 0 /dev/null
    check "/dev/null is still a character device" test -c /dev/null
    check "no temporary left in /dev" test -z "$(ls /dev | grep '\.tmp\.')"
fi

# A FIFO with a reader: the 32-byte record arrives through it, the FIFO stays.
mkfifo "$T/fifo"
cat "$T/fifo" > "$T/from-fifo" &
reader=$!
export_to 0 "$T/fifo"
wait "$reader"
check "the record came through the FIFO" test "$(stat -c %s "$T/from-fifo")" = 32
check "the FIFO is still a FIFO" test -p "$T/fifo"

# A symbolic link into another folder: the target is replaced, the link stays.
mkdir -p "$T/a" "$T/b"
echo old > "$T/b/model.splat"
ln -s ../b/model.splat "$T/a/link.splat"
export_to 0 "$T/a/link.splat"
check "the link is still a link" test -L "$T/a/link.splat"
check "its target holds the record" test "$(stat -c %s "$T/b/model.splat")" = 32
check "no temporary left" test -z "$(ls "$T/a" "$T/b" | grep '\.tmp\.')"

# A directory: one line, exit 1, the directory untouched.
mkdir "$T/dir"
export_to 1 "$T/dir"
one_line "is a directory"
check "the directory is still an empty directory" test -d "$T/dir" -a -z "$(ls -A "$T/dir")"

# An output folder given as a link (scene synth writes a folder, then renames it into place):
# the folder it names is replaced, the link stays, nothing is left beside either.
TINY=(--size 48x32 --frames 2 --samples 1 --quiet)
mkdir -p "$T/scenes"
expect 0 "synth a scene" -- "$G" scene synth --seed 5 --out "$T/scenes/room" "${TINY[@]}"
ln -s scenes/room "$T/room-link"
expect 0 "synth through a link" -- "$G" scene synth --seed 6 --out "$T/room-link/" "${TINY[@]}"
check "the folder link is still a link" test -L "$T/room-link"
check "the scene went into its target" grep -q "seed 6" "$T/scenes/room/synth.txt"
check "nothing left beside the link or the target" test "$(ls "$T/scenes" | tr '\n' ' ')" = "room "
check "nothing left beside the link" test -z "$(ls "$T" | grep -e partial -e '[.]old')"

cli_finish
