#!/usr/bin/env bash
# Hashes of what the library and the element produce on fixed inputs: the stabilized
# frames and the per-frame estimates (motion, correction, model, points). Two builds that
# print the same lines behave the same, bit for bit: for a change that must not change
# behaviour (a refactor), build the base commit in another directory and compare.
#   bash tests/bench/output_hashes.sh BUILD_DIR [BASE_BUILD_DIR]
# With two builds it hashes both on the same inputs and fails unless every line matches.
# Inputs: synthetic flights rendered by the first build (hover, manoeuvre, rolling shutter
# with vibration) at several planners, delays and pixel formats, and the real clips in
# ../shared/data when present, decoded once to y4m (a decoder need not give the same bytes
# twice). About 1 min per build on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=$(realpath "${1:-build}")
base=${2:+$(realpath "$2")}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
hash() { md5sum | cut -c1-32; }
# i420_hash W H < raw: the hash of the picture in I420 frames with GStreamer's default row
# padding (rows to 4 bytes), leaving out the padding, which no element writes.
i420_hash() {
  python3 -c '
import hashlib, sys
w, h = int(sys.argv[1]), int(sys.argv[2])
cw, ch = (w + 1) // 2, (h + 1) // 2
pad = lambda n: (n + 3) // 4 * 4
planes = [(w, h), (cw, ch), (cw, ch)]
data, md5, at = sys.stdin.buffer.read(), hashlib.md5(), 0
while at < len(data):
    for pw, ph in planes:
        for _ in range(ph):
            md5.update(data[at:at + pw])
            at += pad(pw)
print(md5.hexdigest())' "$1" "$2"
}

render="$build/tests/synthetic/uavstab-render-flight"
"$render" "$work/hover.y4m" --width 640 --height 360 --frames 90 --seed 3 >/dev/null
"$render" "$work/manoeuvre.y4m" --width 640 --height 360 --frames 120 --seed 5 --profile manoeuvre >/dev/null
"$render" "$work/rs.y4m" --width 640 --height 360 --frames 90 --seed 7 --readout 0.8 \
  --vibration-hz 47 --vibration-px 2 --vibration-deg 0.1 >/dev/null
clips=(hover rs)
data=../shared/data
if [[ -d $data ]]; then
  for clip in "$data"/*.mp4 "$data"/*.avi; do
    [[ -f $clip ]] || continue
    name=$(basename "${clip%.*}")
    ffmpeg -v error -threads 1 -i "$clip" -pix_fmt yuv420p -f yuv4mpegpipe -y "$work/$name.y4m"
    clips+=("$name")
  done
else
  echo "(no ../shared/data: real clips not hashed)" >&2
fi

# hashes BUILD: one line per run.
hashes() {
local build=$1
export GST_PLUGIN_PATH=$build/gst

# The library alone: every planner at delays 0, 5, 20.
for clip in hover manoeuvre rs; do
  for planner in l1 optimal gaussian box; do
    for delay in 0 5 20; do
      "$build/samples/uavstab-stabilize-y4m" "$work/$clip.y4m" "$work/out.y4m" \
        --planner "$planner" --delay "$delay" >/dev/null
      echo "library $clip planner=$planner delay=$delay $(hash <"$work/out.y4m")"
    done
  done
done

# The element: frames and per-frame statistics, in several pixel formats (real clips in I420).
run="$build/samples/uavstab-run"
for clip in "${clips[@]}"; do
  # The synthetic clips (640x360) have no row padding: their raw frames are hashed as they
  # are. The real clips are hashed without the padding that odd widths have.
  formats=(I420)
  [[ $clip == hover || $clip == rs ]] && formats=(I420 NV12 BGRx GRAY8)
  for format in "${formats[@]}"; do
    "$run" --frames "filesrc location=$work/$clip.y4m ! y4mdec ! videoconvert ! video/x-raw,format=$format \
      ! uavstabilize ! filesink location=$work/out.bin" >"$work/stats.txt" 2>/dev/null
    if [[ $clip == hover || $clip == rs ]]; then
      frames=$(hash <"$work/out.bin")
    else
      read -r width height < <(head -n1 "$work/$clip.y4m" | sed -E 's/.* W([0-9]+) H([0-9]+).*/\1 \2/')
      frames=$(i420_hash "$width" "$height" <"$work/out.bin")
    fi
    echo "element $clip $format frames $frames stats $(hash <"$work/stats.txt")"
  done
done
}

hashes "$build" | tee "$work/hashes.txt"
[[ -n $base ]] || exit 0
hashes "$base" >"$work/base.txt"
if diff "$work/base.txt" "$work/hashes.txt" >&2; then
  echo "output_hashes: $(wc -l <"$work/hashes.txt") runs, identical to $base"
else
  echo "output_hashes: outputs differ from $base (above: < base, > this build)" >&2
  exit 1
fi
