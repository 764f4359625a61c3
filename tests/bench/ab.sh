#!/usr/bin/env bash
# Element throughput of two builds of the plugin, interleaved: this tree against another
# commit, run after run, so that both see the same machine. On a shared machine whose speed
# drifts by tens of percent within minutes, a before/after taken minutes apart says little;
# the ratio of runs taken side by side says more.
#
#   bash tests/bench/ab.sh --base REV [--rounds N] [--resolution WxH]...
#
# Builds REV's plugin in build-bench/ab/REV (kept for the next time; tests/bench/common.sh) and
# this tree's in build-bench, then runs `uavstab-bench-element --only throughput` (this tree's harness, the
# same for both) once per build per round, alternating which goes first. Prints each run's
# median fps for I420 at 1 and 2 threads, then the median over rounds and the median of the
# per-round ratios this / base. Each build runs with a GStreamer registry of its own that
# is not rescanned, so the harness loads that build's plugin (it adds this tree's plugin
# directory to GST_PLUGIN_PATH, and in a scan the first directory wins). A benchmark, not a
# test: it never fails on the numbers.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"
bench_repo=$repo
# shellcheck source=tests/bench/common.sh
source "$repo/tests/bench/common.sh"

base=
rounds=6
resolutions=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --base) base=$2; shift ;;
    --rounds) rounds=$2; shift ;;
    --resolution) resolutions+=(--resolution "$2"); shift ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "ab.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
[[ -n $base ]] || { echo "ab.sh: --base REV is required" >&2; exit 2; }
[[ ${#resolutions[@]} -gt 0 ]] || resolutions=(--resolution 640x480)
sha=$(git rev-parse --short "$base^{commit}")

builddir=${UAVSTAB_BENCH_BUILD_DIR:-$repo/build-bench}
[[ -f $builddir/build.ninja ]] || meson setup "$builddir" >/dev/null
ninja -C "$builddir" -j 2 >/dev/null
bench=$builddir/tests/bench/uavstab-bench-element
[[ -x $bench ]] || { echo "ab.sh: $bench was not built (GStreamer app library missing?)" >&2; exit 1; }

bench_build_base "$sha" "$builddir"

declare -A plugin=([this]="$builddir/gst" [base]="$base_plugin_dir")
bench_check_plugin "${plugin[this]}" && bench_check_plugin "${plugin[base]}" || exit 1
declare -A fps
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "this tree ($(git rev-parse --short HEAD)$(git status --porcelain --untracked-files=no | grep -q . && echo ', with uncommitted changes')) against $sha, ${rounds} rounds, ${resolutions[*]}"
for r in $(seq 1 "$rounds"); do
  order=(this base)
  (( r % 2 == 0 )) && order=(base this)
  for which in "${order[@]}"; do
    lines=$(bench_with_plugin "${plugin[$which]}" "$bench" --out "$out" --only throughput "${resolutions[@]}" 2>&1 |
            grep -E "element [0-9]+x[0-9]+ I420 threads=[12]:" || true)
    while read -r _ res _ threads value _; do
      [[ -n ${res:-} ]] || continue
      key="$res ${threads%:}"
      fps["$which $key $r"]=$value
      printf 'round %d %-4s %s %s: %s fps\n' "$r" "$which" "$res" "${threads%:}" "$value"
    done <<<"$lines"
  done
done

median() { sort -g | awk '{v[NR]=$1} END{if (NR) printf "%.3g", (NR%2 ? v[(NR+1)/2] : (v[NR/2]+v[NR/2+1])/2)}'; }
echo
printf '| size, threads | this tree fps (median of rounds) | %s fps | this / base (median of per-round ratios) |\n' "$sha"
echo '|---|---:|---:|---:|'
for key in $(printf '%s\n' "${!fps[@]}" | awk '{print $2"_"$3}' | sort -u); do
  k=${key/_/ }
  this=() other=() ratio=()
  for r in $(seq 1 "$rounds"); do
    a=${fps["this $k $r"]:-} b=${fps["base $k $r"]:-}
    [[ -n $a ]] && this+=("$a")
    [[ -n $b ]] && other+=("$b")
    [[ -n $a && -n $b ]] && ratio+=("$(awk -v a="$a" -v b="$b" 'BEGIN{printf "%.4f", a/b}')")
  done
  printf '| %s | %s | %s | %s |\n' "$k" "$(printf '%s\n' "${this[@]}" | median)" \
    "$(printf '%s\n' "${other[@]}" | median)" "$(printf '%s\n' "${ratio[@]}" | median)"
done
