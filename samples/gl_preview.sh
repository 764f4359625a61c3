#!/usr/bin/env bash
# Stabilized preview drawn by the GPU: uavstabilize does not warp the frames (render=auto
# picks affine-meta in front of glimagesink); each frame goes to the screen untouched with
# a GstVideoAffineTransformationMeta that glimagesink applies as it draws.
#   bash samples/gl_preview.sh [VIDEO] [DELAY]
# Use it on a drone's own computer (Jetson, Raspberry Pi, i.MX) or wherever the CPU is the
# scarce part and the picture ends on a GL display: the CPU then only estimates the motion.
# For a file or a stream to encode, the frames must be warped (file_to_file.sh).
# Without VIDEO it shows the project's synthetic shaky flight (needs the build: meson setup
# build && ninja -C build).
# videoconvert in front of uavstabilize matters: it writes each frame into glupload's GL
# buffers (uavstabilize passes glupload's allocation upstream), which glupload hands on
# with their metas; frames in plain memory it copies, and the copy loses the meta.
set -euo pipefail
cd "$(dirname "$0")/.."
export GST_PLUGIN_PATH=${GST_PLUGIN_PATH:-$PWD/build/gst}
delay=${2:-10}
if [[ $# -ge 1 && -n $1 ]]; then
  source=(filesrc location="$1" ! decodebin)
else
  flight=$(mktemp --suffix=.y4m)
  trap 'rm -f "$flight"' EXIT
  build/tests/synthetic/uavstab-render-flight "$flight" --width 1280 --height 720 --frames 300 >/dev/null
  source=(filesrc location="$flight" ! y4mdec)
fi
gst-launch-1.0 "${source[@]}" ! videoconvert ! video/x-raw,format=RGBA \
  ! uavstabilize delay="$delay" render=auto ! glupload ! glimagesink
