#!/usr/bin/env bash
# Regenerates docs/configuration.md from the option table (`pl_slam_offline
# --print-config-markdown`, defaults only). Run it after adding or changing an option;
# test_util's ConfigDoc.MatchesTheOptionTable fails while the page is out of date.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
bash "${HERE}/setup.sh"
source "${HERE}/env.sh"
out="${PL_SLAM_ROOT}/docs/configuration.md"
"${PL_SLAM_WS}/devel/lib/pl_slam/pl_slam_offline" --print-config-markdown > "${out}.tmp"
mv "${out}.tmp" "${out}"
echo "gen_config_doc.sh: wrote docs/configuration.md ($(grep -c '^| `' "${out}") options)"
