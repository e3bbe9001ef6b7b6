#!/bin/sh
# Per-thread CPU of one `sphice run` (issue 22, docs/bench.md "Session 10: free drift"): every
# thread's utime, stime (clock ticks, /proc/PID/task/TID/stat fields 14, 15) each 0.25 s
# into OUTDIR.samp (time tid name utime stime run_ns wait_ns; the last two from
# /proc/PID/task/TID/schedstat: time on a CPU, time runnable but waiting for one),
# GNU time into OUTDIR.time, the process id
# (= the main thread's tid) into OUTDIR.pid. The products' writer thread is named sphice-writer.
# usage: bench/thread_cpu.sh BIN CFG THREADS OUTDIR -> per-thread utime+stime (ticks) sampled every 0.25 s
BIN=$1; CFG=$2; TH=$3; O=$4
OMP_WAIT_POLICY=passive OMP_NUM_THREADS=$TH /usr/bin/time -f "%U %S %e %M" -o $O.time $BIN run $CFG --cycle 1999-02-07T22:00Z --hours 48 --out $O.out --force > $O.log 2>&1 &
P=$!
sleep 0.05
pid=$(pgrep -P $P sphice || echo $P)
echo $pid > $O.pid
: > $O.samp
while kill -0 $P 2>/dev/null; do
  t=$(date +%s.%N)
  for d in /proc/$pid/task/*; do
    [ -r $d/stat ] || continue
    read -r run wait slices < $d/schedstat 2>/dev/null || { run=0; wait=0; }
    awk -v t=$t -v r=$run -v w=$wait '{print t, $1, $2, $14, $15, r, w}' $d/stat 2>/dev/null
  done >> $O.samp
  sleep 0.25
done
wait $P
cat $O.time
