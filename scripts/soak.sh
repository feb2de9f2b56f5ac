#!/usr/bin/env bash
# Soak run (issue "Reliability"): at least 10,000 frames of the rendered room, looped 21 times,
# through the threaded pipeline (tracking, local mapping and loop closing threads, frames fed
# as fast as tracking takes them). A watchdog fails the run when one frame takes more than
# 5 s (deadlock or stall); resident memory, map size and the mapping queue are logged every
# 500 frames and judged by scripts/soak_report.py (plateau, bounded queue, full coverage).
#
#   bash scripts/soak.sh [loops:=21] [out:=DIR] [extra pl_slam_offline options...]
# The sequence (4.2 GB of PNGs) is rendered once into output/soak/ (git-ignored); about
# 15 min to render and 10-15 min to run on 2 cores. Needs a built workspace (scripts/setup.sh).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
loops=21
out_arg=""
extra=()
for a in "$@"; do
  case "$a" in
    loops:=*) loops="${a#loops:=}" ;;
    out:=*) out_arg="${a#out:=}" ;;
    *) extra+=("$a") ;;
  esac
done
source "${HERE}/env.sh"
BIN="${PL_SLAM_WS}/devel/lib/pl_slam"
[ -x "${BIN}/pl_slam_offline" ] || { echo "soak.sh: ${BIN}/pl_slam_offline missing; run scripts/setup.sh first" >&2; exit 1; }
data="${PL_SLAM_ROOT}/output/soak/room_x${loops}"
out="${out_arg:-${PL_SLAM_ROOT}/output/soak/run_x${loops}}"
if [ ! -f "${data}/.complete" ]; then
  echo "[soak] rendering room x${loops} into ${data}"
  rm -rf "${data}"
  "${BIN}/pl_slam_generate" --scene room --loops "${loops}" --euroc "${data}" > "${data}.log" 2>&1
  touch "${data}/.complete"
fi
rm -rf "${out}"
echo "[soak] running: pl_slam_offline ${data} --watchdog 5 --memory-every 500 ${extra[*]}"
start=$(date +%s)
"${BIN}/pl_slam_offline" "${data}" --out "${out}" --quiet --watchdog 5 --memory-every 500 \
  "${extra[@]}" > "${out}.log" 2>&1 || { rc=$?; tail -5 "${out}.log"; echo "soak.sh: pl_slam_offline failed (exit ${rc}; 3 = watchdog)" >&2; exit 1; }
echo "[soak] finished in $(( $(date +%s) - start )) s"
grep -E "^(frames|map|loops):" "${out}.log"
/usr/bin/python3 "${HERE}/soak_report.py" "${out}"
