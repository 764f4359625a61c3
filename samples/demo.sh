#!/usr/bin/env bash
# The main job: stabilize a shaky clip with the uavstabilize GStreamer element and write
# the result plus a side-by-side comparison.
#   bash samples/demo.sh [INPUT_VIDEO] [OUTPUT_DIR]
# Without INPUT_VIDEO it renders the project's synthetic shaky flight over the committed
# aerial photograph (tests/data/aero1.jpg). Its true motion is known, so the demo prints
# the true share of the shake removed; for other clips, the stabilizer's own estimate.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
input=${1:-}
out=$(mkdir -p "${2:-$repo/out}" && cd "${2:-$repo/out}" && pwd)
cd "$repo"

bash .ci/install-deps.sh build demo
[[ -f build/build.ninja ]] || meson setup build >/dev/null
ninja -C build -j "$(nproc)" >/dev/null
export GST_PLUGIN_PATH="$repo/build/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"

truth=()
if [[ -z $input ]]; then
  echo "rendering the synthetic shaky flight (1280x720, 300 frames at 30 fps, 3 moving objects)..."
  build/tests/synthetic/uavstab-render-flight "$out/shaky.y4m" --width 1280 --height 720 --frames 300 \
    --objects 3 --truth "$out/shaky_truth.csv"
  truth=(--truth "$out/shaky_truth.csv")
  source="filesrc location=$out/shaky.y4m ! y4mdec"
  width=1280
else
  input=$(realpath "$input")
  width=$(gst-discoverer-1.0 "$input" | sed -n 's/^ *Width: \([0-9]*\).*/\1/p' | head -n1)
  [[ -n $width ]] || { echo "demo: cannot read the video size of $input" >&2; exit 1; }
  source="filesrc location=\"$input\" ! decodebin ! videoconvert ! video/x-raw,format=I420"
fi

encode="videoconvert ! x264enc speed-preset=veryfast ! mp4mux"
label() { echo "textoverlay text=\"$1\" valignment=top halignment=left font-desc=\"Sans Bold 28\" shaded-background=true"; }
echo "stabilizing with: $source ! uavstabilize ! ..."
build/samples/uavstab-run "${truth[@]}" "$source ! tee name=in \
  in. ! queue max-size-buffers=0 max-size-bytes=0 max-size-time=0 ! $(label input) ! side.sink_0 \
  in. ! queue ! uavstabilize ! tee name=stab \
  stab. ! queue ! $encode ! filesink location=$out/stabilized.mp4 \
  stab. ! queue ! $(label stabilized) ! side.sink_1 \
  compositor name=side sink_1::xpos=$width ! $encode ! filesink location=$out/side_by_side.mp4"
rm -f "$out/shaky.y4m"
echo "wrote $out/stabilized.mp4 and $out/side_by_side.mp4 (left: input, right: stabilized, each labelled)"
