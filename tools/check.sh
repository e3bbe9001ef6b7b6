#!/bin/sh
# The test suite from a fresh Debian 12 machine in one command (README):
# installs the missing Debian packages (as root, or through sudo), builds,
# and runs `make check`. Run from anywhere; as root or as a user with sudo.
#   sh tools/check.sh [MAKE TARGET ...]   (default: check)
set -eu
cd "$(dirname "$0")/.."
sh tools/install-deps.sh
make -j2 all
[ $# -gt 0 ] || set -- check
make "$@"
