#!/usr/bin/env bash
# CI's second half: the library and element tests under ASan+UBSan (the element suite
# includes the chaos test, 300 random sequences), and libFuzzer runs (60 s each unless given) over the
# library and over the element. Run after tests/run.sh (which installs the build
# dependencies).
#   bash .ci/sanitizers.sh [fuzz seconds, for each fuzzer]
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
echo "(the live RTSP test and the KLV sample test are not run under ASan: they drive the uninstrumented gst-launch-1.0)"

[[ -f build-fuzz/build.ninja ]] ||
  CC=clang CXX=clang++ meson setup build-fuzz -Dfuzz=true -Db_sanitize=address,undefined -Db_lundef=false \
    -Dbuildtype=debugoptimized -Dtests=disabled -Dbench=disabled >/dev/null
meson configure build-fuzz -Dgst=enabled >/dev/null  # the element fuzzer links the plugin (older dirs had it off)
ninja -C build-fuzz -j "$(nproc)" tests/fuzz/fuzz_stabilizer tests/fuzz/fuzz_element tests/fuzz/fuzz_lens_profile

# fuzz NAME SEED_CORPUS: a run of fuzz_seconds from the committed seeds; fails on any finding.
fuzz() {
  local corpus log status=0
  corpus=$(mktemp -d)
  log=$(mktemp)
  "build-fuzz/tests/fuzz/$1" -max_total_time="$fuzz_seconds" -rss_limit_mb=4096 -timeout=30 \
    -print_final_stats=1 "$corpus" "$2" >"$log" 2>&1 || status=$?
  grep -E "INITED|DONE|stat::number_of_executed_units|ERROR|SUMMARY|crash-|deadly|contract broken" "$log" || true
  if [[ $status -ne 0 ]]; then
    tail -n 80 "$log"
    echo "$1 found a problem (exit $status)"
    exit 1
  fi
  rm -rf "$corpus" "$log"
}
echo "== libFuzzer: ${fuzz_seconds} s over the library"
fuzz fuzz_stabilizer tests/fuzz/corpus
echo "== libFuzzer: ${fuzz_seconds} s over the element"
fuzz fuzz_element tests/fuzz/element_corpus
echo "== libFuzzer: ${fuzz_seconds} s over the lens-profile reader"
fuzz fuzz_lens_profile tests/fuzz/lens_corpus
echo "sanitizers and fuzzers: clean"
