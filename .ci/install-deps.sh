#!/usr/bin/env bash
# Installs the Debian 12 packages the project needs, only those missing.
#   .ci/install-deps.sh [build] [test] [demo] [fuzz] [bench]   (default: build test)
# Runs apt-get as root (directly, or through sudo when available).
set -euo pipefail

build=(meson ninja-build pkg-config g++ libeigen3-dev
       libopencv-video-dev libopencv-imgcodecs-dev
       libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev
       gstreamer1.0-tools gstreamer1.0-plugins-base)
test=(libgtest-dev gstreamer1.0-plugins-good gstreamer1.0-plugins-bad gstreamer1.0-plugins-ugly
      libgstrtspserver-1.0-dev gstreamer1.0-rtsp gstreamer1.0-libav  # libav: the RTSP test decodes its recording
      gstreamer1.0-plugins-base-apps  # gst-discoverer-1.0: samples/ts_klv_stabilize.sh (element_klv test)
      # element_gl_render: GStreamer's GL elements on Mesa's software OpenGL, in an Xvfb
      gstreamer1.0-gl libegl-mesa0 libgl1-mesa-dri libglx-mesa0 xvfb xauth)
demo=(gstreamer1.0-plugins-base-apps gstreamer1.0-plugins-good gstreamer1.0-plugins-bad gstreamer1.0-plugins-ugly gstreamer1.0-libav
      gstreamer1.0-x fonts-dejavu-core)  # textoverlay: the side-by-side's labels
fuzz=(clang libclang-rt-14-dev)
bench=(ffmpeg libopencv-features2d-dev libopencv-calib3d-dev gstreamer1.0-libav time
       linux-perf valgrind)  # tests/bench/profile.sh: perf record, callgrind where perf cannot sample

groups=("$@")
[[ ${#groups[@]} -gt 0 ]] || groups=(build test)
wanted=("${build[@]}")
for g in "${groups[@]}"; do
  case "$g" in
    build) ;;
    test) wanted+=("${test[@]}") ;;
    demo) wanted+=("${demo[@]}") ;;
    fuzz) wanted+=("${fuzz[@]}") ;;
    bench) wanted+=("${bench[@]}") ;;
    *) echo "install-deps: unknown group $g" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

as_root=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  as_root=(sudo)
fi
echo "install-deps: installing ${missing[*]}"
"${as_root[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
