#!/usr/bin/env bash
# Check that every C++ source file is formatted with the repository's .clang-format (Debian clang-format,
# installed by scripts/setup.sh). Exit code non-zero and the offending lines printed when one is not.
# Fix with: git ls-files '*.cpp' '*.hpp' | xargs clang-format -i
set -euo pipefail
cd "$(dirname "$0")/.."
git ls-files '*.cpp' '*.hpp' | xargs clang-format --dry-run --Werror
echo "check-format: $(git ls-files '*.cpp' '*.hpp' | wc -l) files formatted"
