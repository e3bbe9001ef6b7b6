#!/bin/sh
# Installs the Debian packages sphice needs to build, test and run its demo.
# Idempotent: does nothing when every package is already present. Works as
# root (apt-get directly) or as a user with sudo (asks sudo for apt-get
# only); says in one line what to do when it can be neither.
# Usage: sh tools/install-deps.sh [--fuzz] [--browser] [--mpi] [--promtool] [--perf]
#   --fuzz  also clang, llvm (symbolizer) and libomp-dev: the libFuzzer
#           harnesses of `make fuzz` and the fuzz smoke of `make check`
#   --browser  also chromium: test_daemon loads the status page in headless
#           chromium (skipped with one line without it)
#   --mpi   also OpenMPI (libopenmpi-dev, openmpi-bin): `make MPI=1`, the
#           ensemble over ranks and its test in `make check`
#   --promtool  also prometheus (Debian ships promtool in it): test_daemon
#           runs `promtool check metrics` on a real /metrics answer
#           (skipped with one line without it)
#   --perf  also linux-perf: the profiles of docs/speed.md and docs/bench.md ("Free drift")
set -eu
PKGS="build-essential make pkg-config libnetcdf-dev libhdf5-dev netcdf-bin libcurl4-openssl-dev \
libcjson-dev libgsl-dev libproj-dev proj-data libudunits2-dev libmicrohttpd-dev \
libsqlite3-dev sqlite3 libssl-dev libcairo2-dev libsystemd-dev gmt-gshhg-high gnuplot-nox \
libgdal-dev gdal-bin \
valgrind curl systemd"
case " $* " in *" --fuzz "*) PKGS="$PKGS clang llvm libomp-dev" ;; esac
case " $* " in *" --browser "*) PKGS="$PKGS chromium" ;; esac
case " $* " in *" --mpi "*) PKGS="$PKGS libopenmpi-dev openmpi-bin" ;; esac
case " $* " in *" --promtool "*) PKGS="$PKGS prometheus" ;; esac
case " $* " in *" --perf "*) PKGS="$PKGS linux-perf" ;; esac
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
if [ "$(id -u)" -ne 0 ]; then
    if ! command -v sudo >/dev/null 2>&1; then
        echo "install-deps: not root and sudo is not installed: run 'sh tools/install-deps.sh' as root (missing:$missing)" >&2
        exit 1
    fi
    SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
if [ -n "$SUDO" ]; then
    sudo apt-get update -q
    # shellcheck disable=SC2086
    sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $missing
else
    apt-get update -q
    # shellcheck disable=SC2086
    apt-get install -y -q --no-install-recommends $missing
fi
