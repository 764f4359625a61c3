#!/usr/bin/env bash
# The benchmark of uavstabilize: throughput, latency, memory and quality of the library and
# the GStreamer element, beside ffmpeg's deshake and vid.stab on the same frames.
#
#   bash tests/bench/run.sh            # full run (~65 min on 2 cores, quality ~20 of it, rolling shutter ~10, lens ~5, streams ~12); updates tests/bench/REPORT.md + PNGs
#   bash tests/bench/run.sh --quick    # fewer runs/resolutions/clips (~5-8 min); report in the out dir only
#
# Options: --out DIR (default build-bench/bench-out), --no-wait (do not wait for a quiet
# machine), --no-build (use the build dir as it is), --only PROGRAM (speed, element, memory,
# quality, path, rs, lens, streams, profile; repeatable; the report is still assembled from whatever the out dir holds,
# under the header of the run that made it, with a line saying what was re-run),
# --base REV (the commit streams.sh and profile.sh measure this tree against, default c0aeebc,
# the element with the window planners alone; "none": this tree alone).
# Uses its own build dir, build-bench (UAVSTAB_BENCH_BUILD_DIR overrides). Real clips are
# read from ../shared/data (relative to the repository) when present and skipped when not.
# A benchmark, not a test: it reports numbers and never fails on them.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"

quick=()
out=
wait_quiet=1
build=1
only=()
base=c0aeebc
while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) quick=(--quick) ;;
    --out) out=$2; shift ;;
    --no-wait) wait_quiet=0 ;;
    --no-build) build=0 ;;
    --only) only+=("$2"); shift ;;
    --base) base=$2; shift ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "run.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
wants() { [[ ${#only[@]} -eq 0 ]] || [[ " ${only[*]} " == *" $1 "* ]]; }

builddir=${UAVSTAB_BENCH_BUILD_DIR:-$repo/build-bench}
if [[ $build -eq 1 ]]; then
  bash .ci/install-deps.sh build bench
  [[ -f $builddir/build.ninja ]] || meson setup "$builddir" >/dev/null
  ninja -C "$builddir" -j 2 >/dev/null
fi
bin=$builddir/tests/bench
[[ -x $bin/uavstab-bench-speed ]] || { echo "run.sh: benchmark not built (OpenCV features2d/calib3d missing?)" >&2; exit 1; }

out=${out:-$builddir/bench-out}
mkdir -p "$out"
out=$(cd "$out" && pwd)
if [[ ${#only[@]} -eq 0 ]]; then
  rm -f "$out"/*.md "$out"/*.png "$out"/summary.tsv
fi
data=$(cd "$repo/.." && pwd)/shared/data
[[ -d $data ]] || echo "real clips: $data not found; the real-clip sections will say they were skipped"

# Other work on the machine distorts every number: wait (up to 10 min) until the CPUs are
# mostly idle; each section reports the share other processes took while it ran.
busy_share() {  # percent of all CPUs busy over 3 s
  local a b
  a=($(head -1 /proc/stat)); sleep 3; b=($(head -1 /proc/stat))
  local busy=$(( (b[1]+b[2]+b[3]+b[6]+b[7]) - (a[1]+a[2]+a[3]+a[6]+a[7]) ))
  local total=$(( busy + (b[4]+b[5]) - (a[4]+a[5]) ))
  echo $(( total > 0 ? 100 * busy / total : 0 ))
}
if [[ $wait_quiet -eq 1 ]]; then
  for i in $(seq 1 200); do
    b=$(busy_share)
    [[ $b -le 20 ]] && break
    [[ $i -eq 1 ]] && echo "waiting for a quiet machine (CPUs ${b}% busy; --no-wait to skip)..."
  done
fi
start_busy=$(busy_share)

commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
subject=$(git log -1 --format=%s 2>/dev/null || echo "")
dirty=$(git status --porcelain --untracked-files=no 2>/dev/null | grep -q . && echo " (with uncommitted changes)" || true)
cpu=$(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')
opencv=$(dpkg-query -W -f='${Version}' libopencv-core406 2>/dev/null || echo unknown)
if [[ ${#only[@]} -gt 0 && -f $out/header.md ]]; then
  # A partial re-run keeps the header of the run that made the other sections.
  echo "- Re-run later: ${only[*]} ($(date -u '+%Y-%m-%d %H:%M UTC'), commit \`$(git rev-parse --short HEAD 2>/dev/null || echo unknown)\`$dirty; CPUs ${start_busy} % busy before)" >>"$out/header.md"
else
{
  echo "# uavstabilize benchmark report"
  echo
  echo "- Date: $(date -u '+%Y-%m-%d %H:%M UTC')"
  echo "- Commit: \`$commit\` $subject$dirty"
  echo "- Machine: $cpu, $(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GiB RAM; $(. /etc/os-release && echo "$PRETTY_NAME"), kernel $(uname -r)"
  echo "- Software: $(g++ --version | head -1); GStreamer $(gst-inspect-1.0 --version 2>/dev/null | sed -n 2p | awk '{print $2}'); OpenCV $opencv; $(ffmpeg -version 2>/dev/null | head -1 | awk '{print "ffmpeg", $3}')"
  echo "- Command: \`bash tests/bench/run.sh${quick:+ --quick}$([[ $base == c0aeebc ]] || echo " --base $base")\`$([[ ${#quick[@]} -gt 0 ]] && echo " (quick: fewer runs, resolutions and clips)")"
  echo "- The machine is shared: CPUs were ${start_busy} % busy just before the run. Each section states the share of the CPUs other processes took while it ran; the speed and latency tables give it per row (\"other processes\"): a measurement is repeated (up to 3 attempts, after waiting for a quiet moment) when others took 15 % or more, and the share is **bold** when it stayed that high."
  echo "- Real clips: $( [[ -d $data ]] && echo "\`../shared/data\` ($(ls "$data" | grep -cE '\.(mp4|avi)$') clips)" || echo "not present (sections skipped)")"
} >"$out/header.md"
fi

t0=$(date +%s)
step() { echo; echo "== $1 ($(( $(date +%s) - t0 )) s)"; }
if wants speed; then
  step "library, per-stage, latency, peers"
  "$bin/uavstab-bench-speed" --out "$out" "${quick[@]}"
fi
if wants element; then
  step "element"
  if [[ -x $bin/uavstab-bench-element ]]; then
    "$bin/uavstab-bench-element" --out "$out" "${quick[@]}"
  else
    echo "Element: skipped: the plugin was not built (GStreamer or its app library missing)." | tee "$out/speed_element.md"
    cp "$out/speed_element.md" "$out/latency_element.md"
  fi
fi
if wants memory; then
  step "memory"
  "$bin/uavstab-bench-memory" --out "$out" "${quick[@]}"
fi
if wants quality; then
  step "quality"
  "$bin/uavstab-bench-quality" --out "$out" --data "$data" "${quick[@]}"
fi
if wants path; then
  step "planners alone (perfect estimates)"
  if [[ ${#quick[@]} -gt 0 ]]; then
    "$bin/uavstab-bench-path" --planner l1 --planner optimal --seeds 1 --strengths 1 --out "$out/quality_path.md" >/dev/null
  else
    "$bin/uavstab-bench-path" --planner l1 --planner optimal --planner gaussian --seeds 3 --strengths 0.5,1,2 \
      --out "$out/quality_path.md" >/dev/null
  fi
fi
if wants rs; then
  step "rolling shutter"
  "$bin/uavstab-bench-rolling-shutter" --out "$out" --data "$data" "${quick[@]}"
fi
if wants lens; then
  step "lens profiles"
  "$bin/uavstab-bench-lens" --out "$out" "${quick[@]}"
fi
base_args=()
[[ $base == none ]] || base_args=(--base "$base")
if wants streams; then
  step "live streams at once${base_args[*]:+, this tree and $base}"
  if [[ ${#quick[@]} -gt 0 ]]; then
    bash tests/bench/streams.sh --out "$out" "${base_args[@]}" --seconds 4 --mode one
  else
    bash tests/bench/streams.sh --out "$out" "${base_args[@]}"
  fi
fi
if wants profile; then
  step "CPU profile at 1080p${base_args[*]:+, this tree and $base}"
  if [[ ${#quick[@]} -gt 0 ]]; then
    bash tests/bench/profile.sh --out "$out" "${base_args[@]}" --frames 100
  else
    bash tests/bench/profile.sh --out "$out" "${base_args[@]}"
  fi
fi
step "report"
cp tests/bench/reliability.md "$out/reliability.md"  # kept by hand: runs too long for the benchmark
[[ ${#only[@]} -gt 0 ]] || echo "- Duration of the run: $(( ($(date +%s) - t0) / 60 )) min $(( ($(date +%s) - t0) % 60 )) s" >>"$out/header.md"
"$bin/uavstab-bench-report" --out "$out" "${quick[@]}"
if [[ ${#quick[@]} -eq 0 && ${#only[@]} -eq 0 ]]; then
  cp "$out/REPORT.md" "$out"/*.png "$repo/tests/bench/"
  echo "updated tests/bench/REPORT.md and its plots"
fi
echo "report: $out/REPORT.md"
