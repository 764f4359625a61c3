#!/usr/bin/env bash
# The project's test command: installs what is missing (Debian 12), builds, runs every test.
#   bash tests/run.sh [extra meson test args]
set -euo pipefail
cd "$(dirname "$0")/.."
bash .ci/install-deps.sh build test
if [[ ! -f build/build.ninja ]]; then
  meson setup build
fi
ninja -C build -j "$(nproc)"
meson test -C build --print-errorlogs --num-processes "$(nproc)" "$@"
