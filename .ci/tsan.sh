#!/usr/bin/env bash
# ThreadSanitizer build of the library and element tests, run by hand (about 4 min on
# 2 cores, plus the build).  bash .ci/tsan.sh
# Library tests: any report fails.  Element tests: the tests must pass, but TSan's reports
# are only counted and left in the log for review: Debian's GLib is not instrumented and
# its GMutex is a futex, so everything synchronised through GLib (GST_OBJECT_LOCK, the
# start of a GstTask thread, GLib's allocator) shows up as a race. tests/bench/reliability.md
# records the last review.
set -euo pipefail
cd "$(dirname "$0")/.."
bash .ci/install-deps.sh build test
[[ -f build-tsan/build.ninja ]] ||
  meson setup build-tsan -Db_sanitize=thread -Db_lundef=false -Dbuildtype=debugoptimized -Dbench=disabled \
    -Dgst=enabled >/dev/null
ninja -C build-tsan -j "$(nproc)"
supp="suppressions=$PWD/.ci/tsan.supp second_deadlock_stack=1"
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
