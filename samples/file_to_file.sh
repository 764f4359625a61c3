#!/usr/bin/env bash
# Stabilize a video file into a new H.264 mp4.
#   bash samples/file_to_file.sh IN_VIDEO OUT.mp4 [extra uavstabilize properties...]
# e.g.  bash samples/file_to_file.sh flight.mp4 steady.mp4 planner=gaussian smoothing-radius=20
set -euo pipefail
in=${1:?usage: file_to_file.sh IN_VIDEO OUT.mp4 [properties]}
out=${2:?usage: file_to_file.sh IN_VIDEO OUT.mp4 [properties]}
shift 2
exec gst-launch-1.0 -e \
  filesrc location="$in" ! decodebin ! videoconvert \
  ! uavstabilize "$@" \
  ! videoconvert ! x264enc speed-preset=medium ! h264parse ! mp4mux ! filesink location="$out"
