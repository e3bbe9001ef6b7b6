#!/bin/sh
# Installs the Debian packages sphice needs to build, test and run its demo.
# Idempotent: does nothing when every package is already present.
# Usage (as root): tools/install-deps.sh
set -eu
PKGS="build-essential pkg-config libnetcdf-dev netcdf-bin libcurl4-openssl-dev \
libcjson-dev libgsl-dev libproj-dev proj-data libudunits2-dev libmicrohttpd-dev \
libsqlite3-dev sqlite3 libssl-dev libcairo2-dev libsystemd-dev gmt-gshhg-high gnuplot-nox \
valgrind curl systemd"
missing=""
for p in $PKGS; do
    dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"
done
if [ -z "$missing" ]; then
    echo "install-deps: all packages present"
    exit 0
fi
echo "install-deps: installing:$missing"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
# shellcheck disable=SC2086
$SUDO apt-get install -y -q --no-install-recommends $missing
