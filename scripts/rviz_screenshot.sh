#!/usr/bin/env bash
# Headless rviz check: starts Xvfb on a free display and a private ROS master on a free port,
# roslaunches the synthetic demo (nodelet + camera mount + rviz with rviz/pl_slam.rviz),
# plays the demo recording into it, takes a screenshot of the whole screen, and checks that
# rviz (and the nodelet) logged no errors and that the picture is not blank.
#
#   bash scripts/rviz_screenshot.sh [out:=FILE.png] [scene:=room|corridor|fast_turn]
#                                   [frames:=N] [rate:=R] [junit:=FILE.xml]
# Default output: output/rviz/pl_slam_rviz.png (git-ignored), logs in output/rviz/logs/.
# Exit code 0 when the screenshot was taken and passed the checks, 1 otherwise; junit:= also
# writes the verdict as a JUnit report (for catkin's test results).
# Needs a build (scripts/setup.sh) and the packages xvfb, xauth, imagemagick, rviz (installed
# by scripts/install_deps.sh). Takes about a minute.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"

out=""; scene=room; frames=240; rate=1.0; junit=""
for a in "$@"; do
  case "$a" in
    out:=*) out="${a#out:=}" ;;
    scene:=*) scene="${a#scene:=}" ;;
    frames:=*) frames="${a#frames:=}" ;;
    rate:=*) rate="${a#rate:=}" ;;
    junit:=*) junit="${a#junit:=}" ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "rviz_screenshot.sh: unknown argument '$a' (see --help)" >&2; exit 2 ;;
  esac
done

source "${HERE}/env.sh"
BIN="${PL_SLAM_WS}/devel/lib/pl_slam"
for tool in Xvfb import rviz roscore roslaunch; do
  command -v "$tool" >/dev/null || { echo "rviz_screenshot.sh: error: '$tool' not found; run scripts/install_deps.sh" >&2; exit 1; }
done
[ -x "${BIN}/pl_slam_generate" ] || { echo "rviz_screenshot.sh: error: no build in ${PL_SLAM_WS}; run scripts/setup.sh first" >&2; exit 1; }

out="${out:-${PL_SLAM_ROOT}/output/rviz/pl_slam_rviz.png}"
mkdir -p "$(dirname "${out}")"
out="$(cd "$(dirname "${out}")" && pwd)/$(basename "${out}")"
logs="$(dirname "${out}")/logs"
rm -rf "${logs}"; mkdir -p "${logs}"
rm -f "${out}"

# The same recording cache as run_demo.sh.
data="${PL_SLAM_ROOT}/output/demo/${scene}_f${frames}"
if [ ! -f "${data}/recording.bag" ]; then
  echo "[rviz] rendering the synthetic '${scene}' recording (${frames} frames)"
  rm -rf "${data}"
  "${BIN}/pl_slam_generate" --scene "${scene}" --frames "${frames}" \
    --euroc "${data}/euroc" --bag "${data}/recording.bag" > "${logs}/generate.log"
fi

# The verdict as a JUnit report, whatever way the script ends.
verdict="the script stopped before the checks"
write_junit() {
  [ -n "${junit}" ] || return 0
  mkdir -p "$(dirname "${junit}")"
  local failure=""
  [ "${verdict}" = OK ] || failure="<failure message=\"$(echo "${verdict}" | tr -d '<>&"')\"/>"
  printf '<?xml version="1.0" encoding="UTF-8"?>\n<testsuite name="rviz" tests="1" failures="%d" errors="0">\n  <testcase classname="rviz" name="screenshot">%s</testcase>\n</testsuite>\n' \
    "$([ -n "${failure}" ] && echo 1 || echo 0)" "${failure}" > "${junit}"
}

pids=()
cleanup() {
  for ((i=${#pids[@]}-1; i>=0; i--)); do
    kill -INT "${pids[$i]}" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "${pids[$i]}" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "${pids[$i]}" 2>/dev/null || true
  done
}
trap 'cleanup; write_junit' EXIT

# A free X display: no lock file and no socket. Another X server (e.g. in a container or chroot
# sharing the abstract socket namespace) can hold a display without either, so a display where
# Xvfb fails to start is skipped for the next one.
display=""
for n in $(seq 91 199); do
  if [ -e "/tmp/.X${n}-lock" ] || [ -e "/tmp/.X11-unix/X${n}" ]; then continue; fi
  Xvfb ":${n}" -screen 0 1280x800x24 -nolisten tcp > "${logs}/xvfb.log" 2>&1 &
  xvfb_pid=$!
  for _ in $(seq 50); do
    { [ -e "/tmp/.X11-unix/X${n}" ] || ! kill -0 "${xvfb_pid}" 2>/dev/null; } && break
    sleep 0.1
  done
  if kill -0 "${xvfb_pid}" 2>/dev/null && [ -e "/tmp/.X11-unix/X${n}" ]; then
    pids+=("${xvfb_pid}"); display=":${n}"; break
  fi
  kill "${xvfb_pid}" 2>/dev/null || true
  echo "[rviz] Xvfb could not start on :${n}; trying the next display"
done
[ -n "${display}" ] || { echo "rviz_screenshot.sh: error: Xvfb did not start on any display in :91-:199 (see ${logs}/xvfb.log)" >&2; exit 1; }
export DISPLAY="${display}"

port="$(bash "${HERE}/free_port.sh")"
export ROS_MASTER_URI="http://127.0.0.1:${port}"
export ROS_IP=127.0.0.1
export ROS_LOG_DIR="${logs}/ros"
echo "[rviz] Xvfb on ${display}, ROS master on port ${port}; logs in ${logs}"
roscore -p "${port}" > "${logs}/roscore.log" 2>&1 &
pids+=($!)
for _ in $(seq 100); do rosparam get /run_id >/dev/null 2>&1 && break; sleep 0.2; done
rosparam get /run_id >/dev/null 2>&1 || { echo "rviz_screenshot.sh: error: ROS master did not start (see ${logs}/roscore.log)" >&2; exit 1; }

roslaunch pl_slam synthetic_demo.launch rviz:=true > "${logs}/roslaunch.log" 2>&1 &
pids+=($!)
for _ in $(seq 150); do rosservice info /pl_slam/save_trajectory >/dev/null 2>&1 && break; sleep 0.2; done
rosservice info /pl_slam/save_trajectory >/dev/null 2>&1 || { echo "rviz_screenshot.sh: error: the nodelet did not start (see ${logs}/roslaunch.log)" >&2; exit 1; }
# rviz subscribes once its window is up.
for _ in $(seq 150); do rostopic info /pl_slam/path 2>/dev/null | grep -q "/rviz" && break; sleep 0.2; done

echo "[rviz] playing ${data}/recording.bag at rate ${rate}"
rosbag play --quiet --rate "${rate}" "${data}/recording.bag"
sleep 3  # the last frames through the pipeline, and a few rviz redraws

import -display "${display}" -window root "${out}"
rosrun nodelet nodelet unload /pl_slam /pl_slam_manager >/dev/null 2>&1 || true
cleanup; pids=()

# Checks: errors logged by rviz or the nodelet, and a picture that is not blank.
fail=0
errors="$(grep -hE "\[ERROR\]|\[ FATAL\]|\[FATAL\]|Segmentation fault|process has died" \
  "${logs}/roslaunch.log" "${logs}"/ros/*/rviz*.log 2>/dev/null || true)"
if [ -n "${errors}" ]; then
  echo "[rviz] FAIL: errors in the logs:"; echo "${errors}" | head -20; fail=1
  verdict="errors in the logs: $(echo "${errors}" | head -1)"
fi
[ -s "${out}" ] || { echo "[rviz] FAIL: no screenshot written"; verdict="no screenshot"; exit 1; }
# Spread of grey levels over the whole screen, and the share of pixels that differ from the
# rviz background (48,48,48) in the 3D view (left part of the window).
stddev="$(/usr/bin/convert "${out}" -colorspace Gray -format "%[fx:standard_deviation]" info:)"
colours="$(/usr/bin/convert "${out}" -format "%k" info:)"
drawn="$(/usr/bin/convert "${out}" -crop 700x500+300+150 +repage -fill black -fuzz 3% \
  -opaque "rgb(48,48,48)" -fill white +opaque black -format "%[fx:mean]" info:)"
echo "[rviz] screenshot ${out}: grey std ${stddev}, ${colours} colours, 3D view ${drawn} non-background"
if awk -v s="${stddev}" -v c="${colours}" -v d="${drawn}" 'BEGIN { exit !(s < 0.02 || c < 50 || d < 0.01) }'; then
  echo "[rviz] FAIL: the screenshot looks blank"; fail=1
  verdict="blank screenshot (grey std ${stddev}, ${colours} colours, 3D view ${drawn})"
fi
if [ "${fail}" -eq 0 ]; then echo "[rviz] OK"; verdict=OK; fi
exit "${fail}"
