#!/usr/bin/env bash
# Installs every system package pl_slam needs, from Debian's own archive only.
# Idempotent: packages already present are not reinstalled, and apt-get update only
# runs when something is missing. Needs root (or sudo) on Debian 12.
set -euo pipefail
export PATH="/usr/sbin:/usr/bin:/sbin:/bin:${PATH}"
export DEBIAN_FRONTEND=noninteractive

PKGS=(
  build-essential cmake git pkg-config clang-format
  catkin python3-catkin-pkg ros-base-dev ros-base-python-dev rosbash
  ros-message-generation ros-message-runtime
  libnodelet-dev libnodeletlib-dev libnodeletlib-tools pluginlib-dev librosbag-dev python3-rosbag python3-rostest
  libmessage-filters-dev libimage-transport-dev libcv-bridge-dev python3-cv-bridge
  libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev python3-tf2-ros
  libstd-srvs-dev libnav-msgs-dev libvisualization-msgs-dev libgeometry-msgs-dev
  libdiagnostic-updater-dev
  libsensor-msgs-dev libroslib-dev libros-rosgraph-msgs-dev
  libgtest-dev googletest libgmock-dev
  libopencv-dev libopencv-contrib-dev libeigen3-dev libceres-dev libsuitesparse-dev
  libtbb-dev libyaml-cpp-dev libbenchmark-dev
  rviz librviz-dev xvfb xauth imagemagick
)
# Optional groups: "fuzz" adds clang with its libFuzzer runtime (scripts/run_fuzzers.sh);
# "profile" adds heaptrack (scripts/heap_growth.sh).
for group in "$@"; do
  case "${group}" in
    fuzz) PKGS+=(clang libclang-rt-14-dev) ;;
    profile) PKGS+=(heaptrack) ;;
    *) echo "[pl_slam] install_deps.sh: unknown group '${group}' (known: fuzz, profile)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

SUDO=""
if [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null; then SUDO="sudo"; fi

# roslaunch resolves 'localhost'; minimal containers may lack it.
if ! grep -qE '^\s*127\.0\.0\.1\s.*\blocalhost\b' /etc/hosts 2>/dev/null; then
  echo "127.0.0.1 localhost" | $SUDO tee -a /etc/hosts >/dev/null || \
    echo "[pl_slam] warning: /etc/hosts has no localhost entry and cannot be fixed" >&2
fi

if [ "${#missing[@]}" -eq 0 ]; then
  echo "[pl_slam] all ${#PKGS[@]} system packages present"
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  if [ -z "$SUDO" ]; then
    echo "[pl_slam] error: missing packages (${missing[*]}) and not root; rerun as root" >&2
    exit 1
  fi
fi
echo "[pl_slam] installing ${#missing[@]} missing packages: ${missing[*]}"
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"

