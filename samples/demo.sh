#!/usr/bin/env bash
# The main job: stabilize a shaky clip and write the result plus a side-by-side comparison.
#   bash samples/demo.sh [INPUT_VIDEO] [OUTPUT_DIR]
# Without INPUT_VIDEO it renders the project's synthetic shaky flight over the committed
# aerial photograph (tests/data/aero1.jpg), whose true motion is known, and also prints
# how much of the shake was removed.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
input=${1:-}
out=$(mkdir -p "${2:-$repo/out}" && cd "${2:-$repo/out}" && pwd)
cd "$repo"

bash .ci/install-deps.sh build demo
[[ -f build/build.ninja ]] || meson setup build >/dev/null
ninja -C build -j "$(nproc)" >/dev/null

truth=()
if [[ -z $input ]]; then
  echo "rendering the synthetic shaky flight (1280x720, 300 frames at 30 fps)..."
  build/tests/synthetic/uavstab-render-flight "$out/shaky.y4m" --width 1280 --height 720 --frames 300 \
    --objects 3 --truth "$out/shaky_truth.csv"
  truth=(--truth "$out/shaky_truth.csv")
else
  echo "decoding $input..."
  gst-launch-1.0 -q filesrc location="$input" ! decodebin ! videoconvert ! video/x-raw,format=I420 \
    ! y4menc ! filesink location="$out/shaky.y4m"
fi

build/samples/uavstab-stabilize-y4m "$out/shaky.y4m" "$out/stabilized.y4m" \
  --side-by-side "$out/side_by_side.y4m" "${truth[@]}"

encode() {
  gst-launch-1.0 -q filesrc location="$1" ! y4mdec ! videoconvert ! x264enc speed-preset=veryfast \
    ! mp4mux ! filesink location="$2"
}
encode "$out/shaky.y4m" "$out/shaky.mp4"
encode "$out/stabilized.y4m" "$out/stabilized.mp4"
encode "$out/side_by_side.y4m" "$out/side_by_side.mp4"
rm -f "$out"/*.y4m
echo "wrote $out/stabilized.mp4 and $out/side_by_side.mp4 (left: input, right: stabilized)"
