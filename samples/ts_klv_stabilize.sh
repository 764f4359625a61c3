#!/usr/bin/env bash
# Stabilize the video of a drone's MPEG-TS and keep its KLV telemetry (MISB ST 0601 and the
# like, meta/x-klv) in sync: the KLV stream is remuxed unchanged, with its own timestamps,
# next to the stabilized H.264 video in a new TS.
#   bash samples/ts_klv_stabilize.sh IN.ts OUT.ts [uavstabilize properties...]
# e.g.  bash samples/ts_klv_stabilize.sh flight.ts steady.ts delay=30 crop=0.1
# ENCODER overrides the video encoder, what goes between videoconvert and h264parse
# (default "video/x-raw,format=I420 ! x264enc speed-preset=medium": 4:2:0, which every
# player decodes, even when the input was 4:4:4), e.g.
#   ENCODER="x264enc bitrate=8000 key-int-max=30" bash samples/ts_klv_stabilize.sh ...
#
# Why the KLV packets stay with their frames: uavstabilize holds `delay` frames but gives
# every frame its original PTS, and the KLV packets keep theirs, so the muxer interleaves
# them by timestamp as in the input. The video leaves the decoder/stabilizer/encoder chain
# late (the element's delay plus the encoder's look-ahead) while the KLV is ready at once,
# so the KLV branch has an unbounded queue: the demuxer must never block on it while the
# muxer waits for video. The video has one too, before the muxer: with sparse KLV the muxer
# waits for the next KLV packet and encoded video piles up there instead of stalling the
# demuxer before it reaches that packet. Both hold only what the delay puts between them.
#
# A TS without KLV is stabilized all the same (a KLV branch that never gets data would
# keep the muxer waiting forever, so the streams are looked at first with
# gst-discoverer-1.0). Any video codec decodebin knows is accepted; the output is H.264.
# Only the first video and the first KLV stream are kept; audio and other streams are dropped.
set -euo pipefail
usage() {
  echo "usage: ts_klv_stabilize.sh IN.ts OUT.ts [uavstabilize properties, e.g. delay=30]" >&2
  exit 2
}
[[ $# -ge 2 ]] || usage
in=$1
out=$2
shift 2
for prop in "$@"; do
  [[ $prop == *=* ]] || { echo "ts_klv_stabilize: '$prop' is not a property (name=value)" >&2; usage; }
done
[[ -f $in && -r $in ]] || { echo "ts_klv_stabilize: cannot read $in" >&2; exit 1; }
for tool in gst-launch-1.0 gst-inspect-1.0 gst-discoverer-1.0; do
  command -v "$tool" >/dev/null || {
    echo "ts_klv_stabilize: $tool is missing (Debian: gstreamer1.0-tools, gstreamer1.0-plugins-base-apps)" >&2
    exit 1
  }
done

gst-inspect-1.0 uavstabilize >/dev/null 2>&1 || {
  echo "ts_klv_stabilize: GStreamer cannot find uavstabilize (a build tree: export GST_PLUGIN_PATH=\$PWD/build/gst)" >&2
  exit 1
}

# The streams of the input, e.g. "    video #1: video/x-h264, stream-format=..." and
# "    unknown #2: meta/x-klv, parsed=(boolean)true".
streams=$(gst-discoverer-1.0 -v "$in" 2>&1) || true
grep -q 'container #[0-9]*: video/mpegts' <<<"$streams" || {
  echo "ts_klv_stabilize: $in is not an MPEG transport stream (or cannot be read):" >&2
  grep -iE 'error|warning' <<<"$streams" >&2 || true
  exit 1
}
video_type=$(sed -n 's/^ *video #[0-9]*: \([^,]*\).*/\1/p' <<<"$streams" | head -n1)
[[ -n $video_type ]] || { echo "ts_klv_stabilize: no video stream in $in" >&2; exit 1; }
klv_streams=$(grep -c '#[0-9]*: meta/x-klv' <<<"$streams" || true)

encoder=${ENCODER:-video/x-raw,format=I420 ! x264enc speed-preset=medium}
unbounded="queue max-size-buffers=0 max-size-bytes=0 max-size-time=0"
video=(d. ! "$video_type" ! queue ! decodebin ! videoconvert ! uavstabilize "$@"
       ! videoconvert ! $encoder ! h264parse ! $unbounded ! m.)
klv=()
if [[ $klv_streams -eq 0 ]]; then
  echo "ts_klv_stabilize: no KLV stream (meta/x-klv) in $in: stabilizing the video alone" >&2
else
  [[ $klv_streams -eq 1 ]] || echo "ts_klv_stabilize: $klv_streams KLV streams in $in: keeping the first" >&2
  klv=(d. ! meta/x-klv ! $unbounded ! m.)
fi
echo "ts_klv_stabilize: $video_type video$([[ ${#klv[@]} -gt 0 ]] && echo ' + KLV') -> $out" >&2
exec gst-launch-1.0 -e filesrc location="$in" ! tsdemux name=d \
  mpegtsmux name=m ! filesink location="$out" \
  "${video[@]}" "${klv[@]}"
