#!/usr/bin/env bash
# How many live streams fit on this machine: N pipelines, each a camera emulated by raw frames
# of the synthetic shaky flight read from tmpfs and released at 30 frames/s by the clock,
#   filesrc ! rawvideoparse ! identity sync=true ! uavstabilize ! fakesink sync=true
# for S seconds, all N in one process (one gst-launch-1.0) and in N processes. A stream
# that is not kept up with releases its frames late, so the run ends late: N streams keep
# real time when the run ends within half a second of one stream's run (S + the element's
# 20-frame delay + start-up). (videotestsrc would cost more than the stabilizer at 1080p.)
#
#   bash tests/bench/streams.sh [--seconds S] [--out DIR]     (run.sh calls it; ~5 min)
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
seconds=10
out=
while [[ $# -gt 0 ]]; do
  case "$1" in
    --seconds) seconds=$2; shift ;;
    --out) out=$2; shift ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) echo "streams.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
builddir=${UAVSTAB_BENCH_BUILD_DIR:-$repo/build-bench}
export GST_PLUGIN_PATH=$builddir/gst${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}
gst-inspect-1.0 uavstabilize >/dev/null 2>&1 || { echo "streams.sh: uavstabilize not found in $builddir/gst" >&2; exit 1; }
frames=$((seconds * 30))
delay_s=0.667
render=$builddir/tests/synthetic/uavstab-render-flight
command -v ffmpeg >/dev/null || { echo "streams.sh: skipped: needs ffmpeg (to strip the y4m headers)"; exit 0; }
clip_dir=$(mktemp -d /dev/shm/uavstab-streams.XXXXXX)
trap 'rm -rf "$clip_dir"' EXIT
clip() {  # raw I420 frames of the flight at WxH, made once
  local f=$clip_dir/$1x$2.yuv
  if [[ ! -f $f ]]; then
    "$render" "$clip_dir/flight.y4m" --width "$1" --height "$2" --frames "$frames" >/dev/null
    ffmpeg -loglevel error -i "$clip_dir/flight.y4m" -f rawvideo "$f"
    rm -f "$clip_dir/flight.y4m"
  fi
  echo "$f"
}

branch() {  # one stream's pipeline description
  echo "filesrc location=$(clip "$1" "$2") ! rawvideoparse width=$1 height=$2 format=i420 framerate=30/1 ! identity sync=true ! uavstabilize ! fakesink sync=true"
}
now() { date +%s.%N; }

# Wall time of N streams in one process.
one_process() {  # W H N
  local desc="" i t0
  for ((i = 0; i < $3; i++)); do desc+=" $(branch "$1" "$2")"; done
  t0=$(now)
  # shellcheck disable=SC2086
  gst-launch-1.0 -q $desc >/dev/null
  awk -v a="$(now)" -v b="$t0" 'BEGIN { printf "%.2f", a - b }'
}
# Wall time of N processes of one stream each (until the last one ends).
n_processes() {  # W H N
  local i t0 pids=()
  t0=$(now)
  for ((i = 0; i < $3; i++)); do
    # shellcheck disable=SC2046
    gst-launch-1.0 -q $(branch "$1" "$2") >/dev/null &
    pids+=($!)
  done
  wait "${pids[@]}"
  awk -v a="$(now)" -v b="$t0" 'BEGIN { printf "%.2f", a - b }'
}

table="| resolution | streams | one process: wall s | keeps real time | N processes: wall s | keeps real time | CPU busy % (N processes) |
|---|---:|---:|---:|---:|---:|---:|"
fits_one=0
fits_many=0
cpu_busy() { local a=($(head -1 /proc/stat)); echo "${a[1]} ${a[2]} ${a[3]} ${a[4]} ${a[5]} ${a[6]} ${a[7]}"; }
for res in 1920x1080 1280x720; do
  w=${res%x*}; h=${res#*x}
  base=$(one_process "$w" "$h" 1)
  limit=$(awk -v b="$base" 'BEGIN { printf "%.2f", b + 0.5 }')
  still_one=1 still_many=1
  echo "streams $res: 1 stream takes $base s for ${seconds} s of video (real time if <= $limit s)"
  counts="1 2 4 6 8 10 12 14"
  [[ $res == 1280x720 ]] && counts="4"
  for n in $counts; do
    t1=$(one_process "$w" "$h" "$n")
    read -r -a a <<<"$(cpu_busy)"
    t2=$(n_processes "$w" "$h" "$n")
    read -r -a b <<<"$(cpu_busy)"
    busy=$(( (b[0]+b[1]+b[2]+b[5]+b[6]) - (a[0]+a[1]+a[2]+a[5]+a[6]) ))
    idle=$(( (b[3]+b[4]) - (a[3]+a[4]) ))
    share=$(( 100 * busy / (busy + idle) ))
    ok1=$(awk -v t="$t1" -v l="$limit" 'BEGIN { print (t <= l) ? "yes" : "no" }')
    ok2=$(awk -v t="$t2" -v l="$limit" 'BEGIN { print (t <= l) ? "yes" : "no" }')
    # The count that fits: the largest N before the first that did not keep up.
    [[ $ok1 == yes ]] || still_one=0
    [[ $ok2 == yes ]] || still_many=0
    [[ $res == 1920x1080 && $still_one -eq 1 ]] && fits_one=$n
    [[ $res == 1920x1080 && $still_many -eq 1 ]] && fits_many=$n
    printf "  %s x%d: one process %.1f s (%s), %d processes %.1f s (%s), CPUs %d %% busy\n" \
      "$res" "$n" "$t1" "$ok1" "$n" "$t2" "$ok2" "$share"
    table+=$'\n'"| $res | $n | $(printf %.1f "$t1") | $ok1 | $(printf %.1f "$t2") | $ok2 | $share |"
    [[ $ok1 == no && $ok2 == no ]] && break
  done
done
text="Live streams at once: N pipelines \`filesrc (raw I420 frames of the synthetic flight in tmpfs) ! rawvideoparse framerate=30/1 ! identity sync=true (releases them at 30 frames/s, like a camera) ! uavstabilize ! fakesink sync=true\`, ${seconds} s of video each, default properties, all in one process (one gst-launch-1.0) and in N processes. Wall time until the last stream's EOS; a run keeps real time when it ends within 0.5 s of one stream's run (${seconds} s + the ${delay_s} s delay + start-up).

$table

Real-time 1080p30 streams on this machine: **$fits_one in one process, $fits_many in separate processes** (largest N tried that kept real time).
"
echo "$text"
if [[ -n $out ]]; then
  printf '%s' "$text" >"$out/streams.md"
  printf 'streams.1080p.one_process\t%s\nstreams.1080p.processes\t%s\n' "$fits_one" "$fits_many" >>"$out/summary.tsv"
fi
