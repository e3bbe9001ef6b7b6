#!/bin/sh
# One rheology iteration's cost, this tree against a baseline tree, in one
# run (issue 22, item 3): builds bench/bench_loops.c in both (the baseline
# gets this tree's copy of it and of its header-only helper tests/lattice.h;
# it uses only the public model API),
# runs them alternately `rounds` times, one thread each, and prints the
# CSV rows (the baseline's with problem loops_base) and then one summary
# line per case on stderr: summed CPU seconds of both, their ratio, and
# whether the final states' checksums agree (bit for bit the same state).
# Usage: sh bench/bench_loops.sh BASE_TREE [max_N] [rounds]
#   BASE_TREE  e.g. mkdir /tmp/base && git archive 31f122e | tar -x -C /tmp/base
#   max_N      largest lattice (default 10000; 100000 adds 1e5)
set -eu
[ $# -ge 1 ] || { echo "usage: $0 BASE_TREE [max_N] [rounds]" >&2; exit 2; }
base=$1; maxn=${2:-10000}; rounds=${3:-2}
BUILD=${BUILD:-build}
cp bench/bench_loops.c "$base/bench/bench_loops.c"
cp tests/lattice.h "$base/tests/lattice.h"
make -C "$base" build/bench/bench_loops >/dev/null
make "$BUILD/bench/bench_loops" >/dev/null
export OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=1
tmp=${TMPDIR:-/tmp}/bench_loops.$$
i=0
while [ "$i" -lt "$rounds" ]; do
    "$base/build/bench/bench_loops" "$maxn" | sed 's/^loops,/loops_base,/'
    "$BUILD/bench/bench_loops" "$maxn"
    i=$((i + 1))
done > "$tmp"
cat "$tmp"
awk -F, '{ key = $2 "," $3; side = ($1 == "loops_base") ? "b" : "n";
           cpu[key, side] += $4; st[key, side] = $7; if (!(key in seen)) { seen[key] = 1; order[++n] = key } }
     END { for (i = 1; i <= n; i++) { k = order[i];
               same = (st[k, "b"] == st[k, "n"]) ? "same state" : "STATE DIFFERS";
               printf "bench_loops: %s: base %.3f s, this %.3f s, base/this %.2f, %s\n",
                      k, cpu[k, "b"], cpu[k, "n"], cpu[k, "b"] / cpu[k, "n"], same } }' "$tmp" >&2
rm -f "$tmp"
