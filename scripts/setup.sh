#!/usr/bin/env bash
# Installs the system dependencies (Debian packages) and builds pl_slam in a git-ignored
# catkin workspace at .ws/. Safe to run again: it only installs what is missing and catkin
# rebuilds only what changed.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
bash "${HERE}/install_deps.sh"
source "${HERE}/env.sh"

mkdir -p "${PL_SLAM_WS}/src" "${ROS_LOG_DIR}"
link="${PL_SLAM_WS}/src/pl_slam"
if [ ! -e "${link}" ]; then ln -s "${PL_SLAM_ROOT}" "${link}"; fi

cd "${PL_SLAM_WS}"
JOBS="${PL_SLAM_JOBS:-$(nproc)}"
echo "[pl_slam] building in ${PL_SLAM_WS} with ${JOBS} jobs"
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release \
  -DCATKIN_ENABLE_TESTING=ON -j"${JOBS}" "$@"
