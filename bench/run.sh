#!/bin/sh
# The benchmark suite (issue 2 performance, issue 7 speed-accuracy,
# stability envelope, auto vs full, read windows on a global file).
# `make bench` runs it after building.
#   BENCH_QUICK=1  small matrices (CI, ~3 min)
#   BENCH_OUT=dir  output folder (default bench/out)
#   BENCH_ONLY="neighbours reference stability auto demo hyperslab"  a subset
#              (box2001: CICE's box2001 side by side, not in the default list;
#              loads: the station DEM's cost on the demo, bench/bench_loads.sh, neither;
#              season: the particle count over a 90-day season with and
#              without merging, bench/bench_season.c, not in the default
#              list; writes $BENCH_OUT/season_counts.dat; SEASON_DAYS=d)
#              (loops: one rheology iteration's CPU cost and a state checksum,
#              bench/bench_loops.c, not in the default list; against a baseline
#              tree in one run: sh bench/bench_loops.sh BASE_TREE, docs/speed.md)
#              (r300: R300 from rest with mEVP stopping and acceleration
#              variants, bench/bench_r300.c, issue 22; not in the default list)
#   DEMO_HOURS=h   the demo problem's forecast length (bench/bench_demo.sh; 96)
# Writes $BENCH_OUT/results.csv (one row per run, see bench/bench_common.h),
# $BENCH_OUT/machine.txt, and the charts (bench/plot.sh, needs gnuplot).
# The accuracy runs use one thread (CPU time comparable with the serial
# grid baseline); bench_neighbours sets its own thread counts. OpenMP
# threads wait passively: on a shared machine spinning threads distort
# the timings.
set -eu
BUILD=${BUILD:-build}
OUT=${BENCH_OUT:-bench/out}
ONLY=${BENCH_ONLY:-"neighbours reference stability auto demo hyperslab"}
mkdir -p "$OUT"
export OMP_WAIT_POLICY=PASSIVE
{
    echo "date: $(date -u +%Y-%m-%dT%H:%MZ)"
    echo "git: $(git rev-parse --short=12 HEAD 2>/dev/null || echo unknown)"
    echo "nproc: $(nproc)"
    echo "cpu: $(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -n 1)"
    echo "memory: $(free -g 2>/dev/null | awk '/^Mem:/ {print $2 " GiB"}')"
    echo "load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
    echo "quick: ${BENCH_QUICK:-0}"
} > "$OUT/machine.txt"
CSV="$OUT/results.csv"
echo "problem,method,config,cpu_s,wall_s,peak_rss_mb,status,err_name,err,err2_name,err2,err3_name,err3" > "$CSV"
for b in $ONLY; do
    echo "bench: $b" >&2
    t0=$(date +%s)
    case $b in
    neighbours) "$BUILD/bench/bench_neighbours" >> "$CSV" ;;
    demo) BUILD="$BUILD" BENCH_OUT="$OUT" sh bench/bench_demo.sh >> "$CSV" ;;
    loads) BUILD="$BUILD" BENCH_OUT="$OUT" sh bench/bench_loads.sh >> "$CSV" ;;
    auto) # the channel half packed, then packed everywhere
        OMP_NUM_THREADS=1 "$BUILD/bench/bench_auto" >> "$CSV"
        BENCH_AUTO_PACKED=1 OMP_NUM_THREADS=1 "$BUILD/bench/bench_auto" >> "$CSV" ;;
    box2001) # CICE's box2001 (issue 26): 10 days at 16 km, the residual rule at 1e-3
        B01_RELTOL=1e-3 B01_DT=432 B01_DAYS=10 OMP_NUM_THREADS=1 "$BUILD/bench/bench_box2001" >> "$CSV" ;;
    season) # the 90-day season, merging on and off in one run
        BENCH_OUT="$OUT" OMP_NUM_THREADS=1 "$BUILD/bench/bench_season" ${SEASON_DAYS:-} >> "$CSV" ;;
    *) OMP_NUM_THREADS=1 "$BUILD/bench/bench_$b" >> "$CSV" ;;
    esac
    echo "bench: $b took $(( $(date +%s) - t0 )) s" >&2
done
echo "load average at end: $(cut -d' ' -f1-3 /proc/loadavg)" >> "$OUT/machine.txt"
if command -v gnuplot >/dev/null 2>&1; then
    sh bench/plot.sh "$CSV" "$OUT"
else
    echo "bench: gnuplot not installed (tools/install-deps.sh), no charts" >&2
fi
echo "bench: results in $CSV" >&2
