#!/usr/bin/env bash
# Where the element's time goes at 1080p: a CPU profile (perf record, sampling) of
#   filesrc (raw I420 frames of the synthetic flight in tmpfs) ! rawvideoparse ! uavstabilize ! fakesink sync=false
# over F frames (default 300) as fast as it goes, default properties, all threads of the
# process; the top functions by self time (`perf report --no-children`) and the share per
# library. --base REV: the same for REV's plugin (built in build-bench/ab/SHA as ab.sh does),
# side by side. Where perf cannot sample (perf_event_paranoid, no perf), valgrind's
# callgrind counts instructions instead, on fewer frames (--callgrind-frames, default 40),
# and the text says so (UAVSTAB_PROFILE_TOOL=callgrind forces it).
#
#   bash tests/bench/profile.sh [--frames F] [--resolution WxH] [--top K] [--base REV] [--out DIR]
#
# Writes DIR/profile.md (and keeps the raw profiles there, profile-this.data / profile-base.data
# or callgrind.out.*); without --out prints the fragment only. ~1 min (with --base ~2 min,
# plus building REV's plugin the first time).
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
bench_repo=$repo
# shellcheck source=tests/bench/common.sh
source "$repo/tests/bench/common.sh"
frames=300
cg_frames=40
res=1920x1080
top=20
base=
out=
while [[ $# -gt 0 ]]; do
  case "$1" in
    --frames) frames=$2; shift ;;
    --callgrind-frames) cg_frames=$2; shift ;;
    --resolution) res=$2; shift ;;
    --top) top=$2; shift ;;
    --base) base=$2; shift ;;
    --out) out=$2; shift ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    *) echo "profile.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
w=${res%x*} h=${res#*x}
builddir=${UAVSTAB_BENCH_BUILD_DIR:-$repo/build-bench}
render=$builddir/tests/synthetic/uavstab-render-flight
command -v ffmpeg >/dev/null || { echo "profile.sh: skipped: needs ffmpeg (to strip the y4m headers)"; exit 0; }
[[ -x $render ]] || { echo "profile.sh: $render not built" >&2; exit 1; }

builds=(this)
declare -A plugin=([this]=$builddir/gst)
declare -A label=([this]="this tree ($(bench_commit_label))")
declare -A tag=([this]="")  # column headers: the build's label when there are two
bench_check_plugin "${plugin[this]}" || exit 1
if [[ -n $base ]]; then
  echo "profile: building $base's plugin (kept in $builddir/ab)"
  bench_build_base "$base" "$builddir"
  bench_check_plugin "$base_plugin_dir" || exit 1
  plugin[base]=$base_plugin_dir
  label[base]="base $base_sha"
  builds+=(base)
  tag=([this]="this tree: " [base]="$base_sha: ")
fi

work=$(mktemp -d /dev/shm/uavstab-profile.XXXXXX)
trap 'rm -rf "$work"' EXIT
keep=${out:-$work}

# The profiler: perf with its default event (cycles where the CPU's counters are visible),
# else the cpu-clock software event, else callgrind.
tool=${UAVSTAB_PROFILE_TOOL:-}
perf_event=()
if [[ -z $tool ]]; then
  if command -v perf >/dev/null && perf record -q -o "$work/probe.data" -- true >/dev/null 2>&1; then
    tool=perf
  elif command -v perf >/dev/null && perf record -q -e cpu-clock -o "$work/probe.data" -- true >/dev/null 2>&1; then
    tool=perf perf_event=(-e cpu-clock)
  elif command -v valgrind >/dev/null; then
    tool=callgrind
  else
    echo "profile.sh: skipped: neither perf (linux-perf) nor valgrind can profile here"; exit 0
  fi
fi
why_callgrind=
if [[ $tool == callgrind ]]; then
  if [[ -n ${UAVSTAB_PROFILE_TOOL:-} ]]; then
    why_callgrind="valgrind's callgrind (chosen with UAVSTAB_PROFILE_TOOL=callgrind) counted "
  else
    why_callgrind="perf could not sample here (kernel.perf_event_paranoid = $(cat /proc/sys/kernel/perf_event_paranoid 2>/dev/null || echo '?')$(command -v perf >/dev/null || echo ', perf not installed')), so valgrind's callgrind counted "
  fi
  frames=$cg_frames
fi
clip=$(bench_raw_clip "$w" "$h" "$frames" "$work" "$render")
pipeline=(filesrc "location=$clip" ! rawvideoparse "width=$w" "height=$h" format=i420 framerate=30/1
          ! uavstabilize ! fakesink sync=false)

cell() {  # a function or library name as a table cell: shortened, pipes escaped
  local s=$1
  ((${#s} > 90)) && s="${s:0:87}..."
  s=${s//|/\\|}
  # shellcheck disable=SC2016
  printf '`%s`' "$s"
}

# profile BUILD: runs the pipeline under the profiler; writes $work/BUILD.fun (self % TAB
# function TAB library, best first) and $work/BUILD.dso (self % TAB library) and prints
# "wall_s event".
profile() {
  local b=$1 data event samples
  bench_with_plugin "${plugin[$b]}" gst-inspect-1.0 uavstabilize >/dev/null  # registry up to date first
  if [[ $tool == perf ]]; then
    data=$keep/profile-$b.data
    bench_with_plugin "${plugin[$b]}" perf record -q "${perf_event[@]}" -o "$data" -- \
      gst-launch-1.0 "${pipeline[@]}" >"$work/$b.out" 2>"$work/$b.err" || { cat "$work/$b.err" >&2; return 1; }
    perf report -i "$data" --stdio --no-children --sort dso,sym -t $'\t' 2>/dev/null >"$work/$b.report"
    samples="$(awk '/^# Samples: / && !n++ { print $3 }' "$work/$b.report") samples"
    awk -F'\t' '!/^#/ && NF >= 3 {
        gsub(/^ +| +$/, "", $1); gsub(/^ +| +$/, "", $2); gsub(/^ +| +$/, "", $3)
        sub(/^\[[.k]\] /, "", $3); sub(/%$/, "", $1); print $1 "\t" $3 "\t" $2 }' "$work/$b.report" >"$work/$b.raw"
    event=$(perf report -i "$data" --stdio --header-only 2>/dev/null | awk -F': ' '/^# event : name = / && !n++ {split($2, a, ","); sub(/name = /, "", a[1]); print a[1]}')
  else
    data=$keep/callgrind.out.$b
    bench_with_plugin "${plugin[$b]}" valgrind --tool=callgrind --callgrind-out-file="$data" -q \
      gst-launch-1.0 "${pipeline[@]}" >"$work/$b.out" 2>"$work/$b.err" || { cat "$work/$b.err" >&2; return 1; }
    # "1,234,567 (12.34%)  file:function [library]", self cost per function, best first.
    callgrind_annotate --inclusive=no --threshold=100 "$data" 2>/dev/null |
      sed -nE 's/^ *[0-9,]+ \( *([0-9.]+)%\)  (.*) \[(.*)\]$/\1\t\2\t\3/p' |
      awk -F'\t' '{ f = $2; sub(/^[^:]*:/, "", f)
        # "name(args)": the name, as perf shows it (the last balanced parenthesis group dropped)
        if (f ~ /\)$/) { d = 0; for (i = length(f); i > 0; i--) { c = substr(f, i, 1)
          if (c == ")") d++; else if (c == "(" && --d == 0) { f = substr(f, 1, i - 1); break } } }
        print $1 "\t" f "\t" $3 }' >"$work/$b.raw"
    event="instructions (callgrind Ir)"
    samples=$(callgrind_annotate "$data" 2>/dev/null | awk '/PROGRAM TOTALS/ && !n++ { gsub(/,/, "", $1); print $1 " instructions" }')
  fi
  # Addresses in libraries without symbols (Debian's OpenCV) summed into one row per library.
  awk -F'\t' '{ f = $2; if (f ~ /^(0x)?[0-9a-f]+$/ || f == "???") f = "(code without symbols)"; s[f "\t" $3] += $1 }
    END { for (k in s) printf "%.2f\t%s\n", s[k], k }' "$work/$b.raw" | sort -t$'\t' -k1,1gr >"$work/$b.fun"
  awk -F'\t' '{ d = $3; sub(/.*\//, "", d); s[d] += $1 } END { for (d in s) printf "%.2f\t%s\n", s[d], d }' \
    "$work/$b.raw" | sort -t$'\t' -k1,1gr >"$work/$b.dso"
  # PLAYING to EOS as gst-launch-1.0 reports it: "Execution ended after 0:00:02.345678901"
  awk -v e="$event" '/^Execution ended after / { split($4, t, ":"); s = t[1] * 3600 + t[2] * 60 + t[3] }
    END { printf "%.2f %s", s, e }' "$work/$b.out" >"$work/$b.info"
  echo "${samples:-?}" >"$work/$b.samples"
}

declare -A wall event samples
for b in "${builds[@]}"; do
  echo "profile: ${label[$b]}, $frames frames of ${res} I420 under $tool"
  profile "$b"
  r=$(cat "$work/$b.info")
  wall[$b]=${r%% *}
  samples[$b]=$(cat "$work/$b.samples")
  event[$b]=${r#* }
done

# Tables: rank x build, self % / function / library; then the share per library.
header="| # |" rule="|---:|"
for b in "${builds[@]}"; do
  header+=" ${tag[$b]}self % | function | library |"
  rule+="---:|---|---|"
done
fun_table="$header"$'\n'"$rule"
for ((i = 1; i <= top; i++)); do
  row="| $i |" any=0
  for b in "${builds[@]}"; do
    line=$(sed -n "${i}p" "$work/$b.fun")
    if [[ -n $line ]]; then
      IFS=$'\t' read -r pct fun lib <<<"$line"
      row+=" $pct | $(cell "$fun") | $(cell "${lib##*/}") |"
      any=1
    else
      row+=" | | |"
    fi
  done
  [[ $any -eq 1 ]] && fun_table+=$'\n'"$row"
done
header="| library |" rule="|---|"
for b in "${builds[@]}"; do
  header+=" ${tag[$b]}self % |"
  rule+="---:|"
done
dso_table="$header"$'\n'"$rule"
while IFS= read -r lib; do
  row="| $(cell "$lib") |"
  for b in "${builds[@]}"; do
    pct=$(awk -F'\t' -v l="$lib" '{ d = $2; sub(/.*\//, "", d) } d == l { print $1; exit }' "$work/$b.dso")
    row+=" ${pct:--} |"
  done
  dso_table+=$'\n'"$row"
done < <(for b in "${builds[@]}"; do head -8 "$work/$b.dso"; done | awk -F'\t' '{ d = $2; sub(/.*\//, "", d); if (!seen[d]++) print d }')

runs=""
for b in "${builds[@]}"; do
  runs+="${runs:+; }${label[$b]}: ${samples[$b]}, ${wall[$b]} s from PLAYING to EOS under the profiler ($(awk -v t="${wall[$b]}" -v f="$frames" 'BEGIN { printf "%.1f", 1000 * t / f }') ms per frame)"
done
if [[ $tool == perf ]]; then
  how="\`perf record\` (event ${event[this]}, all threads of the gst-launch-1.0 process), self time per function (\`perf report --no-children\`)"
else
  how="${why_callgrind}instructions executed per function (not time: memory stalls do not show), self cost (\`callgrind_annotate --inclusive=no\`)"
fi
text="CPU profile of the element at ${res} I420: \`gst-launch-1.0 filesrc (raw frames of the synthetic flight in tmpfs) ! rawvideoparse ! uavstabilize ! fakesink sync=false\`, ${frames} frames as fast as they go, default properties; $how. Shares are of the whole process (reading the file, GStreamer and start-up included). ${runs}.

Top functions:

$fun_table

Per library:

$dso_table
"
echo
echo "$text"
[[ -n $out ]] && printf '%s' "$text" >"$out/profile.md"
exit 0
