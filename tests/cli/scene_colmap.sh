#!/bin/bash
# gaussvid scene colmap: COLMAP missing, an unreadable photo, photos COLMAP cannot register give
# one line and exit 1; 24 frames of the shared livingroom scene (every 2nd of the first 48,
# 256x144) become a scene folder that loads, with every photo registered and the cameras of the
# scene's own model recovered up to a similarity (tests/cli/lib/compare_cameras.py: relative
# rotations within 2 degrees, centres within 3 % of the extent; measured 1.17 degrees, 1.9 %),
# and a synthesised room with non-repeating texture (scene synth --seed 3 --frames 48
# --texture-detail 1, every 2nd frame) whose exact cameras are recovered within the issue's
# 1 degree and 1 % of the extent (medians; the worst within 3 times them; measured in four
# runs 0.10-0.12 degrees and 0.43-0.57 %, worst 0.55 degrees and 1.4 %; the same room without
# the texture detail 0.76 degrees and 2.6 %, worst 12 %; docs/SCENES.md "From photos").
# Skipped (exit 77) without COLMAP after the checks that need none.
# Usage: bash scene_colmap.sh /path/to/gaussvid   ($GV_TMP scratch; $GV_SHARED_DATA the shared data)
source "$(dirname "$0")/lib/harness.sh"
cli_setup scene_colmap "$1"
LIB="$(cd "$(dirname "$0")/lib" && pwd)"
cd "$T" || exit 1

expect 0 "help" -- "$G" scene colmap --help
has "--images"
expect 0 "listed" -- "$G" scene --help
has "colmap"
expect 2 "no images flag" -- "$G" scene colmap --out X
mkdir -p three
for i in 1 2 3; do "$G" scene synth --seed $i --frames 2 --size 32x32 --samples 1 --out s$i --quiet; cp s$i/images/frame_00000.png three/p$i.png; done
expect 1 "COLMAP not installed" -- env PATH=/nonexistent "$G" scene colmap --images three --out X
one_line "colmap is not installed"
expect 1 "a missing COLMAP program" -- "$G" scene colmap --images three --out X --colmap ./no-colmap
one_line "./no-colmap: not an executable COLMAP program"

if ! command -v colmap >/dev/null; then
    echo "scene_colmap.sh: colmap is not installed (scripts/setup.sh installs it): the COLMAP runs are skipped"
    cli_finish || exit 1
    exit 77
fi
expect 1 "no folder" -- "$G" scene colmap --images nowhere --out X
one_line "nowhere: no such folder of photos"
mkdir -p broken && cp three/*.png broken/ && echo "not a picture" >broken/p4.png
expect 1 "unreadable photo" -- "$G" scene colmap --images broken --out X --quiet
one_line "broken/p4.png: not a PNG or JPEG image"
mkdir -p sizes && cp three/*.png sizes/ && "$G" scene synth --seed 9 --frames 2 --size 48x32 --samples 1 --out s9 --quiet \
    && cp s9/images/frame_00000.png sizes/p4.png
expect 1 "two sizes" -- "$G" scene colmap --images sizes --out X --quiet
one_line "photos of one camera share a size"
check "nothing written on bad input" test ! -e X
# Three unrelated rooms: nothing to match.
expect 1 "too few registered" -- "$G" scene colmap --images three --out U --colmap-threads 2 --quiet
one_line "COLMAP registered 0 of 3 photos (at least 3 needed)"

# A synthesised room: its exact cameras recovered within 1 degree and 1 % of their extent.
expect 0 "synth with texture detail" -- "$G" scene synth --seed 3 --frames 48 --texture-detail 1 --out R3 --quiet
mkdir -p room_photos
for i in $(seq 0 2 46); do cp "R3/images/frame_$(printf %05d $i).png" room_photos/; done
expect 0 "colmap on the room" -- "$G" scene colmap --images room_photos --out R3C --colmap-threads 2
has "R3C: 24 of 24 photos registered"
check "the room's cameras within 1 degree and 1 %" python3 "$LIB/compare_cameras.py" R3/sparse/0/images.txt \
    R3C/sparse/0/images.txt 1 0.01

LIVINGROOM="${GV_SHARED_DATA:-data}/scenes/livingroom"
if [ ! -d "$LIVINGROOM" ]; then
    echo "scene_colmap.sh: no shared livingroom scene ($LIVINGROOM): the camera check is skipped"
    cli_finish
    exit $?
fi
mkdir -p photos
for i in $(seq 0 2 46); do cp "$LIVINGROOM/images/frame_$(printf %05d $i).png" photos/; done
expect 0 "colmap" -- "$G" scene colmap --images photos --out L --colmap-threads 2
has "L: 24 of 24 photos registered"
for f in images/frame_00046.png sparse/0/cameras.txt sparse/0/images.txt sparse/0/points3D.txt transforms.json points3D.ply; do
    exists "L/$f"
done
expect 0 "the scene loads" -- "$G" scene info L --interval 4
has "24"
check "PINHOLE cameras" grep -q " PINHOLE " L/sparse/0/cameras.txt
check "the cameras up to a similarity" python3 "$LIB/compare_cameras.py" "$LIVINGROOM/sparse/0/images.txt" \
    L/sparse/0/images.txt 3 0.03
cli_finish
