#!/usr/bin/env bash
# ThreadSanitizer build of the library and element tests.
#   bash .ci/tsan.sh          library and element tests (by hand, about 4 min on 2 cores, plus the build)
#   bash .ci/tsan.sh lib      library tests only (CI runs this after the sanitizers; builds only them)
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
  # Only the library tests' executables (and what they link), not the plugin.
  mapfile -t targets < <(meson introspect build-tsan --tests | python3 -c '
import json, os, sys
for t in json.load(sys.stdin):
    if any(s.endswith(":lib") or s == "lib" for s in t["suite"]):
        print(os.path.relpath(t["cmd"][0], "build-tsan"))')
  [[ ${#targets[@]} -gt 0 ]] || { echo "tsan.sh: no library tests found" >&2; exit 1; }
  ninja -C build-tsan -j "$(nproc)" "${targets[@]}"
  TSAN_OPTIONS="$supp halt_on_error=1 exitcode=66" \
    meson test -C build-tsan --no-rebuild --print-errorlogs --num-processes "$(nproc)" --suite lib \
    --timeout-multiplier 10
  log=build-tsan/meson-logs/testlog.txt
  if grep -q 'WARNING: ThreadSanitizer' "$log"; then  # belt and braces: a report that did not fail its test
    echo "ThreadSanitizer reports in $log" >&2
    exit 1
  fi
  echo "ThreadSanitizer, library tests: clean"
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
