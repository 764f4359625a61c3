#!/usr/bin/env bash
# aarch64 cross build of the library and its tests, the tests run under
# qemu-user. The GStreamer element is not built (-Dgst=disabled).
#   bash .ci/cross-aarch64.sh [extra meson test args, e.g. test names]
# e.g. `bash .ci/cross-aarch64.sh frame_warper`: its log names the warp kernel that ran
# ("warp kernel: neon128") and compares it byte for byte with the scalar reference.
# By hand, not in .ci/run: on 2 cores it takes about 12.5 min (sysroot 1 min, once; build
# 3 min; the library tests 9 min under emulation, feature_tracker and trajectory_smoother
# 5-6 min each).
# Needs root (or sudo) for apt-get and mmdebstrap; Debian 12 (amd64) with network access
# to deb.debian.org. Works in build-aarch64/ (sysroot/ is kept and reused; build/).
#
# The arm64 libraries go into a sysroot made by mmdebstrap, not into the machine's own
# dpkg database (dpkg --add-architecture arm64): on Debian 12 libopencv-imgcodecs-dev:arm64
# (which the tests' synthetic-flight library needs) cannot be installed next to the amd64
# one, and apt would remove the machine's OpenCV dev packages: libopencv-imgcodecs406
# depends on libgdal32 and libopencv-imgcodecs-dev on libgdcm-dev, neither of which is
# Multi-Arch: same.
set -euo pipefail
cd "$(dirname "$0")/.."
src=$PWD
export DEBIAN_FRONTEND=noninteractive

as_root=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "cross-aarch64.sh: needs root (or sudo)" >&2; exit 1; }
  as_root=(sudo)
fi

# Build machine: meson and ninja as for the native build, the cross compiler, qemu-user
# (no binfmt registration: meson calls it as the exe_wrapper), mmdebstrap for the sysroot.
missing=()
for p in meson ninja-build pkg-config g++-aarch64-linux-gnu qemu-user mmdebstrap; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  "${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

top=$src/build-aarch64
sysroot=$top/sysroot
if [[ ! -f $sysroot/.uavstab-complete ]]; then
  "${as_root[@]}" rm -rf "$sysroot"
  mkdir -p "$top"
  start=$(date +%s)
  # extract: unpack the packages and their dependencies, run no maintainer scripts.
  "${as_root[@]}" mmdebstrap --quiet --variant=extract --arch=arm64 \
    --include=libc6-dev,libstdc++-12-dev,libeigen3-dev,libopencv-video-dev,libopencv-imgcodecs-dev,libgtest-dev \
    bookworm "$sysroot" \
    "deb http://deb.debian.org/debian bookworm main" \
    "deb http://deb.debian.org/debian bookworm-updates main" \
    "deb http://deb.debian.org/debian-security bookworm-security main"
  # The links update-alternatives would have made (OpenCV's core needs BLAS and LAPACK).
  lib=$sysroot/usr/lib/aarch64-linux-gnu
  "${as_root[@]}" ln -sf blas/libblas.so.3 "$lib/libblas.so.3"
  "${as_root[@]}" ln -sf lapack/liblapack.so.3 "$lib/liblapack.so.3"
  "${as_root[@]}" touch "$sysroot/.uavstab-complete"
  echo "cross-aarch64.sh: sysroot made in $(( $(date +%s) - start )) s ($(du -sh "$sysroot" | cut -f1))"
fi
printf "[constants]\nsysroot = '%s'\n" "$sysroot" > "$top/sysroot.ini"

start=$(date +%s)
if [[ ! -f $top/build/build.ninja ]]; then
  meson setup "$top/build" --cross-file "$top/sysroot.ini" --cross-file cross/aarch64-linux-gnu.ini \
    -Dgst=disabled -Dtests=enabled -Dbench=disabled
fi
ninja -C "$top/build" -j "$(nproc)"
echo "cross-aarch64.sh: built in $(( $(date +%s) - start )) s"
start=$(date +%s)
# Emulation is several times slower than native: allow the tests more time.
meson test -C "$top/build" --print-errorlogs --num-processes "$(nproc)" --timeout-multiplier 4 "$@"
echo "cross-aarch64.sh: tests under qemu-aarch64 took $(( $(date +%s) - start )) s"
