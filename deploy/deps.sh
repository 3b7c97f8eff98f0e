#!/bin/sh
# Installs the Debian packages rayd needs; quiet and quick when all are present.
# Usage: deploy/deps.sh [bench]   ("bench" adds what `make bench` compares against)
set -eu
pkgs="gcc clang clang-format libclang-rt-dev make pkg-config libc6-dev libpng-dev zlib1g-dev libcjson-dev libmicrohttpd-dev libopenexr-dev libcriterion-dev libcurl4-openssl-dev curl python3 python3-jsonschema chromium"
[ "${1:-}" = bench ] && pkgs="$pkgs povray wrk hey git"
missing=""
for p in $pkgs; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && exit 0
echo "installing:$missing" >&2
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO=sudo
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
# shellcheck disable=SC2086
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
