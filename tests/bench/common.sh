# shellcheck shell=bash disable=SC2034,SC2154
# Shell helpers of the benchmark's scripts (ab.sh, streams.sh, profile.sh); sourced, not run.
#
#   source "$(dirname "$0")/common.sh"   # needs bench_repo (the repository's top directory) set
#
# bench_build_base REV BUILDDIR
#   Builds REV's plugin in BUILDDIR/ab/SHA (a detached git worktree of REV in BUILDDIR/ab/SHA/src,
#   built in src/build; kept for the next time) and sets base_sha (REV's short hash) and
#   base_plugin_dir (the directory holding REV's libgstuavstabilize.so).
# bench_check_plugin PLUGIN_DIR
#   Makes PLUGIN_DIR's GStreamer registry (PLUGIN_DIR/../gst-registry.bin: the system's plugins
#   and PLUGIN_DIR's uavstabilize) and fails (returns 1, with a message) unless uavstabilize
#   comes from PLUGIN_DIR. Call it once per build (after building) before bench_with_plugin.
# bench_with_plugin PLUGIN_DIR COMMAND [ARG]...
#   Runs COMMAND with that registry and no registry update (GST_REGISTRY_UPDATE=no), so that
#   GStreamer loads PLUGIN_DIR's uavstabilize and no other build's: not the one the benchmark
#   programs add to GST_PLUGIN_PATH themselves (the first directory listed with a plugin of
#   that file name wins a scan), nor one from other work on the machine sharing
#   ~/.cache/gstreamer-1.0.
# bench_raw_clip W H FRAMES DIR RENDER
#   Prints the path of raw I420 frames of the synthetic shaky flight at WxH (FRAMES frames),
#   made once in DIR with RENDER (build/tests/synthetic/uavstab-render-flight) and ffmpeg.
# bench_commit_label
#   This tree's short hash, with ", with uncommitted changes" when it has some.

bench_build_base() {  # REV BUILDDIR
  local rev=$1 builddir=$2 src
  base_sha=$(git -C "$bench_repo" rev-parse --short "$rev^{commit}")
  src=$builddir/ab/$base_sha/src
  if [[ ! -d $src ]]; then
    mkdir -p "$builddir/ab/$base_sha"
    git -C "$bench_repo" worktree add --detach "$src" "$base_sha" >/dev/null 2>&1 ||
      git -C "$bench_repo" worktree add -f --detach "$src" "$base_sha" >/dev/null
  fi
  [[ -f $src/build/build.ninja ]] || meson setup "$src/build" "$src" -Dtests=disabled >/dev/null
  ninja -C "$src/build" -j 2 gst/libgstuavstabilize.so >/dev/null
  base_plugin_dir=$src/build/gst
}

bench_with_plugin() {  # PLUGIN_DIR COMMAND [ARG]...
  GST_PLUGIN_PATH=$1 GST_REGISTRY=$(dirname "$1")/gst-registry.bin GST_REGISTRY_UPDATE=no "${@:2}"
}

bench_check_plugin() {  # PLUGIN_DIR
  local file
  file=$(GST_PLUGIN_PATH=$1 GST_REGISTRY=$(dirname "$1")/gst-registry.bin gst-inspect-1.0 uavstabilize 2>/dev/null |
         awk '/^ *Filename/ {print $2}')
  if [[ $file != "$1"/* ]]; then
    echo "uavstabilize not loaded from $1 (got: ${file:-nothing})" >&2
    return 1
  fi
}

bench_raw_clip() {  # W H FRAMES DIR RENDER
  local f=$4/$1x$2-$3.yuv
  if [[ ! -f $f ]]; then
    "$5" "$4/flight.y4m" --width "$1" --height "$2" --frames "$3" >/dev/null
    ffmpeg -loglevel error -y -i "$4/flight.y4m" -f rawvideo "$f"
    rm -f "$4/flight.y4m"
  fi
  echo "$f"
}

bench_commit_label() {
  echo "$(git -C "$bench_repo" rev-parse --short HEAD)$(git -C "$bench_repo" status --porcelain --untracked-files=no | grep -q . && echo ', with uncommitted changes')"
}
