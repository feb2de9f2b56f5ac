#!/usr/bin/env bash
# Regenerates docs/configuration.md from the option table (`pl_slam_offline
# --print-config-markdown`, defaults only), and config/template.yaml's option lines (its
# comment header is kept) from `--print-config`. Run it after adding or changing an option;
# test_util's ConfigDoc.MatchesTheOptionTable fails while the page is out of date.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
bash "${HERE}/setup.sh"
source "${HERE}/env.sh"
out="${PL_SLAM_ROOT}/docs/configuration.md"
"${PL_SLAM_WS}/devel/lib/pl_slam/pl_slam_offline" --print-config-markdown > "${out}.tmp"
mv "${out}.tmp" "${out}"
echo "gen_config_doc.sh: wrote docs/configuration.md ($(grep -c '^| `' "${out}") options)"
tmpl="${PL_SLAM_ROOT}/config/template.yaml"
{ grep '^#' "${tmpl}"; "${PL_SLAM_WS}/devel/lib/pl_slam/pl_slam_offline" --print-config; } > "${tmpl}.tmp"
mv "${tmpl}.tmp" "${tmpl}"
echo "gen_config_doc.sh: wrote config/template.yaml"
