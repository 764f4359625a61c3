#!/usr/bin/env bash
# CI: builds the Debian packages (debian/), installs them, and checks them
# from the system install alone:
#   - gst-inspect-1.0 finds uavstabilize with no GST_PLUGIN_PATH, and a pipeline runs;
#   - a program built with $(pkg-config --cflags --libs uavstab) stabilizes a few frames.
# Then removes them again. GStreamer knows a plugin by its file name and keeps the first
# one its scan meets; GST_PLUGIN_PATH is scanned before the system directory, so the tests'
# build-tree plugin would still win, but anything run without GST_PLUGIN_PATH (samples,
# a test checking the plugin's absence, a stale registry) would get the system copy.
#   bash .ci/package.sh [out_dir]       out_dir: where to keep the .debs (default: only in a
#                                       temp dir, deleted at exit)
#   bash .ci/package.sh --reuse dir     skip the build, check the .debs a run left in dir
# Needs root (or sudo) for apt-get; Debian 12.
set -euo pipefail
cd "$(dirname "$0")/.."
src=$PWD
export DEBIAN_FRONTEND=noninteractive

as_root=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "package.sh: needs root (or sudo)" >&2; exit 1; }
  as_root=(sudo)
fi

work=$(mktemp -d)
installed=0
cleanup() {
  if [[ $installed == 1 ]]; then
    "${as_root[@]}" apt-get remove -y -qq gstreamer1.0-uavstabilize libuavstab-dev >/dev/null || true
  fi
  rm -rf "$work"
}
trap cleanup EXIT

# Build tools and the Build-Depends of debian/control.
"${as_root[@]}" apt-get install -y -qq --no-install-recommends \
  dpkg-dev debhelper fakeroot build-essential gstreamer1.0-tools gstreamer1.0-plugins-base >/dev/null
"${as_root[@]}" apt-get build-dep -y -qq "$src" >/dev/null

reuse=""
if [[ ${1:-} == --reuse ]]; then
  reuse=${2:?package.sh: --reuse needs a directory}
  shift 2
fi

if [[ -n $reuse ]]; then
  cp "$reuse"/gstreamer1.0-uavstabilize_*.deb "$reuse"/libuavstab-dev_*.deb "$work"/
else
  # Build in a copy: dpkg-buildpackage writes its results into the parent directory, and
  # this keeps the clone (and its parent) clean. Only tracked files plus the working
  # copy's changes go in (git ls-files), never a build directory.
  mkdir "$work/uavstabilize"
  if git -C "$src" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    (cd "$src" && git ls-files -z --cached --others --exclude-standard \
       | while IFS= read -r -d '' f; do if [[ -e $f ]]; then printf '%s\0' "$f"; fi; done \
       | xargs -0 cp --parents -t "$work/uavstabilize")
  else
    tar -C "$src" --exclude='./build*' --exclude=./.git -cf - . | tar -C "$work/uavstabilize" -xf -
  fi
  start=$(date +%s)
  # noddebs: no -dbgsym package (not checked here, and it saves time).
  (cd "$work/uavstabilize" && DEB_BUILD_OPTIONS="noddebs ${DEB_BUILD_OPTIONS:-}" \
     dpkg-buildpackage -us -uc -b -j"$(nproc)") > "$work/build.log" 2>&1 || {
    tail -n 60 "$work/build.log" >&2
    echo "package.sh: dpkg-buildpackage failed" >&2
    exit 1
  }
  echo "package.sh: dpkg-buildpackage took $(( $(date +%s) - start )) s"
fi
plugin_deb=$(ls "$work"/gstreamer1.0-uavstabilize_*.deb)
dev_deb=$(ls "$work"/libuavstab-dev_*.deb)
debs=("$plugin_deb" "$dev_deb")
for d in "${debs[@]}"; do
  echo "  $(basename "$d")"
  dpkg-deb -c "$d" | awk '$1 !~ /^d/ {print "    " $6}'
done
if [[ $# -ge 1 ]]; then
  mkdir -p "$1"
  cp "${debs[@]}" "$1"/
fi

# The plugin must land in GStreamer's own plugin directory.
pluginsdir=$(pkg-config --variable=pluginsdir gstreamer-1.0)
plugin_files=$(dpkg-deb -c "$plugin_deb")
grep -q " \.${pluginsdir}/libgstuavstabilize\.so$" <<<"$plugin_files" || {
  echo "package.sh: the plugin is not in $pluginsdir" >&2
  exit 1
}

installed=1
"${as_root[@]}" apt-get install -y -qq --no-install-recommends "$plugin_deb" "$dev_deb" >/dev/null

# Checks against the system install only: no build tree plugin path, a fresh registry.
unset GST_PLUGIN_PATH GST_PLUGIN_PATH_1_0
export GST_REGISTRY="$work/registry.bin"
gst-inspect-1.0 uavstabilize > "$work/inspect.txt"
# (GStreamer may report it through /lib, the merged-/usr symlink: compare real paths.)
loaded=$(awk '$1 == "Filename" {print $2; exit}' "$work/inspect.txt")
[[ -n $loaded && $(readlink -f "$loaded") == $(readlink -f "$pluginsdir/libgstuavstabilize.so") ]] || {
  cat "$work/inspect.txt" >&2
  echo "package.sh: gst-inspect-1.0 did not load the installed plugin" >&2
  exit 1
}
echo "package.sh: gst-inspect-1.0 uavstabilize: loaded $loaded"
gst-launch-1.0 -q videotestsrc num-buffers=60 pattern=ball ! video/x-raw,width=320,height=240 \
  ! uavstabilize ! fakesink
echo "package.sh: pipeline with the installed plugin ran"

# The README's library example, built against the installed library alone; every
# installed header compiles on its own; the metadata header compiles with GStreamer alone.
python3 - README.md "$work/app.cpp" <<'PY'
import re, sys
example = re.search(r"```cpp\n(// The smallest embedding.*?)```", open(sys.argv[1]).read(), re.S)
if not example:
    sys.exit("package.sh: README.md has no library example (a cpp block starting '// The smallest embedding')")
open(sys.argv[2], "w").write(example.group(1))
PY
# shellcheck disable=SC2046
c++ -std=c++17 -Wall -Wextra -Werror -o "$work/app" "$work/app.cpp" $(pkg-config --cflags --libs uavstab)
echo "package.sh: README's library example: $("$work/app")"
headers=0
for header in /usr/include/uavstab/*.hpp; do
  # shellcheck disable=SC2046
  echo "#include <uavstab/$(basename "$header")>" | c++ -std=c++17 -fsyntax-only -x c++ - $(pkg-config --cflags uavstab)
  headers=$((headers + 1))
done
printf '#include <uavstabilize/uavstab_meta.h>\nint main(void) { return GST_UAV_STAB_META_API_TYPE == 0; }\n' >"$work/meta.c"
# shellcheck disable=SC2046
cc -o "$work/meta" "$work/meta.c" $(pkg-config --cflags --libs gstreamer-1.0)
echo "package.sh: $headers installed headers compile alone; the metadata header builds"

"${as_root[@]}" apt-get remove -y -qq gstreamer1.0-uavstabilize libuavstab-dev >/dev/null
installed=0
if [[ -e "$pluginsdir/libgstuavstabilize.so" ]]; then
  echo "package.sh: the plugin is still in $pluginsdir after removal" >&2
  exit 1
fi
echo "package.sh: OK (packages built, installed, checked and removed)"
