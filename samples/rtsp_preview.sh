#!/usr/bin/env bash
# Live preview of an RTSP camera, stabilized.
#   bash samples/rtsp_preview.sh rtsp://HOST:PORT/PATH [DELAY]
# The preview runs DELAY frames (default 5) behind the camera; the sink is told so by the
# latency query. For a raw view without stabilization but the same timing, add bypass=true.
set -euo pipefail
url=${1:?usage: rtsp_preview.sh RTSP_URL [DELAY]}
delay=${2:-5}
exec gst-launch-1.0 \
  rtspsrc location="$url" latency=100 ! decodebin ! videoconvert \
  ! uavstabilize delay="$delay" ! videoconvert ! autovideosink
