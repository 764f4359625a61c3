#!/usr/bin/env bash
# ThreadSanitizer build of the library and element tests (run by hand: about 10 min on 2 cores,
# too slow for every CI run).  bash .ci/tsan.sh [meson test args...]
set -euo pipefail
cd "$(dirname "$0")/.."
bash .ci/install-deps.sh build test
[[ -f build-tsan/build.ninja ]] ||
  meson setup build-tsan -Db_sanitize=thread -Db_lundef=false -Dbuildtype=debugoptimized -Dbench=disabled >/dev/null
ninja -C build-tsan -j "$(nproc)"
export TSAN_OPTIONS="suppressions=$PWD/.ci/tsan.supp second_deadlock_stack=1 halt_on_error=1 exitcode=66"
# The plugin is instrumented: scan it in-process.
export GST_REGISTRY_FORK=no
rm -f build-tsan/tests/element/registry.bin
meson test -C build-tsan --print-errorlogs --num-processes "$(nproc)" --suite lib --suite element \
  --timeout-multiplier 10 "$@"
echo "ThreadSanitizer: clean"
