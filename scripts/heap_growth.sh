#!/usr/bin/env bash
# Where does held memory grow? Runs pl_slam_offline (sequential mapping) under heaptrack twice
# on the same rendered sequence and kills each run with SIGKILL once it has processed EARLY
# and LATE frames respectively, so nothing is freed and heaptrack's "leaked" bytes are what
# the process held at that moment. scripts/heap_growth_diff.py then prints the call stacks
# whose held bytes changed most between the two. Once the map has stopped growing (after the
# first lap of the room), every site that still grows is a leak or an unbounded record.
#
#   bash scripts/heap_growth.sh [early:=960] [late:=2640] [out:=DIR] [loops:=6] [data:=DIR]
# data:= reuses a rendered room folder (e.g. output/bench/data/room_x6 of the benchmark).
# Needs heaptrack (scripts/install_deps.sh profile) and a built workspace (scripts/setup.sh).
# About 10 min on 2 cores (rendering room x6 once, 1.2 GB, into output/heap_growth/).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
early=960
late=2640
loops=6
out_arg=""
data_arg=""
for a in "$@"; do
  case "$a" in
    early:=*) early="${a#early:=}" ;;
    late:=*) late="${a#late:=}" ;;
    loops:=*) loops="${a#loops:=}" ;;
    out:=*) out_arg="${a#out:=}" ;;
    data:=*) data_arg="${a#data:=}" ;;
    *) echo "heap_growth.sh: unknown argument '$a' (early:=N late:=N loops:=N out:=DIR data:=DIR)" >&2; exit 2 ;;
  esac
done
source "${HERE}/env.sh"
command -v heaptrack >/dev/null && command -v heaptrack_print >/dev/null ||
  { echo "heap_growth.sh: heaptrack not installed (scripts/install_deps.sh profile)" >&2; exit 1; }
BIN="${PL_SLAM_WS}/devel/lib/pl_slam"
[ -x "${BIN}/pl_slam_offline" ] || { echo "heap_growth.sh: ${BIN}/pl_slam_offline missing; run scripts/setup.sh first" >&2; exit 1; }
every=$(( early < 240 ? early : 240 ))
(( early % every == 0 && late % every == 0 && early < late )) ||
  { echo "heap_growth.sh: early and late must be multiples of ${every} with early < late" >&2; exit 2; }
(( late < loops * 480 )) || { echo "heap_growth.sh: late:=${late} must be below the ${loops} laps' $((loops * 480)) frames" >&2; exit 2; }
out="${out_arg:-${PL_SLAM_ROOT}/output/heap_growth}"
data="${PL_SLAM_ROOT}/output/heap_growth/room_x${loops}"
[ -n "${data_arg}" ] && data="$(cd "${data_arg}" && pwd)"
mkdir -p "${out}"
if [ -n "${data_arg}" ]; then
  [ -d "${data}/mav0" ] || { echo "heap_growth.sh: ${data}: not an EuRoC folder (no mav0/)" >&2; exit 1; }
elif [ ! -f "${data}/.complete" ]; then
  echo "[heap_growth] rendering room x${loops} into ${data}"
  rm -rf "${data}"
  "${BIN}/pl_slam_generate" --scene room --loops "${loops}" --euroc "${data}" > "${data}.log" 2>&1 ||
    { tail -3 "${data}.log"; echo "heap_growth.sh: rendering failed" >&2; exit 1; }
  touch "${data}/.complete"
fi

# Runs until memory.csv has the row of frame $2, then kills the program (not heaptrack's
# interpreter, which then writes its file).
run_until() {
  local name="$1" frame="$2" dir="${out}/$1"
  rm -rf "${dir}"
  mkdir -p "${dir}"
  echo "[heap_growth] ${name}: running to frame ${frame} under heaptrack"
  heaptrack -o "${dir}/heap" "${BIN}/pl_slam_offline" "${data}" --out "${dir}/run" --quiet \
    --memory-every "${every}" --set mapping.threaded=false > "${dir}/heaptrack.log" 2>&1 &
  local wrapper=$!
  local pid=""
  until grep -q "^${frame}," "${dir}/run/memory.csv" 2>/dev/null; do
    if ! kill -0 "${wrapper}" 2>/dev/null; then
      tail -5 "${dir}/heaptrack.log"
      echo "heap_growth.sh: ${name}: the run ended before frame ${frame}" >&2
      exit 1
    fi
    sleep 0.2
  done
  pid="$(pgrep -f -n "^${BIN}/pl_slam_offline ${data} --out ${dir}/run")"
  kill -9 "${pid}"
  wait "${wrapper}" || true
  ls "${dir}"/heap*.zst > /dev/null
}

run_until early "${early}"
run_until late "${late}"
for n in early late; do
  heaptrack_print -f "$(ls "${out}/${n}"/heap*.zst)" --flamegraph-cost-type leaked \
    -F "${out}/${n}/held_stacks.txt" -p 0 -a 0 -T 0 -l 0 > /dev/null
done
echo "[heap_growth] memory.csv rows (frame, resident MB, ..., heap in use MB):"
tail -n 1 "${out}/early/run/memory.csv" "${out}/late/run/memory.csv"
/usr/bin/python3 "${HERE}/heap_growth_diff.py" "${out}/early/held_stacks.txt" "${out}/late/held_stacks.txt"
