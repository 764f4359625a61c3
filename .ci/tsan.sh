#!/usr/bin/env bash
# ThreadSanitizer build of the library and element tests.
#   bash .ci/tsan.sh          library and element tests (by hand, about 4 min on 2 cores, plus the build)
#   bash .ci/tsan.sh lib      the library tests that start threads (CI runs this after the
#                             sanitizers; builds only them)
# Library tests: any report fails.  Element tests: the tests must pass, but TSan's reports
# are only counted and left in the log for review: Debian's GLib is not instrumented and
# its GMutex is a futex, so everything synchronised through GLib (GST_OBJECT_LOCK, the
# start of a GstTask thread, GLib's allocator) shows up as a race. tests/bench/reliability.md
# records the last review.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-all}
case "$mode" in
  all | lib) ;;
  *) echo "usage: $0 [all|lib]" >&2; exit 2 ;;
esac
bash .ci/install-deps.sh build test
[[ -f build-tsan/build.ninja ]] ||
  meson setup build-tsan -Db_sanitize=thread -Db_lundef=false -Dbuildtype=debugoptimized -Dbench=disabled \
    -Dgst=enabled >/dev/null
supp="suppressions=$PWD/.ci/tsan.supp second_deadlock_stack=1"

if [[ $mode == lib ]]; then
  # The library tests whose code runs on more than one thread: the stabilizer's worker
  # pool (planning, warps in stripes, handing frames back), the tracker's work lent to an
  # idle thread, the pool itself, and 16-bit frames through the threaded stabilizer. The
  # others test single-threaded stages, where TSan has nothing to find; the long quality
  # flights of the exclude test run the same threaded code as the stabilizer test.
  threaded=(stabilizer worker_pool feature_tracker thermal)
  mapfile -t targets < <(meson introspect build-tsan --tests | python3 -c '
import json, os, sys
wanted = set(sys.argv[1:])
for t in json.load(sys.stdin):
    if t["name"] in wanted:
        print(os.path.relpath(t["cmd"][0], "build-tsan"))' "${threaded[@]}")
  [[ ${#targets[@]} -eq ${#threaded[@]} ]] || { echo "tsan.sh: not every threaded library test was found (${threaded[*]})" >&2; exit 1; }
  ninja -C build-tsan -j "$(nproc)" "${targets[@]}"
  TSAN_OPTIONS="$supp halt_on_error=1 exitcode=66" \
    meson test -C build-tsan --no-rebuild --print-errorlogs --num-processes "$(nproc)" --suite lib \
    --timeout-multiplier 10 "${threaded[@]}"
  log=build-tsan/meson-logs/testlog.txt
  if grep -q 'WARNING: ThreadSanitizer' "$log"; then  # belt and braces: a report that did not fail its test
    echo "ThreadSanitizer reports in $log" >&2
    exit 1
  fi
  echo "ThreadSanitizer, threaded library tests (${threaded[*]}): clean"
  exit 0
fi

ninja -C build-tsan -j "$(nproc)"
# The plugin is instrumented: scan it in-process.
export GST_REGISTRY_FORK=no
rm -f build-tsan/tests/element/registry.bin

TSAN_OPTIONS="$supp halt_on_error=1 exitcode=66" \
  meson test -C build-tsan --print-errorlogs --num-processes "$(nproc)" --suite lib --timeout-multiplier 10
echo "ThreadSanitizer, library tests: clean"

TSAN_OPTIONS="$supp halt_on_error=0 exitcode=0" \
  meson test -C build-tsan --print-errorlogs --num-processes "$(nproc)" --suite element --timeout-multiplier 10 \
  >/dev/null
log=build-tsan/meson-logs/testlog.txt
echo "ThreadSanitizer, element tests: passed; $(grep -c 'WARNING: ThreadSanitizer' "$log") reports to review in $log" \
  "($(grep -A12 'WARNING: ThreadSanitizer' "$log" | grep -c '\.\./gst/') stack frames in gst/)"
