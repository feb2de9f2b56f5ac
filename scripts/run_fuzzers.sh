#!/usr/bin/env bash
# libFuzzer run (issue "Reliability"): builds the fuzz targets of fuzz/ with clang
# (coverage + AddressSanitizer + UndefinedBehaviorSanitizer) in a git-ignored workspace
# (.ws_fuzz) and runs each for a bounded time, starting from the committed inputs in
# fuzz/corpus/<target>/ plus the package's own config files. Fails when a target finds a
# crash, a sanitizer report, a leak or an undocumented exception; the reproducer is left in
# .ws_fuzz/findings/<target>/ (copy it into fuzz/corpus/<target>/ once fixed: the test command
# replays that folder in test_fuzz_regressions).
#
#   bash scripts/run_fuzzers.sh [seconds:=N] [targets:=config,map_loader,calibration,trajectory]
# N seconds per target (default 300). Needs scripts/install_deps.sh fuzz (clang).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
seconds=300
targets="config,map_loader,calibration,trajectory"
for a in "$@"; do
  case "$a" in
    seconds:=*) seconds="${a#seconds:=}" ;;
    targets:=*) targets="${a#targets:=}" ;;
    *) echo "run_fuzzers.sh: unknown argument '$a'" >&2; exit 2 ;;
  esac
done
[[ "${seconds}" =~ ^[0-9]+$ ]] || { echo "run_fuzzers.sh: seconds:=${seconds} must be a whole number" >&2; exit 2; }
bash "${HERE}/install_deps.sh" fuzz
export PL_SLAM_WS="$(cd "${HERE}/.." && pwd)/.ws_fuzz"
source "${HERE}/env.sh"
mkdir -p "${PL_SLAM_WS}/src" "${ROS_LOG_DIR}"
[ -e "${PL_SLAM_WS}/src/pl_slam" ] || ln -s "${PL_SLAM_ROOT}" "${PL_SLAM_WS}/src/pl_slam"
IFS=',' read -r -a names <<< "${targets}"
cd "${PL_SLAM_WS}"
catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DPL_SLAM_FUZZ=ON \
  -j"${PL_SLAM_JOBS:-$(nproc)}" "${names[@]/#/fuzz_}" > "${PL_SLAM_WS}/build.log" 2>&1 || {
  tail -30 "${PL_SLAM_WS}/build.log"; echo "run_fuzzers.sh: build failed" >&2; exit 1; }

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
BIN="${PL_SLAM_WS}/devel/lib/pl_slam"
failed=()
for t in "${names[@]}"; do
  corpus="${PL_SLAM_WS}/corpus/${t}"     # grows run after run; seeds are copied in each time
  findings="${PL_SLAM_WS}/findings/${t}"
  mkdir -p "${corpus}" "${findings}"
  cp "${PL_SLAM_ROOT}/fuzz/corpus/${t}/"* "${corpus}/"
  [ "${t}" = config ] && cp "${PL_SLAM_ROOT}"/config/*.yaml "${corpus}/"
  echo "[fuzz] ${t}: ${seconds} s from $(ls "${corpus}" | wc -l) inputs"
  log="${PL_SLAM_WS}/fuzz_${t}.log"
  # -rss_limit_mb: the loaders must bound their allocations by the input size.
  if "${BIN}/fuzz_${t}" -max_total_time="${seconds}" -rss_limit_mb=2048 -max_len=65536 \
      -timeout=10 -print_final_stats=1 -artifact_prefix="${findings}/" "${corpus}" \
      > "${log}" 2>&1; then
    echo "[fuzz] ${t}: clean ($(grep -Eo 'stat::number_of_executed_units: *[0-9]+' "${log}" | grep -Eo '[0-9]+$' || echo '?') runs, corpus $(ls "${corpus}" | wc -l))"
  else
    failed+=("${t}")
    grep -E "ERROR|SUMMARY|runtime error|Test unit written" "${log}" | head -5
  fi
done
if [ "${#failed[@]}" -gt 0 ]; then
  echo "run_fuzzers.sh: FAILED: ${failed[*]} (reproducers in ${PL_SLAM_WS}/findings, logs in ${PL_SLAM_WS}/fuzz_*.log)"
  exit 1
fi
echo "run_fuzzers.sh: clean: ${names[*]}, ${seconds} s each"
