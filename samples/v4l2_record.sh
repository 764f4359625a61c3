#!/usr/bin/env bash
# Stabilized recording from a V4L2 camera (USB, HDMI grabber, a UAV video receiver).
#   bash samples/v4l2_record.sh /dev/video0 out.mp4 [DELAY]
# uavstabilize answers the allocation query asking for delay + 4 buffers, so cameras
# with a fixed buffer pool do not starve while it holds DELAY frames.
set -euo pipefail
device=${1:?usage: v4l2_record.sh DEVICE OUT.mp4 [DELAY]}
out=${2:?usage: v4l2_record.sh DEVICE OUT.mp4 [DELAY]}
delay=${3:-10}
exec gst-launch-1.0 -e \
  v4l2src device="$device" ! videoconvert \
  ! uavstabilize delay="$delay" \
  ! tee name=t \
  t. ! queue ! videoconvert ! autovideosink sync=false \
  t. ! queue ! videoconvert ! x264enc speed-preset=veryfast tune=zerolatency ! h264parse ! mp4mux \
     ! filesink location="$out"
