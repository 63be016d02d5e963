#!/usr/bin/env bash
# Installs what a fresh machine of this project's kind (Debian, Rust 1.95, root) lacks.
# Idempotent: installs only the packages that are missing. Sourced by the other scripts.
set -euo pipefail

# System packages:
#   pkg-config, libudev-dev  gilrs (gamepads) builds against libudev
#   xvfb, xauth              the real-window GUI test runs the station under a virtual display
#   mesa-vulkan-drivers, libvulkan1  a CPU Vulkan adapter (lavapipe) for wgpu/egui_kittest
#   libgstreamer1.0-dev, libgstreamer-plugins-base1.0-dev
#                            rov_video (camera video) builds against GStreamer core, app,
#                            video and pbutils through gstreamer-rs
#   gstreamer1.0-plugins-base  videotestsrc, videoconvert/scale, appsrc/appsink, the
#                            text and clock overlays, playbin/uridecodebin
#   gstreamer1.0-plugins-good  v4l2src (USB frame grabbers), RTSP, RTP/UDP, mp4mux
#   gstreamer1.0-plugins-bad   h264parse (access units, SPS/PPS with every key frame)
#   gstreamer1.0-plugins-ugly  x264enc (the H.264 encoder of recordings and exports)
#   gstreamer1.0-libav         avdec_h264 (decoding for replay and network sources)
#   gstreamer1.0-tools         gst-launch-1.0 / gst-inspect-1.0 (source tests, diagnosis)
#   ffmpeg                     ffprobe: tests check that an exported MP4 plays
APT_PACKAGES=(pkg-config libudev-dev xvfb xauth mesa-vulkan-drivers libvulkan1
  libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev gstreamer1.0-plugins-base
  gstreamer1.0-plugins-good gstreamer1.0-plugins-bad gstreamer1.0-plugins-ugly
  gstreamer1.0-libav gstreamer1.0-tools ffmpeg)

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# Python's official `mcap` reader proves our session files open in other tools;
# mcap-protobuf-support (with `protobuf`) decodes the Foxglove schemas (pose, video) with
# the descriptors stored in the files.
if ! python3 -c "import mcap, mcap_protobuf" 2>/dev/null; then
  echo "setup: installing the Python mcap reader and its protobuf decoder"
  python3 -m pip install --quiet --disable-pip-version-check "mcap>=1.1" "mcap-protobuf-support>=0.5" \
    || echo "setup: warning: pip could not install mcap / mcap-protobuf-support"
fi
