#!/bin/sh
# The model on paper of docs/domain.md: a 72 h pan-Arctic 3 km forecast on
# 64 to 1024 ranks, from the halo fraction and volume bench_mpi_dd measured
# (docs/bench/mpi_dd.csv) and stated machine constants.
#   [CSV=FILE] sh bench/mpi_dd_model.sh [N] [ITERS] [T_PI] [ALPHA_US] [BETA_GBS] [CORES]
# N particles (1.5e6: 13.5e6 km2 of winter ice at 9 km2 each), ITERS mEVP
# iterations per step (120, the default), T_PI s per particle-iteration
# (measured on one rank, bench_mpi_dd strong 1 rank: cpu_max_step_s /
# (N iters)), ALPHA_US the latency per message, BETA_GBS the bandwidth per
# rank, CORES the ranks one 1-hour window has for the ensemble.
N=${1:-1500000}
IT=${2:-120}
CSV=${CSV:-docs/bench/mpi_dd.csv}
TPI=${3:-$(awk -F, '$1 == "strong" && $2 == 1 && $3 > n { n = $3; t = $7 / ($3 * $5) } END { printf "%.3g", t }' "$CSV")}
# halo fraction f = K sqrt(P / N): K from the 4-rank rows (pieces with two
# inner sides); a piece inside a large decomposition has four: 2 K
K=$(awk -F, '$2 == 4 { k += $9 / sqrt(4 / $3); n++ } END { printf "%.3g", 2 * k / n }' "$CSV")
awk -v N="$N" -v IT="$IT" -v TPI="$TPI" -v K="$K" -v A="${4:-2}" -v B="${5:-10}" -v C="${6:-1024}" 'BEGIN {
  steps = 72 * 3600 / 300; row = 441; refresh = 40;
  printf "N %d, %d mEVP iterations, %d steps of 300 s, t_pi %.3g s, K %.3g, alpha %g us, beta %g GB/s\n", N, IT, steps, TPI, K, A, B;
  printf "| ranks | particles/rank | halo fraction | compute s/step | comm s/step | forecast min | members in 1 h on %d ranks |\n", C;
  printf "|---|---|---|---|---|---|---|\n";
  for (P = 64; P <= 1024; P *= 2) {
    n = N / P; f = K * sqrt(P / N);
    comp = n * (1 + f) * IT * TPI;
    lg = log(P) / log(2);
    # per iteration: 8 neighbour messages each way, the refresh, one allreduce of 4 x 552 + 8 bytes
    it = 8 * A * 1e-6 + f * n * refresh / (B * 1e9) + 2 * lg * A * 1e-6;
    # per step: two alltoall (P messages) and alltoallv (halo copies, migration), one allreduce
    st = 2 * P * A * 1e-6 + f * n * row / (B * 1e9) + 2 * lg * A * 1e-6;
    comm = IT * it + st;
    T = steps * (comp + comm);
    mem = int(C / P) * int(3600 / T);
    printf "| %d | %.0f | %.3f | %.3f | %.4f | %.1f | %d |\n", P, n, f, comp, comm, T / 60, mem;
  }
}'
