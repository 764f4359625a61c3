#!/usr/bin/env bash
# Record a stabilized copy of a live RTSP camera (e.g. a UAV ground station's feed).
#   bash samples/rtsp_record.sh rtsp://HOST:PORT/PATH out.mp4 [DELAY]
# Stop with Ctrl-C: -e turns it into an end-of-stream, so uavstabilize drains the frames
# it holds and mp4mux writes a playable file.
# DELAY (default 10 frames, 1/3 s at 30 fps) is the path planner's look-ahead:
# shorter is more responsive, longer is smoother. It is reported as latency, so live
# sinks and the RTP jitterbuffer account for it.
set -euo pipefail
url=${1:?usage: rtsp_record.sh RTSP_URL OUT.mp4 [DELAY]}
out=${2:?usage: rtsp_record.sh RTSP_URL OUT.mp4 [DELAY]}
delay=${3:-10}
exec gst-launch-1.0 -e \
  rtspsrc location="$url" latency=200 ! decodebin ! videoconvert \
  ! uavstabilize delay="$delay" \
  ! videoconvert ! x264enc speed-preset=veryfast tune=zerolatency ! h264parse \
  ! mp4mux ! filesink location="$out"
