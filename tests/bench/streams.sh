#!/usr/bin/env bash
# How many live streams fit on this machine: N pipelines, each a camera emulated by raw frames
# of the synthetic shaky flight read from tmpfs and released at 30 frames/s by the clock,
#   filesrc ! rawvideoparse ! identity sync=true ! uavstabilize ! fakesink sync=true
# for S seconds, all N in one process (one gst-launch-1.0) and in N processes. A stream
# that is not kept up with releases its frames late, so the run ends late: N streams keep
# real time when the run (PLAYING to the last EOS) ends within half a second of one stream's
# run (S + the element's 20-frame delay). (videotestsrc would cost more than the stabilizer at 1080p.)
#
#   bash tests/bench/streams.sh [--seconds S] [--out DIR] [--base REV] [--mode one|processes|both]
#                               [--counts "1 2 ..."] [--max N] [--retries R]
#
# 1080p: N = 1, 2, 4, 6, ... (up to --max, default 32) until a run falls behind, then the
# count between the last that kept real time and the first that did not (--counts: only
# those N, then the same bisection); 720p: 4 streams. --base REV: REV's plugin too (built in
# build-bench/ab/SHA as ab.sh does), its run next to this tree's for every N, which goes
# first alternating, and the ratio of the two counts. Writes DIR/streams.md and summary
# lines (streams.*) to DIR/summary.tsv. ~6 min alone; ~10-12 min with --base (S = 10; fewer
# steps on a busy machine, where the counts are lower).
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
bench_repo=$repo
# shellcheck source=tests/bench/common.sh
source "$repo/tests/bench/common.sh"
seconds=10
out=
base=
mode=both
counts=
max_n=32
retries=1
while [[ $# -gt 0 ]]; do
  case "$1" in
    --seconds) seconds=$2; shift ;;
    --out) out=$2; shift ;;
    --base) base=$2; shift ;;
    --mode) mode=$2; shift ;;
    --counts) counts=$2; shift ;;
    --max) max_n=$2; shift ;;
    --retries) retries=$2; shift ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    *) echo "streams.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
case "$mode" in
  one) modes=(one) ;;
  processes) modes=(processes) ;;
  both) modes=(one processes) ;;
  *) echo "streams.sh: --mode one|processes|both" >&2; exit 2 ;;
esac
builddir=${UAVSTAB_BENCH_BUILD_DIR:-$repo/build-bench}
render=$builddir/tests/synthetic/uavstab-render-flight
command -v ffmpeg >/dev/null || { echo "streams.sh: skipped: needs ffmpeg (to strip the y4m headers)"; exit 0; }
[[ -x $render ]] || { echo "streams.sh: $render not built" >&2; exit 1; }
t_start=$(date +%s)

builds=(this)
declare -A plugin=([this]=$builddir/gst)
declare -A label=([this]="this tree ($(bench_commit_label))")
declare -A tag=([this]="")  # in the table and the result line: the build's label when there are two
bench_check_plugin "${plugin[this]}" || exit 1
if [[ -n $base ]]; then
  echo "streams: building $base's plugin (kept in $builddir/ab)"
  bench_build_base "$base" "$builddir"
  bench_check_plugin "$base_plugin_dir" || exit 1
  plugin[base]=$base_plugin_dir
  label[base]="base $base_sha"
  builds+=(base)
  tag=([this]="this tree" [base]="$base_sha")
fi

frames=$((seconds * 30))
delay_s=0.667
clip_dir=$(mktemp -d /dev/shm/uavstab-streams.XXXXXX)
trap 'rm -rf "$clip_dir"' EXIT
declare -A clip
for res in 1920x1080 1280x720; do
  clip[$res]=$(bench_raw_clip "${res%x*}" "${res#*x}" "$frames" "$clip_dir" "$render")
done

branch() {  # one stream's pipeline description: W H
  echo "filesrc location=${clip[$1x$2]} ! rawvideoparse width=$1 height=$2 format=i420 framerate=30/1 ! identity sync=true ! uavstabilize ! fakesink sync=true"
}
cpu_ticks() {  # "busy idle" jiffies of all CPUs so far
  local _ user nice system idle iowait irq softirq rest
  read -r _ user nice system idle iowait irq softirq rest </proc/stat
  echo "$((user + nice + system + irq + softirq)) $((idle + iowait))"
}

# One run: BUILD MODE W H N; prints "seconds cpu_busy_percent", seconds from PLAYING to EOS
# as gst-launch-1.0 reports it ("Execution ended after"; start-up left out, it varies with
# the machine's load by more than the half-second margin), the longest of the N processes.
# One process: all N streams in one gst-launch-1.0; processes: N of one stream each.
run_streams() {
  local dir=${plugin[$1]} i a b desc="" pids=() log logs=1
  log=$(mktemp -d "$clip_dir/run.XXXXXX")
  read -r -a a <<<"$(cpu_ticks)"
  if [[ $2 == one ]]; then
    for ((i = 0; i < $5; i++)); do desc+=" $(branch "$3" "$4")"; done
    # shellcheck disable=SC2086
    bench_with_plugin "$dir" gst-launch-1.0 $desc >"$log/0" 2>&1 || { cat "$log/0" >&2; return 1; }
  else
    for ((i = 0; i < $5; i++)); do
      # shellcheck disable=SC2046
      bench_with_plugin "$dir" gst-launch-1.0 $(branch "$3" "$4") >"$log/$i" 2>&1 &
      pids+=($!)
    done
    wait "${pids[@]}" || { cat "$log"/* >&2; return 1; }
    logs=$5
  fi
  read -r -a b <<<"$(cpu_ticks)"
  # "Execution ended after 0:00:10.712345678"
  cat "$log"/* | awk -v busy=$((b[0] - a[0])) -v idle=$((b[1] - a[1])) -v n="$logs" '
    /^Execution ended after / { split($4, t, ":"); s = t[1] * 3600 + t[2] * 60 + t[3]; if (s > m) m = s; k++ }
    END { if (k < n) m = 1e9; printf "%.2f %d", m, (busy + idle > 0) ? 100 * busy / (busy + idle) : 0 }'
  rm -rf "$log"
}

declare -A wall busy keeps tries limit fits fail_at active
mode_text() { if [[ $1 == one ]]; then echo "one process"; elif [[ $2 == 1 ]]; then echo "1 process"; else echo "$2 processes"; fi; }
where_text() { if [[ $1 == one ]]; then echo "in one process"; else echo "in separate processes"; fi; }
# One measurement: BUILD MODE RES N; records it and prints a line. A run that falls behind is
# repeated (--retries, default 1) and the count keeps real time when one of the tries does: a
# moment of load from other work should not end a build's count early.
measure() {
  local try
  for ((try = 0; try <= retries; try++)); do
    measure_once "$@" "$try"
    [[ ${keeps[$1 $2 $3 $4]} == yes ]] && break
  done
  return 0
}
try_text() { if (($1 > 1)); then echo " (try $1)"; fi; }
measure_once() {  # BUILD MODE RES N TRY
  local w=${3%x*} h=${3#*x} r
  r=$(run_streams "$1" "$2" "$w" "$h" "$4")
  tries[$1 $2 $3 $4]=$(($5 + 1))
  wall[$1 $2 $3 $4]=${r% *}
  busy[$1 $2 $3 $4]=${r#* }
  keeps[$1 $2 $3 $4]=$(awk -v t="${r% *}" -v l="${limit[$1 $3]}" 'BEGIN { print (t <= l) ? "yes" : "no" }')
  printf '  %s x%d %-4s %-14s %6.2f s (%s), CPUs %d %% busy%s\n' "$3" "$4" "$1" "$(mode_text "$2" "$4")" \
    "${r% *}" "${keeps[$1 $2 $3 $4]}" "${r#* }" "$(try_text $(($5 + 1)))"
}
# Builds in the order of round $1: this first in even rounds, the base first in odd ones.
in_order() {
  if (($1 % 2 == 0)); then printf '%s\n' "${builds[@]}"; else printf '%s\n' "${builds[@]}" | tac; fi
}

round=0
for res in 1920x1080 1280x720; do
  # Each build's own one-stream run sets its limit.
  for b in $(in_order "$round"); do
    r=$(run_streams "$b" one "${res%x*}" "${res#*x}" 1)
    limit[$b $res]=$(awk -v t="${r% *}" 'BEGIN { printf "%.2f", t + 0.5 }')
    echo "streams $res ${label[$b]}: 1 stream takes ${r% *} s for ${seconds} s of video (real time if <= ${limit[$b $res]} s)"
  done
  ((++round))
  if [[ $res == 1280x720 ]]; then
    for m in "${modes[@]}"; do
      for b in $(in_order "$round"); do measure "$b" "$m" "$res" 4; done
      ((++round))
    done
    continue
  fi
  for b in "${builds[@]}"; do for m in "${modes[@]}"; do
    fits[$b $m]=0; active[$b $m]=1; fail_at[$b $m]=
  done; done
  # Step up until every build falls behind in every mode.
  if [[ -n $counts ]]; then list=$counts; else list="1 $(seq -s ' ' 2 2 "$max_n")"; fi
  for n in $list; do
    any=0
    for m in "${modes[@]}"; do
      for b in $(in_order "$round"); do
        [[ ${active[$b $m]} -eq 1 ]] || continue
        any=1
        measure "$b" "$m" "$res" "$n"
        if [[ ${keeps[$b $m $res $n]} == yes ]]; then fits[$b $m]=$n; else active[$b $m]=0; fail_at[$b $m]=$n; fi
      done
    done
    ((++round))
    [[ $any -eq 1 ]] || break
  done
  # Bisect between the last count that kept real time and the first that did not.
  while :; do
    todo=()
    for m in "${modes[@]}"; do
      for b in $(in_order "$round"); do
        f=${fits[$b $m]} x=${fail_at[$b $m]}
        [[ -n $x && $f -ge 1 && $((x - f)) -gt 1 ]] && todo+=("$b $m $(((f + x) / 2))")
      done
    done
    [[ ${#todo[@]} -gt 0 ]] || break
    for t in "${todo[@]}"; do
      read -r b m n <<<"$t"
      measure "$b" "$m" "$res" "$n"
      if [[ ${keeps[$b $m $res $n]} == yes ]]; then fits[$b $m]=$n; else fail_at[$b $m]=$n; fi
    done
    ((++round))
  done
done

# The table: one row per resolution and N, one column per mode and build.
header="| resolution | streams |"
rule="|---|---:|"
for m in "${modes[@]}"; do for b in "${builds[@]}"; do
  header+=" $(mode_text "$m" N)${tag[$b]:+, ${tag[$b]}}: s to EOS, real time?, CPUs busy |"
  rule+="---:|"
done; done
table="$header"$'\n'"$rule"
for res in 1920x1080 1280x720; do
  for n in $(printf '%s\n' "${!wall[@]}" | awk -v r="$res" '$3 == r {print $4}' | sort -nu); do
    row="| $res | $n |"
    for m in "${modes[@]}"; do for b in "${builds[@]}"; do
      k="$b $m $res $n"
      if [[ -n ${wall[$k]:-} ]]; then
        row+=" $(printf %.1f "${wall[$k]}"), ${keeps[$k]}$(try_text "${tries[$k]}"), ${busy[$k]} % |"
      else
        row+=" - |"
      fi
    done; done
    table+=$'\n'"$row"
  done
done

count_text() {  # BUILD MODE: the count, "at least" when nothing tried fell behind
  local n=${fits[$1 $2]}
  [[ -z ${fail_at[$1 $2]} ]] && echo "at least $n" || echo "$n"
}
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (b > 0) printf "%.2f", a / b; else print "nan" }'; }
result=""
for b in "${builds[@]}"; do
  part=""
  for m in "${modes[@]}"; do
    part+="${part:+, }$(count_text "$b" "$m") $(where_text "$m")"
  done
  result+="${result:+; }${tag[$b]:+${tag[$b]}: }$part"
done
capped() {  # MODE: "1" when a count is only a bound (a build never fell behind in the counts tried)
  if [[ -z ${fail_at[this $1]} || -z ${fail_at[base $1]} ]]; then echo 1; else echo 0; fi
}
if [[ -n $base ]]; then
  part=""
  for m in "${modes[@]}"; do
    part+="${part:+, }$(ratio "${fits[this $m]}" "${fits[base $m]}")x $(where_text "$m")"
    [[ $(capped "$m") == 0 ]] || part+=" (a bound: not every count fell behind)"
  done
  result+="; this / base: $part"
fi
duration=$(( $(date +%s) - t_start ))
order_text=
[[ -n $base ]] && order_text=" This tree's plugin ($(bench_commit_label)) and that of ${label[base]} (built from that commit; same pipelines and frames) run one after the other for every N, which goes first alternating."
where="all in one process (one gst-launch-1.0) and in N processes"
[[ $mode == both ]] || where=$(mode_text "$mode" N)
text="Live streams at once: N pipelines \`filesrc (raw I420 frames of the synthetic flight in tmpfs) ! rawvideoparse framerate=30/1 ! identity sync=true (releases them at 30 frames/s, like a camera) ! uavstabilize ! fakesink sync=true\`, ${seconds} s of video each, default properties, $where.${order_text} Time from PLAYING to the last stream's EOS (gst-launch-1.0's \"Execution ended after\", the longest of the N processes; start-up left out); a run keeps real time when it ends within 0.5 s of one stream's run of the same build (${seconds} s + the ${delay_s} s delay). A run that falls behind is tried again, ${retries} more time(s) at most (\"try 2\": the table shows the last try). At 1080p N steps 1, 2, 4, 6, ... until a run falls behind, then the count in between is tried; \"CPUs busy\" is the share of both CPUs busy during the run, other processes included. The run took $((duration / 60)) min $((duration % 60)) s.

$table

Real-time 1080p30 streams on this machine: **$result** (largest N that kept real time).
"
echo
echo "$text"
summary=""
for m in "${modes[@]}"; do
  key=one_process
  [[ $m == one ]] || key=processes
  summary+="streams.1080p.$key"$'\t'"${fits[this $m]}"$'\n'
  if [[ -z $base ]]; then  # no base in this run: hide an earlier run's base counts from the report
    summary+="streams.1080p.base.$key"$'\t'"nan"$'\n'
  else
    summary+="streams.1080p.base.$key"$'\t'"${fits[base $m]}"$'\n'
    summary+="streams.1080p.ratio.$key"$'\t'"$(ratio "${fits[this $m]}" "${fits[base $m]}")"$'\n'
    summary+="streams.1080p.ratio_capped.$key"$'\t'"$(capped "$m")"$'\n'
  fi
done
[[ -n $base ]] && summary+="streams.base"$'\t'"$base_sha"$'\n'
summary+="streams.seconds"$'\t'"$seconds"$'\n'
if [[ -n $out ]]; then
  printf '%s' "$text" >"$out/streams.md"
  printf '%s' "$summary" >>"$out/summary.tsv"
else
  echo "summary lines (with --out DIR: appended to DIR/summary.tsv):"
  printf '%s' "$summary"
fi
