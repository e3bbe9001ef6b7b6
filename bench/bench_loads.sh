#!/bin/sh
# The station DEM's cost on the Liaodong demo (issue 25 items 3 and 4;
# docs/dem.md "The station DEM"): the demo cycle run twice in one run,
#   none   the demo as it is (no structure: no load product), the baseline;
#   loads  the same cycle with the seed's leg (stations[].structure kind
#          vertical, 1.6 m, 300 t, 5.0e5 kN/m, damping 0.03: the keys'
#          defaults) at both stations, loads.model LOADS_MODEL (default
#          dem: the demo's ice at the stations is 0.04-0.08 m thick, below
#          the DEM's 0.1 m threshold, so auto would run the cheap model
#          only), loads.dem_duration LOADS_DURATION s (default 0.2).
# Reads cycle.json's timing block of the second run and prints CSV rows
# (bench/bench_common.h's format) on stdout:
#   loads_demo_<H>h,none|loads,<config>,cpu_s,wall_s,peak_rss_mb,status,
#     dem_s_per_station_hour,<DEM wall s / (stations x forecast hours)>,
#     dem_share,<DEM wall s / the cycle's forecast wall s>,
#     dem_runs,<runs>/<rows> (the rest came from the cycle's cache)
# and a human summary on stderr. The DEM runs inside the forecast's wall
# time (the products are written as the model goes), so the share is a
# part of that run's own total, and the "none" row is the same cycle
# without it, measured in the same run.
#
# Environment: BUILD (build), BENCH_OUT (bench/out), DEMO_HOURS (6),
# DEMO_CONFIG (etc/liaodong-demo.json), LOADS_MODEL (dem), LOADS_DURATION
# (0.2). One process at a time, OMP_NUM_THREADS (default 1) as bench/run.sh.
set -eu
BUILD=${BUILD:-build}
OUT=${BENCH_OUT:-bench/out}
CONFIG=${DEMO_CONFIG:-etc/liaodong-demo.json}
HOURS=${DEMO_HOURS:-6}
MODEL=${LOADS_MODEL:-dem}
DURATION=${LOADS_DURATION:-0.2}
CYCLE="1999-02-07T22:00Z"
NAME=19990207T22Z
: "${OMP_NUM_THREADS:=1}"
: "${OMP_WAIT_POLICY:=passive}"
export OMP_NUM_THREADS OMP_WAIT_POLICY
W="$OUT/loads"
die() { echo "bench_loads: $*" >&2; exit 1; }
[ -f "$CONFIG" ] && [ -d forcing/liaodong-1999 ] || die "run from the repository root ($CONFIG, forcing/liaodong-1999)"
[ -x "$BUILD/sphice" ] || die "build first (make -j2)"
[ -x /usr/bin/time ] || die "/usr/bin/time (GNU time, Debian package time) is needed for the CPU times"
case "$MODEL" in auto|cheap|dem) ;; *) die "LOADS_MODEL=$MODEL: expected auto, cheap or dem" ;; esac
mkdir -p "$W"
n=$(grep -c '^ *{ "name": "[^"]*", "lon": [0-9.]*, "lat": [0-9.]* },\{0,1\}$' "$CONFIG" || true)
[ "$n" -ge 1 ] || die "$CONFIG: no station line of the form { \"name\": ..., \"lon\": ..., \"lat\": ... }"
grep -q '^ *"stations": \[$' "$CONFIG" || die "$CONFIG: expected a line '\"stations\": ['"

# write_config NAME WITH_STRUCTURES -> $W/NAME.json
write_config() {
    if [ "$2" = 1 ]; then
        sed -e 's/^\( *{ "name": "[^"]*", "lon": [0-9.]*, "lat": [0-9.]*\) }/\1, "structure": { "kind": "vertical" } }/' \
            -e "s/^\( *\)\"stations\": \[\$/\1\"loads\": { \"model\": \"$MODEL\", \"dem_duration\": $DURATION },\n\1\"stations\": [/" \
            "$CONFIG"
    else
        cat "$CONFIG"
    fi | sed -e "s#^\( *\"state_dir\": *\"\)[^\"]*\"#\1$W/$1.state\"#" \
             -e "s#^\( *\"cache_dir\": *\"\)[^\"]*\"#\1$W/$1.cache\"#" >"$W/$1.json"
}

# run_cycle NAME: sets CPU WALL RSS (GNU time's last line: user, system, wall, peak kB) and STATUS
run_cycle() {
    rm -rf "$W/$1" "$W/$1.state" "$W/$1.cache"
    echo "bench_loads: $1: sphice run $W/$1.json --hours $HOURS" >&2
    STATUS=ok
    /usr/bin/time -f '%U %S %e %M' -o "$W/$1.time" "$BUILD/sphice" run "$W/$1.json" --cycle "$CYCLE" \
        --hours "$HOURS" --out "$W/$1" --force >"$W/$1.log" 2>&1 || STATUS=failed
    read -r CPU WALL RSS <<EOF_T
$(awk 'END { printf "%.2f %s %.1f", $1 + $2, $3, $4 / 1024 }' "$W/$1.time")
EOF_T
}

# num FILE KEY: the first number after "KEY": in cycle.json
num() { sed -n "s/^[[:space:]]*\"$2\":[[:space:]]*\([-0-9.eE+]*\),\{0,1\}\$/\1/p" "$1" | head -n 1; }

PROBLEM="loads_demo_${HOURS}h"
write_config none 0
run_cycle none
echo "$PROBLEM,none,stations without structure,$CPU,$WALL,$RSS,$STATUS,,,,,,"
WALL_NONE=$WALL

write_config loads 1
run_cycle loads
J="$W/loads/$NAME/cycle.json"
if [ "$STATUS" = ok ] && [ -f "$J" ]; then
    DEM=$(num "$J" dem_wall_seconds)
    FC=$(awk '/"forecast":/ { f = 1 } f && /"wall_seconds"/ { gsub(/[^0-9.eE+-]/, "", $2); print $2; exit }' "$J")
    RUNS=$(num "$J" dem_runs)
    ROWS=$(num "$J" dem_rows)
    CACHED=$(num "$J" dem_cached)
    PSTEPS=$(num "$J" dem_particle_steps)
    PER=$(awk -v d="$DEM" -v n="$n" -v h="$HOURS" 'BEGIN { printf "%.3f", d / (n * h) }')
    SHARE=$(awk -v d="$DEM" -v f="$FC" 'BEGIN { printf "%.4f", (f > 0 ? d / f : 0) }')
    echo "$PROBLEM,loads,model=$MODEL duration=${DURATION}s stations=$n,$CPU,$WALL,$RSS,$STATUS,dem_s_per_station_hour,$PER,dem_share,$SHARE,dem_runs,$RUNS/$ROWS"
    echo "bench_loads: $HOURS h, $n stations with the seed's leg, loads.model $MODEL, $DURATION s per DEM run:" >&2
    echo "bench_loads:   cycle wall $WALL s (without structures $WALL_NONE s); forecast wall $FC s of which DEM $DEM s (share $SHARE)" >&2
    echo "bench_loads:   $RUNS DEM runs, $CACHED rows from the cache, of $ROWS DEM rows; $PSTEPS particle-steps" >&2
    echo "bench_loads:   DEM cost per station per forecast hour: $PER s" >&2
else
    echo "$PROBLEM,loads,model=$MODEL duration=${DURATION}s stations=$n,$CPU,$WALL,$RSS,$STATUS,,,,,,"
    tail -n 3 "$W/loads.log" >&2
fi
