#!/bin/sh
# `make soak`: SOAK_CYCLES (default 200) accelerated cycles of a small real
# forecast (the engine, not the test double) under `sphice serve`, on the
# scene of tools/soak_case.c (cycles every SOAK_EVERY seconds, 0.5 h
# forecasts, output.retention_cycles = SOAK_KEEP). Samples the daemon's
# resident memory (VmRSS in /proc/PID/status) and open descriptors
# (/proc/PID/fd) after each published cycle and checks at the end:
#   - RSS flat from cycle SOAK_FROM (default 20): its least-squares trend
#     under SOAK_SLOPE_KB (default 1) kB per cycle, and the last sample
#     under SOAK_GROWTH_PCT (default 2) % above the one at SOAK_FROM,
#   - the open descriptors do not grow: neither the fewest nor the most
#     seen over the last 20 samples exceeds those over the 20 from SOAK_FROM
#     (a sample may fall while a cycle still has its files open, so single
#     samples differ by a few),
#   - output.dir holds exactly SOAK_KEEP cycle folders (retention pruning),
#   - the daemon exits 0 on SIGTERM.
# Prints the samples to SOAK_DIR/samples.txt and one line per check;
# exit 1 on any failure. BUILD selects the build (default build).
set -u
B=${BUILD:-build}
N=${SOAK_CYCLES:-200}
EVERY=${SOAK_EVERY:-3}
KEEP=${SOAK_KEEP:-5}
FROM=${SOAK_FROM:-20}
SLOPE=${SOAK_SLOPE_KB:-1}
GROWTH=${SOAK_GROWTH_PCT:-2}
[ "$FROM" -ge "$N" ] && FROM=$((N / 2))
D=${SOAK_DIR:-$(mktemp -d /tmp/sphice-soak-XXXXXX)}
mkdir -p "$D"
hours=$(( (N * EVERY) / 3600 + 2 ))
"$B/tools/soak_case" "$D" "$hours" "$EVERY" "$KEEP" || exit 1
OMP_WAIT_POLICY=passive OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} \
    nice -n 10 "$B/sphice" serve "$D/sphice.json" >"$D/serve.log" 2>&1 &
pid=$!
echo "soak: daemon $pid, $N cycles every $EVERY s, in $D"
: >"$D/samples.txt"
done_cycles=0
deadline=$(( $(date +%s) + N * EVERY * 4 + 120 ))
fail=0
while [ "$done_cycles" -lt "$N" ]; do
    if ! kill -0 "$pid" 2>/dev/null; then
        echo "soak: FAIL: the daemon died after $done_cycles cycles (see $D/serve.log)"
        tail -n 5 "$D/serve.log"
        exit 1
    fi
    if [ "$(date +%s)" -gt "$deadline" ]; then
        echo "soak: FAIL: only $done_cycles of $N cycles before the deadline"
        fail=1
        break
    fi
    n=$(grep -c 'published' "$D/serve.log")
    if [ "$n" -gt "$done_cycles" ]; then
        done_cycles=$n
        rss=$(awk '/^VmRSS:/ { print $2 }' "/proc/$pid/status")
        fds=$(ls "/proc/$pid/fd" | wc -l)
        echo "$done_cycles $rss $fds" >>"$D/samples.txt"
        # what is open, for a failure's diagnosis: at SOAK_FROM and the latest
        [ "$done_cycles" -eq "$FROM" ] && ls -l "/proc/$pid/fd" >"$D/fds-from.txt" 2>/dev/null
        ls -l "/proc/$pid/fd" >"$D/fds-last.txt" 2>/dev/null
        case "$done_cycles" in *0) echo "soak: cycle $done_cycles: RSS $rss kB, $fds fds" ;; esac
    fi
    sleep 0.5
done
failed=$(grep -c 'cycle .* failed\|ERROR\|error:' "$D/serve.log")
kill -TERM "$pid"
wait "$pid"
rc=$?
[ $rc -eq 0 ] || { echo "soak: FAIL: the daemon exited $rc on SIGTERM"; fail=1; }
[ "$failed" -eq 0 ] || { echo "soak: FAIL: $failed error lines in $D/serve.log"; grep -m 3 'failed\|ERROR\|error:' "$D/serve.log"; fail=1; }
first=$(awk -v c="$FROM" '$1 >= c { print; exit }' "$D/samples.txt")
last=$(tail -n 1 "$D/samples.txt")
r0=$(echo "$first" | awk '{ print $2 }'); f0=$(echo "$first" | awk '{ print $3 }')
r1=$(echo "$last" | awk '{ print $2 }'); f1=$(echo "$last" | awk '{ print $3 }')
c0=$(echo "$first" | awk '{ print $1 }'); c1=$(echo "$last" | awk '{ print $1 }')
if [ -z "$r0" ] || [ -z "$r1" ]; then
    echo "soak: FAIL: no samples"
    exit 1
fi
growth=$(awk -v a="$r0" -v b="$r1" 'BEGIN { printf "%.2f", 100 * (b - a) / a }')
echo "soak: RSS $r0 kB at cycle $c0, $r1 kB at cycle $c1 ($growth %); min $(awk '{ print $2 }' "$D/samples.txt" | sort -n | head -n 1) kB, max $(awk '{ print $2 }' "$D/samples.txt" | sort -n | tail -n 1) kB"
echo "soak: open descriptors $f0 at cycle $c0, $f1 at cycle $c1 (range $(awk '{ print $3 }' "$D/samples.txt" | sort -n | head -n 1)..$(awk '{ print $3 }' "$D/samples.txt" | sort -n | tail -n 1))"
# flat: the least-squares slope of RSS over the samples from cycle FROM
# (a single sample may catch a cycle's peak, so no one pair decides)
slope=$(awk -v c="$c0" '$1 >= c { n++; sx += $1; sy += $2; sxx += $1 * $1; sxy += $1 * $2 }
    END { d = n * sxx - sx * sx; printf "%.2f", (d > 0 ? (n * sxy - sx * sy) / d : 0) }' "$D/samples.txt")
echo "soak: RSS trend from cycle $c0: $slope kB per cycle (least squares; limit $SLOPE kB per cycle)"
awk -v s="$slope" -v l="$SLOPE" 'BEGIN { exit !(s < l) }' || { echo "soak: FAIL: RSS grows $slope kB per cycle (limit $SLOPE)"; fail=1; }
awk -v g="$growth" -v l="$GROWTH" 'BEGIN { exit !(g < l) }' || { echo "soak: FAIL: RSS grew $growth % (limit $GROWTH %)"; fail=1; }
early=$(awk -v c="$c0" '$1 >= c' "$D/samples.txt" | head -n 20 | awk '{ print $3 }' | sort -n)
late=$(tail -n 20 "$D/samples.txt" | awk '{ print $3 }' | sort -n)
e0=$(echo "$early" | head -n 1); e1=$(echo "$early" | tail -n 1)
l0=$(echo "$late" | head -n 1); l1=$(echo "$late" | tail -n 1)
echo "soak: open descriptors from cycle $c0: $e0..$e1, over the last 20 cycles: $l0..$l1"
[ "$l0" -le "$e0" ] && [ "$l1" -le "$e1" ] || { echo "soak: FAIL: descriptors grew ($e0..$e1 -> $l0..$l1)"; fail=1; }
out=$D/out
kept=$(find "$out" -mindepth 1 -maxdepth 1 -type d -name '[0-9]*T*Z' | wc -l)
echo "soak: $kept cycle folders in $out (output.retention_cycles = $KEEP) after $done_cycles cycles"
want=$KEEP; [ "$done_cycles" -lt "$KEEP" ] && want=$done_cycles
[ "$kept" -eq "$want" ] || { echo "soak: FAIL: retention kept $kept, want $want"; fail=1; }
if [ $fail -eq 0 ]; then
    echo "soak: ok"
    [ -z "${SOAK_DIR:-}" ] && rm -rf "$D"
fi
exit $fail
