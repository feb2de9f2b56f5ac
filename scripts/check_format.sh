#!/usr/bin/env bash
# Fails when a C++ file of the package differs from the house .clang-format style.
# `scripts/check_format.sh --fix` rewrites the files in place instead.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
export PATH="/usr/bin:/bin:${PATH}"
command -v clang-format >/dev/null || { echo "check_format.sh: clang-format not installed (scripts/install_deps.sh installs it)" >&2; exit 1; }
mapfile -t files < <(git ls-files '*.cpp' '*.h' '*.hpp' 2>/dev/null || find include src nodes test -name '*.cpp' -o -name '*.h')
if [ "${1:-}" = "--fix" ]; then
  clang-format -i "${files[@]}"
  echo "formatted ${#files[@]} files"
  exit 0
fi
bad=()
for f in "${files[@]}"; do
  clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if [ "${#bad[@]}" -gt 0 ]; then
  echo "check_format.sh: ${#bad[@]} file(s) not in the house style (run scripts/check_format.sh --fix): ${bad[*]}" >&2
  exit 1
fi
echo "check_format.sh: ${#files[@]} files in the house style"
