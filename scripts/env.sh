# Sourced by the project's scripts: a PATH and environment that do not depend on what the
# caller inherited (pyenv's python3 lacks the ROS modules; ROS tools need Debian's).
PL_SLAM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PL_SLAM_WS="${PL_SLAM_WS:-${PL_SLAM_ROOT}/.ws}"
export PATH="/usr/sbin:/usr/bin:/sbin:/bin:${PATH}"
unset PYTHONHOME PYENV_VERSION
export PYTHONNOUSERSITE=1
export ROS_PYTHON_VERSION=3
export ROS_HOME="${ROS_HOME:-${PL_SLAM_WS}/ros_home}"
export ROS_LOG_DIR="${ROS_LOG_DIR:-${ROS_HOME}/log}"
# The project's scripts run every ROS process on this machine: advertise on loopback unless
# the user chose otherwise, so a hostname missing from /etc/hosts (containers, chroots) cannot
# break roslaunch ("Unable to contact my own server").
if [ -z "${ROS_IP:-}" ] && [ -z "${ROS_HOSTNAME:-}" ]; then export ROS_IP=127.0.0.1; fi
if [ -f "${PL_SLAM_WS}/devel/setup.bash" ]; then
  # shellcheck disable=SC1091
  set +u; source "${PL_SLAM_WS}/devel/setup.bash"; set -u 2>/dev/null || true
fi
