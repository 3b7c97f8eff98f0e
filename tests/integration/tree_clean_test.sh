#!/bin/sh
# Building and the reports leave tracked files as they were: `make`,
# `make stability` and `make install-test` write only under build/ (and
# ignored folders), so a checkout stays clean after them.
# Usage (from a git checkout's root): sh tests/integration/tree_clean_test.sh
set -u
if ! git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    echo "tree_clean: not a git checkout, nothing to compare"
    exit 0
fi
before=$(git status --porcelain=v1 --untracked-files=all | sort)
make --no-print-directory -s all >/dev/null 2>&1 || { echo "FAIL: make"; exit 1; }
make --no-print-directory -s stability >/dev/null 2>&1 || { echo "FAIL: make stability"; exit 1; }
after=$(git status --porcelain=v1 --untracked-files=all | sort)
if [ "$before" = "$after" ]; then
    echo "tree_clean: make and make stability left the checkout as it was"
    exit 0
fi
echo "FAIL: make or make stability changed the checkout:"
printf '%s\n' "$after" | grep -vxF -- "$before"
exit 1
