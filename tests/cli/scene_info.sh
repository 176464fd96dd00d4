#!/bin/bash
# gaussvid scene info: exit codes (0 ok, 1 bad scene, 2 usage), the text and --json output,
# and one-line failures for missing folders, missing or wrong images and impossible splits.
# Usage: bash scene_info.sh /path/to/gaussvid   ($GV_TMP scratch, $GV_SHARED_DATA optional)
source "$(dirname "$0")/lib/harness.sh"
cli_setup scene-info "$1"

# A tiny scene: three 4x3 PNG frames and a nerfstudio transforms.json, no points.
PNG4x3=iVBORw0KGgoAAAANSUhEUgAAAAQAAAADCAIAAAA7ljmRAAAAMklEQVQImQEnANj/AAAlSm+Uud4DKE1ylwC84QYrUHWav+QJLlMAeJ3C5wwxVnugxeoPJKYQD0amMxQAAAAASUVORK5CYII=
PNG5x3=iVBORw0KGgoAAAANSUhEUgAAAAUAAAADCAIAAADUVFKvAAAAHklEQVQImWNgUPXKn7LzHrOGb9H0PQ/ZmLRRATofAELPCzxEmEl7AAAAAElFTkSuQmCC
make_scene() {
    mkdir -p "$1/images"
    for i in 0 1 2; do echo "$PNG4x3" | base64 -d >"$1/images/f$i.png"; done
    cat >"$1/transforms.json" <<'EOF'
{"camera_model": "OPENCV", "fl_x": 4, "fl_y": 4, "cx": 2, "cy": 1.5, "w": 4, "h": 3,
 "frames": [
  {"file_path": "images/f2.png", "transform_matrix": [[1,0,0,2],[0,1,0,0],[0,0,1,0],[0,0,0,1]]},
  {"file_path": "images/f0.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]},
  {"file_path": "images/f1.png", "transform_matrix": [[1,0,0,1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}
EOF
}
S="$T/tiny"
make_scene "$S"

# Usage errors: exit 2.
expect 0 "help" -- "$G" scene info --help
has "usage: gaussvid scene info"
expect 2 "no folder" -- "$G" scene info
expect 2 "unknown flag" -- "$G" scene info "$S" --nope
expect 2 "interval 0" -- "$G" scene info "$S" --interval 0
expect 2 "interval not a number" -- "$G" scene info "$S" --interval x
expect 2 "downscale 0" -- "$G" scene info "$S" --downscale 0

# A good scene: exit 0 and its description. Centres x = 0, 1, 2: extent 1.1 x 1.
expect 0 "tiny scene" -- "$G" scene info "$S" --interval 2 --quiet
has "source      transforms.json"
has "frames      3"
has "image size  4x3"
has "intrinsics  shared by all frames: fx 4 fy 4 cx 2 cy 1.5"
has "points      0"
has "extent      1.1 (all frames)"
has "split       interval 2: 2 training frames, 1 held out"
has "training    0 2"
if [ ! -s "$T/err" ]; then ok; else bad "--quiet still wrote to stderr: $(cat "$T/err")"; fi

expect 0 "tiny scene --json" -- "$G" scene info "$S" --interval 2 --json --downscale 2
for key in '"dir":' '"source":	"transforms"' '"image_dir":' '"downscale":	2' '"frames":	3' \
    '"image_size":' '"width":	2' '"height":	2' '"intrinsics":' '"shared":	true' '"fx":	2' \
    '"cy":	1' '"points":	0' '"extent":	1.1' '"split":' '"interval":	2' '"train":	[0, 2]' \
    '"held_out":	1' '"train_extent":	1.1'; do
    has "$key"
done
if command -v jq >/dev/null; then
    if jq -e '.frames == 3 and .split.held_out == 1' "$T/out" >/dev/null; then ok; else bad "jq rejects the JSON"; fi
fi

# Bad scenes: exit 1 and one line naming the problem.
expect 1 "missing folder" -- "$G" scene info "$T/nowhere"
one_line "nowhere: no such scene folder"
expect 1 "too few frames for the interval" -- "$G" scene info "$S" --interval 3
one_line "interval 3 leaves 1 training frame of the scene's 3 frames"
mkdir -p "$T/empty"
expect 1 "no description" -- "$G" scene info "$T/empty"
one_line "no scene description"

B="$T/missing_image"
make_scene "$B"
rm "$B/images/f1.png"
expect 1 "missing image" -- "$G" scene info "$B"
one_line "images/f1.png: image of frame 1 is missing"

B="$T/wrong_size"
make_scene "$B"
echo "$PNG5x3" | base64 -d >"$B/images/f2.png"
expect 1 "wrong image size" -- "$G" scene info "$B"
one_line "images/f2.png: is 5x3 but the camera is 4x3"

B="$T/corrupt"
make_scene "$B"
head -c 40 "$S/images/f0.png" >"$B/images/f0.png"
expect 1 "corrupt image" -- "$G" scene info "$B"
one_line "images/f0.png"

B="$T/nan"
make_scene "$B"
sed -i 's/"cy": 1.5/"cy": NaN/' "$B/transforms.json"
expect 1 "NaN in transforms.json" -- "$G" scene info "$B"
one_line "transforms.json: line 1, key cy: NaN/Infinity is not a number"

B="$T/bad_matrix"
make_scene "$B"
sed -i 's/\[\[1,0,0,1\],/[[1,0,0],/' "$B/transforms.json"
expect 1 "bad matrix" -- "$G" scene info "$B"
one_line "transforms.json: frames[2].transform_matrix row 0 does not have 4 entries"

B="$T/colmap"
mkdir -p "$B/sparse/0" && cp -r "$S/images" "$B/"
printf '1 OPENCV 4 3 4 4 2 1.5 0.1 0 0 0\n' >"$B/sparse/0/cameras.txt"
printf '1 1 0 0 0 0 0 0 1 f0.png\n\n' >"$B/sparse/0/images.txt"
: >"$B/sparse/0/points3D.txt"
expect 1 "distorted COLMAP camera" -- "$G" scene info "$B"
one_line "sparse/0/cameras.txt: camera 1: model OPENCV has non-zero distortion"
printf '1 PINHOLE 4 3 4 4 2 1.5\n' >"$B/sparse/0/cameras.txt"
printf '1 1 0 0 0 0 0 0 1 f0.png\n\n2 1 0 0 0 1 0 0 1 f1.png\n' >"$B/sparse/0/images.txt"
expect 0 "COLMAP text scene" -- "$G" scene info "$B" --interval 1
has "source      COLMAP text (sparse/0/*.txt)"
has "split       interval 1: 2 training frames, 0 held out"

# The shared scenes, when present.
for name in courtyard livingroom; do
    D="${GV_SHARED_DATA:-data}/scenes/$name"
    if [ ! -d "$D" ]; then echo "shared scene $D not found: skipped"; continue; fi
    expect 0 "shared $name" -- "$G" scene info "$D" --interval 8 --json --quiet
    has '"frames":	160'
    has '"points":	12000'
    has '"held_out":	140'
done

cli_finish
