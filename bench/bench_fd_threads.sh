#!/bin/sh
# Free drift's 2-thread speed-up at 1e5 (issue 22; docs/bench.md "Session
# 11: free drift (fd5)"): the bench's parcels configuration
# (bench_freedrift.sh, FD_SIZE 1e5, 48 h at 300 s) run by this build and
# by FD_BASE (a build of main; empty: skipped) with 1 and 2 threads, in
# FD_ROUNDS rounds whose order alternates (base first in odd rounds), each
# run under bench/thread_cpu.sh (every thread's utime + stime from /proc
# every 0.25 s). One CSV row per run (stdout):
#   round,binary,threads,wall_s,cpu_s,main_s,worker_s,writer_s,main_blocked_s,worker_blocked_s,team_rqwait_s,load
# (cpu_s: user + system of the whole process; main, worker, writer: the
# thread's last sample; the writer is the products' writer thread, which
# runs only with more than one thread: with one thread its deflate runs on
# the main thread; from /proc/PID/task/TID/schedstat: blocked = the
# thread's lifetime - its time on a CPU - its time runnable but waiting for
# one (asleep: at the OpenMP barriers, for the writer, for I/O), team_rqwait
# = the team's time runnable but waiting for a CPU (the machine's other
# work, and the writer)), then per binary the medians of the rounds and
#   speedup = wall(1 thread) / wall(2 threads)
#   team_extra = (main + worker of the 2-thread run) / (cpu of the 1-thread
#                run - the writer's CPU of the 2-thread run): the CPU the
#                OpenMP team spends for the 1-thread run's compute
#   us_ps, ratio_to_floor = the 1-thread run's CPU per particle-step and
#                its ratio to bench_floor's loop for the same particles
# The products of every run are compared with the first run's by
# tools/same-products.sh after the last run (FD_SAME=0: not). A wall time means little above a
# load of about 1 on 2 cores: on a shared machine read cpu_s, team_extra
# and writer_s.
# FD_NICE=N: instead of base against this, this build with
# output.writer_nice 0 ("nice0") against N ("niceN"), alternating likewise.
# Environment: BUILD (build), FD_BASE, BENCH_OUT (bench/out), FD_ROUNDS (2),
# FD_SIZE (1e5), FD_THREADS ("1 2"), FD_NICE.
set -eu
BUILD=${BUILD:-build}
BASE=${FD_BASE-}
OUT=${BENCH_OUT:-bench/out}/fd_threads
ROUNDS=${FD_ROUNDS:-2}
SIZE=${FD_SIZE:-1e5}
THREADS=${FD_THREADS:-"1 2"}
die() { echo "bench_fd_threads: $*" >&2; exit 1; }
[ -x "$BUILD/sphice" ] && [ -x "$BUILD/bench/bench_floor" ] || die "build first (make -j2 all $BUILD/bench/bench_floor)"
[ -z "$BASE" ] || [ -x "$BASE" ] || die "FD_BASE=$BASE is not executable"
mkdir -p "$OUT"
cfg=$(BENCH_OUT=$OUT BUILD=$BUILD FD_CONFIG_ONLY=1 FD_SIZES=$SIZE FD_METHODS=parcels sh bench/bench_freedrift.sh)
[ -f "$cfg" ] || die "no configuration written"
NICE=${FD_NICE:-}
A=base; B=this
if [ -n "$NICE" ]; then
    A=nice0; B=nice$NICE; BASE=$BUILD/sphice
    sed "s/\"interval_hours\": 1,/\"interval_hours\": 1, \"writer_nice\": $NICE,/" "$cfg" > "${cfg%.json}_nice.json"
    grep -q '"writer_nice"' "${cfg%.json}_nice.json" || die "could not write output.writer_nice"
fi
rows=$OUT/rows.csv
: > "$rows"
: > "$OUT/cycles"
echo "round,binary,threads,wall_s,cpu_s,main_s,worker_s,writer_s,main_blocked_s,worker_blocked_s,team_rqwait_s,load"
r=1
while [ "$r" -le "$ROUNDS" ]; do
    if [ -z "$BASE" ]; then order=$B; elif [ $((r % 2)) = 1 ]; then order="$A $B"; else order="$B $A"; fi
    for th in $THREADS; do
        for b in $order; do
            bin=$BUILD/sphice; c=$cfg
            [ "$b" = base ] && bin=$BASE
            [ -n "$NICE" ] && [ "$b" = "$B" ] && c=${cfg%.json}_nice.json
            o=$OUT/r${r}_${b}_t$th
            load=$(cut -d ' ' -f 1 /proc/loadavg)
            sh bench/thread_cpu.sh "$bin" "$c" "$th" "$o" > /dev/null || die "$o: the run failed ($o.log)"
            read -r us sy wall rss < "$o.time"
            # main: the process's own tid; the writer: the thread named
            # sphice-writer (forecast_writer.c; a binary before fd5 names it
            # not: then the thread seen last, beyond the team); the others:
            # the OpenMP team
            awk -v pid="$(cat "$o.pid")" -v th="$th" -v wall="$wall" '{ if (!($2 in last)) { first[$2] = $1; nt++ } last[$2] = $4 + $5; name[$2] = $3
                                                                   lastt[$2] = $1; run[$2] = $6; rqw[$2] = $7 }
                END { late = ""; for (t in last) if (t != pid && name[t] != "(sphice-writer)" && (late == "" || first[t] > first[late])) late = t;
                      named = 0; for (t in last) named += name[t] == "(sphice-writer)";
                      m = 0; w = 0; wr = 0; mb = 0; wb = 0; q = 0;
                      for (t in last) { c = last[t] / 100;
                                        if (t == pid) { m += c; mb = wall - 1e-9 * (run[t] + rqw[t]); q += 1e-9 * rqw[t] }
                                        else if (name[t] == "(sphice-writer)" || (!named && nt > th && t == late)) wr += c;
                                        else { w += c; wb += lastt[t] - first[t] - 1e-9 * (run[t] + rqw[t]); q += 1e-9 * rqw[t] } }
                      printf "%.2f %.2f %.2f %.2f %.2f %.2f\n", m, w, wr, mb, wb, q }' "$o.samp" > "$o.thr"
            read -r mn wk wr mb wb rq < "$o.thr"
            row=$(echo "$r $b $th $wall $us $sy $mn $wk $wr $mb $wb $rq $load" |
                  awk '{printf "%s,%s,%s,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%s", $1, $2, $3, $4, $5 + $6, $7, $8, $9, $10, $11, $12, $13}')
            echo "$row" | tee -a "$rows"
            ls -d "$o.out"/*/ | head -n 1 >> "$OUT/cycles"
        done
    done
    r=$((r + 1))
done
# the products after all runs (ncdump of a 1e5 particles file takes a minute)
ref=$(head -n 1 "$OUT/cycles")
[ "${FD_SAME:-1}" = 0 ] || tail -n +2 "$OUT/cycles" | while read -r cyc; do
    sh tools/same-products.sh "$ref" "$cyc" > "$OUT/same.txt" 2>&1 && echo "same products: $cyc" >&2 ||
        echo "products differ: $ref $cyc ($OUT/same.txt)" >&2
done
log=$(ls "$OUT"/r1_*_t1.log 2>/dev/null | head -n 1)
[ -n "$log" ] || log=$(ls "$OUT"/r1_*.log | head -n 1)
line=$(grep -a -o '[0-9]* steps, [0-9]* output times, [0-9]* -> [0-9]* particles' "$log" | tail -n 1)
steps=$(echo "$line" | awk '{print $1}')
parts=$(echo "$line" | awk '{printf "%.0f", ($6 + $8) / 2}')
floor=$("$BUILD/bench/bench_floor" "$parts" "$steps" 300 | awk '/^floor_ns/ {print $2 / 1000}')
echo "binary,speedup,team_extra,cpu1_s,cpu2_s,writer_s,us_ps,floor_us,ratio_to_floor (medians over rounds)"
for b in $A $B; do
    grep -q ",$b," "$rows" || continue
    awk -F, -v b="$b" -v steps="$steps" -v parts="$parts" -v floor="$floor" '
        function med(a, n,   i, j, t) { for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
                                        return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2 }
        $2 == b && $3 == 1 { w1[$1] = $4; c1[$1] = $5 }
        $2 == b && $3 == 2 { w2[$1] = $4; c2[$1] = $5; tm[$1] = $6 + $7; wr[$1] = $8 }
        END { n = 0; for (r in w1) if (r in w2) { n++; s[n] = w1[r] / w2[r]; e[n] = tm[r] / (c1[r] - wr[r]);
                                                  a[n] = c1[r]; c[n] = c2[r]; d[n] = wr[r] }
              if (!n) exit; per = 1e6 * med(a, n) / (parts * steps);
              printf "%s,%.3f,%.3f,%.2f,%.2f,%.2f,%.4f,%.4f,%.1f\n", b, med(s, n), med(e, n), med(a, n), med(c, n), med(d, n), per, floor, per / floor }' "$rows"
done
