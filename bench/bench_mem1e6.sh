#!/bin/sh
# Peak RSS and CPU at 1e6 particles (issue 22; docs/bench.md "Session 8:
# memory at 1e6"): this build against a baseline binary in the same run.
# Cases, both from bench_freedrift.sh's 1e6_parcels_t1.json (FD_CONFIG_ONLY):
#   mevp   model.physics auto, no free_drift_parcels, model.dt 10, 3 steps
#          (--hours 0.00833): packed ice through mEVP (docs/bench.md
#          "Memory at 1e6 particles")
#   fd     the configuration as it stands (parcels, plane tables), 2 hours
#   mevpc  mevp with "model.compact_gradients": true (docs/bench.md "Session 9:
#          memory at 1e6"), run by this build only (a base without the key
#          refuses it), 1 and 2 threads; its products against BASE's mevp
# each run by BASE (default /tmp/mem1g-base/build/sphice) and BUILD/sphice,
# alternating, ROUNDS (1) times, with OMP_NUM_THREADS=1, and this build's
# mevp once more with 2 threads (its products against the 1-thread run's:
# tools/same-products.sh; and this build's against BASE's).
# Output (stdout): case,binary,threads,round,cpu_s,wall_s,peak_rss_mb
# (peak_rss_mb: GNU time's maximum RSS in kB / 1024; the KiB are in each run's
# .time file), then the identity lines.
# Environment: BUILD (build), BASE, BENCH_OUT (bench/out), ROUNDS, CASES ("mevp fd";
# mevpc needs mevp in CASES before it), THREADS (unset: the 1-thread rounds and
# this build's extra 2-thread runs above; "1 2": every case with each count,
# base and this alternating), BINARIES ("base this"; "base" or "this" alone
# runs one side, e.g. the base while this is being built: the identity lines
# then compare whatever outputs BENCH_OUT holds from an earlier call).
set -eu
BUILD=${BUILD:-build}
BASE=${BASE:-/tmp/mem1g-base/build/sphice}
OUT=${BENCH_OUT:-bench/out}/mem1e6
ROUNDS=${ROUNDS:-1}
CASES=${CASES:-"mevp fd"}
CYCLE="1999-02-07T22:00Z"
die() { echo "bench_mem1e6: $*" >&2; exit 1; }
[ -x "$BUILD/sphice" ] && [ -x "$BASE" ] || die "build first; BASE=$BASE must be executable"
[ -x /usr/bin/time ] || die "/usr/bin/time (GNU time) is needed"
export OMP_WAIT_POLICY=passive
mkdir -p "$OUT"
src=$(FD_CONFIG_ONLY=1 BUILD=$BUILD BENCH_OUT=$OUT FD_SIZES=1e6 FD_METHODS=parcels sh bench/bench_freedrift.sh)
[ -f "$src" ] || die "bench_freedrift.sh wrote no configuration"
# case binary-tag -> configuration with its own output, state and cache folders
config() {
    f="$OUT/$1_$2.json"
    if [ "$1" = mevp ] || [ "$1" = mevpc ]; then
        compact='s/"model": {/"model": {/'
        [ "$1" = mevpc ] && compact='s/"model": {/"model": { "compact_gradients": true,/'
        sed -e 's/"physics": "free_drift"/"physics": "auto"/' -e 's/ "free_drift_parcels": true,//' \
            -e 's/"dt": 300,/"dt": 10,/' -e "$compact" -e "s#_1e6_parcels_t1#_$1_$2#g" "$src" > "$f"
        grep -q '"physics": "auto"' "$f" && grep -q '"dt": 10,' "$f" && ! grep -q free_drift_parcels "$f" ||
            die "could not write the mEVP case into $f"
    else
        sed -e "s#_1e6_parcels_t1#_$1_$2#g" "$src" > "$f"
    fi
    echo "$f"
}
hours() { [ "$1" = fd ] && echo 2 || echo 0.00833; }
run() { # case tag binary threads round
    cfg=$(config "$1" "$2")
    log="$OUT/$1_$2_t$4_r$5.log"
    if ! OMP_NUM_THREADS=$4 /usr/bin/time -o "$log.time" -f "%U %S %e %M" "$3" run "$cfg" --cycle "$CYCLE" \
        --hours "$(hours "$1")" --out "$OUT/out_$1_$2_t$4" --force > "$log" 2>&1; then
        echo "$1,$2,$4,$5,failed: $(tail -n 1 "$log" | tr ',' ';'),,"
        return
    fi
    read -r us sy wall rss < "$log.time"
    echo "$1 $2 $4 $5 $us $sy $wall $rss" | awk '{printf "%s,%s,%s,%s,%.2f,%.2f,%.0f\n", $1, $2, $3, $4, $5 + $6, $7, $8 / 1024}'
}
THREADS_SET=${THREADS-}
BINARIES=${BINARIES:-"base this"}
has() { case " $BINARIES " in *" $1 "*) return 0 ;; esac; return 1; }
same() { # dirA dirB label
    if [ -d "$1" ] && [ -d "$2" ]; then
        echo "identity $3: $(sh tools/same-products.sh "$1" "$2" | tail -n 1)"
    fi
}
echo "case,binary,threads,round,cpu_s,wall_s,peak_rss_mb"
r=1
while [ "$r" -le "$ROUNDS" ]; do
    for c in $CASES; do
        for t in ${THREADS_SET:-1}; do
            [ "$c" = mevpc ] || ! has base || run "$c" base "$BASE" "$t" "$r"
            ! has this || run "$c" this "$BUILD/sphice" "$t" "$r"
        done
    done
    r=$((r + 1))
done
d="19990207T22Z"
for c in $CASES; do
    b=$c; [ "$c" = mevpc ] && b=mevp
    for t in ${THREADS_SET:-1}; do
        same "$OUT/out_${b}_base_t$t/$d" "$OUT/out_${c}_this_t$t/$d" "$c this against $b base ($t thread(s))"
    done
    for x in base this; do
        [ -n "$THREADS_SET" ] && same "$OUT/out_${c}_${x}_t1/$d" "$OUT/out_${c}_${x}_t2/$d" "$c $x 1/2 threads"
    done
done
[ -z "$THREADS_SET" ] && has this || exit 0
case " $CASES " in *" mevp "*)
    run mevp this "$BUILD/sphice" 2 1
    echo "identity mevp this 1/2 threads: $(sh tools/same-products.sh "$OUT/out_mevp_this_t1/19990207T22Z" "$OUT/out_mevp_this_t2/19990207T22Z" | tail -n 1)" ;;
esac
case " $CASES " in *" mevpc "*)
    run mevpc this "$BUILD/sphice" 2 1
    echo "identity mevpc this 1/2 threads: $(sh tools/same-products.sh "$OUT/out_mevpc_this_t1/19990207T22Z" "$OUT/out_mevpc_this_t2/19990207T22Z" | tail -n 1)" ;;
esac
