#!/usr/bin/env bash
# CI's second half: the library and element tests under ASan+UBSan, and a 60 s libFuzzer
# run over the library. Run after tests/run.sh (which installs the build dependencies).
#   bash .ci/sanitizers.sh [fuzz seconds]
set -euo pipefail
cd "$(dirname "$0")/.."
fuzz_seconds=${1:-60}
bash .ci/install-deps.sh build test fuzz

echo "== ASan + UBSan: library and element tests"
[[ -f build-asan/build.ninja ]] ||
  meson setup build-asan -Db_sanitize=address,undefined -Db_lundef=false -Dbuildtype=debugoptimized \
    -Dbench=disabled >/dev/null
ninja -C build-asan -j "$(nproc)"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# The plugin is instrumented: scan it in-process (the forked scanner is not).
export GST_REGISTRY_FORK=no
rm -f build-asan/tests/element/registry.bin
ASAN_OPTIONS=detect_leaks=1 meson test -C build-asan --print-errorlogs --num-processes "$(nproc)" --suite lib
# Leaks in the element tests are the leaks tracer's job (GST_TRACERS=leaks in every
# element test): LeakSanitizer would also report GLib's and OpenCV's one-time allocations.
ASAN_OPTIONS=detect_leaks=0 meson test -C build-asan --print-errorlogs --num-processes "$(nproc)" --suite element
echo "(the live RTSP test is not run under ASan: it drives the uninstrumented gst-launch-1.0)"

echo "== libFuzzer: ${fuzz_seconds} s over the library"
[[ -f build-fuzz/build.ninja ]] ||
  CC=clang CXX=clang++ meson setup build-fuzz -Dfuzz=true -Db_sanitize=address,undefined -Db_lundef=false \
    -Dbuildtype=debugoptimized -Dgst=disabled -Dtests=disabled -Dbench=disabled >/dev/null
ninja -C build-fuzz -j "$(nproc)" tests/fuzz/fuzz_stabilizer
corpus=$(mktemp -d)
log=$(mktemp)
status=0
build-fuzz/tests/fuzz/fuzz_stabilizer -max_total_time="$fuzz_seconds" -rss_limit_mb=4096 -timeout=30 \
  -print_final_stats=1 "$corpus" tests/fuzz/corpus >"$log" 2>&1 || status=$?
grep -E "INITED|DONE|stat::number_of_executed_units|ERROR|SUMMARY|crash-|deadly" "$log" || true
if [[ $status -ne 0 ]]; then
  tail -n 60 "$log"
  echo "fuzzer found a problem (exit $status)"
  exit 1
fi
rm -rf "$corpus" "$log"
echo "sanitizers and fuzzer: clean"
