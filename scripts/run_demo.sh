#!/usr/bin/env bash
# The main job on its embedded default: installs what is missing, builds, renders the
# synthetic demo recording (a rosbag + EuRoC folder with ground truth), starts a private ROS
# master on a free port, roslaunches the pl_slam nodelet against `rosbag play` of the
# recording, saves the trajectory through the nodelet's service, and prints its accuracy
# against ground truth with a plot.
#
#   bash scripts/run_demo.sh [rviz:=true|false] [scene:=room|corridor|fast_turn]
#                            [frames:=N] [out:=DIR] [rate:=R]
# rviz opens when a display is available ($DISPLAY) unless rviz:=false.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"

rviz=auto; scene=room; frames=0; rate=1.0; out=""
for a in "$@"; do
  case "$a" in
    rviz:=*) rviz="${a#rviz:=}" ;;
    scene:=*) scene="${a#scene:=}" ;;
    frames:=*) frames="${a#frames:=}" ;;
    rate:=*) rate="${a#rate:=}" ;;
    out:=*) out="${a#out:=}" ;;
    -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
    *) echo "run_demo.sh: unknown argument '$a' (see --help)" >&2; exit 2 ;;
  esac
done
[ "$rviz" = auto ] && { [ -n "${DISPLAY:-}" ] && rviz=true || rviz=false; }

bash "${HERE}/setup.sh"
source "${HERE}/env.sh"
out="${out:-${PL_SLAM_ROOT}/output/demo}"
mkdir -p "${out}"
out="$(cd "${out}" && pwd)"
BIN="${PL_SLAM_WS}/devel/lib/pl_slam"

data="${out}/${scene}_f${frames}"
if [ ! -f "${data}/recording.bag" ]; then
  echo "[demo] rendering the synthetic '${scene}' recording"
  rm -rf "${data}"
  "${BIN}/pl_slam_generate" --scene "${scene}" --frames "${frames}" \
    --euroc "${data}/euroc" --bag "${data}/recording.bag"
fi

pids=()
cleanup() {
  for ((i=${#pids[@]}-1; i>=0; i--)); do
    kill -INT "${pids[$i]}" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "${pids[$i]}" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "${pids[$i]}" 2>/dev/null || true
  done
}
trap cleanup EXIT

port="$(bash "${HERE}/free_port.sh")"
export ROS_MASTER_URI="http://127.0.0.1:${port}"
export ROS_IP=127.0.0.1
echo "[demo] ROS master on port ${port}; logs in ${out}/logs"
mkdir -p "${out}/logs"
roscore -p "${port}" > "${out}/logs/roscore.log" 2>&1 &
pids+=($!)
for _ in $(seq 100); do rosparam get /run_id >/dev/null 2>&1 && break; sleep 0.2; done
rosparam get /run_id >/dev/null 2>&1 || { echo "[demo] error: ROS master did not start (see ${out}/logs/roscore.log)" >&2; exit 1; }

roslaunch pl_slam synthetic_demo.launch rviz:="${rviz}" > "${out}/logs/roslaunch.log" 2>&1 &
pids+=($!)
for _ in $(seq 150); do rosservice info /pl_slam/save_trajectory >/dev/null 2>&1 && break; sleep 0.2; done
rosservice info /pl_slam/save_trajectory >/dev/null 2>&1 || { echo "[demo] error: the nodelet did not start (see ${out}/logs/roslaunch.log)" >&2; exit 1; }

echo "[demo] playing ${data}/recording.bag at rate ${rate}"
rosbag play --quiet --rate "${rate}" "${data}/recording.bag"
sleep 1.5  # let the last frames through the pipeline

traj="${out}/trajectory_${scene}.tum"
rosservice call /pl_slam/save_trajectory "{path: '${traj}', format: 'tum'}"

# Unload the nodelet before the manager stops (a loaded nodelet can crash a dying manager).
rosrun nodelet nodelet unload /pl_slam /pl_slam_manager >/dev/null 2>&1 || true
cleanup; pids=()

echo "[demo] accuracy of the nodelet's trajectory against ground truth:"
"${BIN}/pl_slam_evaluate" --est "${traj}" \
  --gt "${data}/euroc/mav0/state_groundtruth_estimate0/data.csv" \
  --align se3 --plot "${out}/trajectory_${scene}.png" --name "synthetic ${scene} (ROS demo)"
echo "[demo] trajectory: ${traj}"
echo "[demo] plot:       ${out}/trajectory_${scene}.png"
