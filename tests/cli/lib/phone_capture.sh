# Shared by the phone-capture tests (scene_colmap_phone.sh, scene_colmap_phone_full.sh), sourced
# after harness.sh's cli_setup:
#   phone_setup SCRIPT   LIB = this folder; cd to the scratch folder; exit 77 (skipped) without
#                        COLMAP or ffmpeg
#   known_cameras IMAGES_TXT FORMAT
#                        prints a synthesised room's COLMAP images.txt with each frame_K.png
#                        renamed by FORMAT of K + 1 (IMG_%04d.JPG as a phone names its photos,
#                        frame_%05d.jpg as scene colmap --video names its frames)

phone_setup() {
    LIB="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
    cd "$T" || exit 1
    if ! command -v colmap >/dev/null || ! command -v ffmpeg >/dev/null; then
        echo "$1: colmap or ffmpeg is not installed (scripts/setup.sh installs them): skipped"
        exit 77
    fi
}

known_cameras() {
    awk -v format="$2" '{
        if (match($0, /frame_[0-9]+\.png$/)) {
            k = substr($0, RSTART + 6, 5) + 1
            sub(/frame_[0-9]+\.png$/, sprintf(format, k))
        }
        print
    }' "$1"
}
