#!/usr/bin/env bash
# Sanitizer run (issue "Reliability"): builds the core tests and the offline runner with
# AddressSanitizer + UndefinedBehaviorSanitizer (address) or ThreadSanitizer (thread) in a
# git-ignored workspace (.ws_asan / .ws_tsan), runs the core gtest binaries and a synthetic
# sequence through the threaded pipeline (local mapping + loop closing threads), and fails on
# any report. Suppressions: scripts/tsan.supp (thread only), each entry with its reason.
#
#   bash scripts/run_sanitizers.sh address|thread [frames:=N] [tests:=test_a,test_b]
# tests:= runs only those core test binaries (a quick re-check after a change; the pipeline
# run always follows).
# Needs the packages of scripts/install_deps.sh. Takes 20-40 min on 2 cores (the build).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
kind="${1:-}"; shift || true
frames=240
only=""
for a in "$@"; do
  case "$a" in
    frames:=*) frames="${a#frames:=}" ;;
    tests:=*) only="${a#tests:=}" ;;
    *) echo "run_sanitizers.sh: unknown argument '$a'" >&2; exit 2 ;;
  esac
done
case "${kind}" in
  address) ws_name=.ws_asan ;;
  thread) ws_name=.ws_tsan ;;
  *) echo "usage: run_sanitizers.sh address|thread [frames:=N]" >&2; exit 2 ;;
esac
bash "${HERE}/install_deps.sh"
export PL_SLAM_WS="$(cd "${HERE}/.." && pwd)/${ws_name}"
source "${HERE}/env.sh"
mkdir -p "${PL_SLAM_WS}/src" "${ROS_LOG_DIR}"
[ -e "${PL_SLAM_WS}/src/pl_slam" ] || ln -s "${PL_SLAM_ROOT}" "${PL_SLAM_WS}/src/pl_slam"
core_tests=(test_geometry test_camera test_io test_eval test_sim test_util test_features
            test_matching test_tracking test_map test_optimization test_mapping test_loop
            test_system)
if [ -n "${only}" ]; then
  IFS=, read -r -a picked <<< "${only}"
  for t in "${picked[@]}"; do
    [[ " ${core_tests[*]} " == *" ${t} "* ]] ||
      { echo "run_sanitizers.sh: tests:= ${t} is not a core test (${core_tests[*]})" >&2; exit 2; }
  done
  core_tests=("${picked[@]}")
fi
cd "${PL_SLAM_WS}"
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCATKIN_ENABLE_TESTING=ON -DPL_SLAM_SANITIZE="${kind}" -j"${PL_SLAM_JOBS:-$(nproc)}" \
  "${core_tests[@]}" pl_slam_offline pl_slam_generate > "${PL_SLAM_WS}/build.log" 2>&1 || {
  tail -30 "${PL_SLAM_WS}/build.log"; echo "run_sanitizers.sh: build failed" >&2; exit 1; }

export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=${HERE}/tsan.supp"
# Thread builds run OpenCV's parallel_for_ sequentially (src/util/sanitizer_setup.cpp), and
# OpenMP (used by SuiteSparse's CHOLMOD inside Ceres) with one thread: both pools synchronise
# inside uninstrumented libraries (libtbb, libgomp), where TSan cannot see, so their workers'
# accesses read as races on memory the caller handed them.
if [ "${kind}" = thread ]; then export OMP_NUM_THREADS=1; fi
BIN="${PL_SLAM_WS}/devel/lib/pl_slam"
logs="${PL_SLAM_WS}/sanitizer_logs"; rm -rf "${logs}"; mkdir -p "${logs}"
failed=()
cd "${PL_SLAM_ROOT}"  # tests read ../shared/datasets relative to the repository
for t in "${core_tests[@]}"; do
  echo "[${kind}] ${t}"
  if ! "${BIN}/${t}" > "${logs}/${t}.log" 2>&1; then failed+=("${t}"); tail -20 "${logs}/${t}.log"; fi
done
data="${PL_SLAM_WS}/room_${frames}"
if [ ! -f "${data}/.complete" ]; then
  rm -rf "${data}"
  if ! "${BIN}/pl_slam_generate" --scene room --frames "${frames}" --euroc "${data}" \
      > "${logs}/generate.log" 2>&1; then
    rm -rf "${data}"
    echo "run_sanitizers.sh (${kind}): rendering the sequence failed:"; tail -20 "${logs}/generate.log"
    exit 1
  fi
  touch "${data}/.complete"
fi
echo "[${kind}] threaded pipeline on ${frames} synthetic frames"
if ! "${BIN}/pl_slam_offline" "${data}" --out "${logs}/run" --quiet > "${logs}/pipeline.log" 2>&1; then
  failed+=("pipeline"); tail -30 "${logs}/pipeline.log"
fi
if grep -lE "ERROR: (AddressSanitizer|LeakSanitizer|ThreadSanitizer)|WARNING: ThreadSanitizer|runtime error:" \
    "${logs}"/*.log > /dev/null 2>&1; then
  failed+=("reports: $(grep -lE "Sanitizer|runtime error:" "${logs}"/*.log | xargs -n1 basename | tr '\n' ' ')")
fi
if [ "${#failed[@]}" -gt 0 ]; then
  echo "run_sanitizers.sh (${kind}): FAILED: ${failed[*]} (logs in ${logs})"; exit 1
fi
echo "run_sanitizers.sh (${kind}): clean: ${#core_tests[@]} test binaries and the threaded pipeline (logs in ${logs})"
