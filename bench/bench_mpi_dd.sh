#!/bin/sh
# Strong and weak scaling of the domain decomposition (docs/domain.md):
# bench_mpi_dd at 1, 2 and 4 ranks, rows into docs/bench/mpi_dd.csv.
#   [OUT=CSV] sh bench/bench_mpi_dd.sh [STRONG_N] [WEAK_N_PER_RANK] [STEPS] [ITERS]
# Needs the MPI build: make MPI=1 BUILD=build-mpi build-mpi/bench/bench_mpi_dd
set -e
N=${1:-250000}
W=${2:-62500}
STEPS=${3:-3}
ITERS=${4:-30}
BIN=build-mpi/bench/bench_mpi_dd
OUT=${OUT:-docs/bench/mpi_dd.csv}
ROOT=""
[ "$(id -u)" = 0 ] && ROOT=--allow-run-as-root
command -v mpirun >/dev/null 2>&1 && [ -x "$BIN" ] || { echo "bench_mpi_dd.sh: needs mpirun and $BIN"; exit 0; }
echo "series,ranks,N,steps,iters,wall_step_s,cpu_max_step_s,cpu_sum_step_s,halo_frac,halo_bytes_step,halo_bytes_per_particle_step,migrate_bytes_step,imbalance,init_s,wait_old_max_step_s,wait_old_min_step_s,reduce_old_step_s,wait_max_step_s,wait_min_step_s,reduce_step_s,rss_max_mb" >"$OUT"
for np in 1 2 4; do
  OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive mpirun $ROOT --oversubscribe -np $np $BIN "$N" "$STEPS" "$ITERS" /tmp/mpi_dd_row.$$.csv >/dev/null
  printf 'strong,' >>"$OUT"; tail -n 1 /tmp/mpi_dd_row.$$.csv >>"$OUT"
  # the weak row equal to the strong one (W x np = N) is not run twice
  [ $((W * np)) -eq "$N" ] || OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive mpirun $ROOT --oversubscribe -np $np $BIN $((W * np)) "$STEPS" "$ITERS" /tmp/mpi_dd_row.$$.csv >/dev/null
  printf 'weak,' >>"$OUT"; tail -n 1 /tmp/mpi_dd_row.$$.csv >>"$OUT"
  echo "bench_mpi_dd.sh: $np ranks done"
done
rm -f /tmp/mpi_dd_row.$$.csv
cat "$OUT"
