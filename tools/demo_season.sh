#!/bin/sh
# The Liaodong Bay freeze-up scene (make demo-season; docs/season.md):
# generates the forcing into build/liaodong-season (tools/gen_season.c),
# runs 30 days from open water on 2000-12-01 00Z with the mixed layer, new
# ice and merging (etc/liaodong-season.json), then writes the numbers
# (tools/season_summary.c) and a chart of ice area and volume against time
# (gnuplot) beside the products.
#
# Environment:
#   SEASON_HOURS  run length in hours (default 720; at most 720)
#   SEASON_OUT    output folder (default output/liaodong-season)
#   SEASON_DENSITY_REINIT  N > 0: continuity density re-initialised by
#                 summation every N steps (model.summation_density false,
#                 model.density_reinit_steps N) instead of the scene's
#                 summation density (docs/ocean.md); default: the scene as is
#   OMP_NUM_THREADS, OMP_WAIT_POLICY (default here: passive)
set -eu
: "${OMP_WAIT_POLICY:=passive}"
export OMP_WAIT_POLICY
die() { echo "demo-season: $*" >&2; exit 1; }
cd "$(dirname "$0")/.."
HOURS="${SEASON_HOURS:-720}"
case "$HOURS" in
    ''|*[!0-9]*) die "SEASON_HOURS=\"$HOURS\": expected whole hours (1 to 720)" ;;
esac
[ "$HOURS" -ge 1 ] && [ "$HOURS" -le 720 ] || die "SEASON_HOURS=$HOURS: the scene's forcing covers 720 hours"
OUT="${SEASON_OUT:-output/liaodong-season}"
BUILD="${BUILD:-build}"
CYCLE="2000-12-01T00:00Z" # the run's cycle and its products' folder name
STAMP="20001201T00Z"
command -v gnuplot >/dev/null || die "gnuplot not found (sh tools/install-deps.sh installs gnuplot-nox)"

"$BUILD/tools/gen_season" "$BUILD/liaodong-season" forcing/liaodong-1999/landmask_liaodong.nc 30 ||
    die "forcing generation failed"
mkdir -p "$OUT"
CONFIG="$OUT/liaodong-season.json"
# the products, state and cache under $OUT (the configuration names output/liaodong-season)
REINIT="${SEASON_DENSITY_REINIT:-0}"
case "$REINIT" in
    ''|*[!0-9]*) die "SEASON_DENSITY_REINIT=\"$REINIT\": expected a whole number of steps" ;;
esac
DENSITY='"summation_density": true,'
[ "$REINIT" -gt 0 ] && DENSITY="\"summation_density\": false, \"density_reinit_steps\": $REINIT,"
sed -e "s#output/liaodong-season/#$OUT/#" -e "s#build/liaodong-season/#$BUILD/liaodong-season/#" \
    -e "s#\"summation_density\": true,#$DENSITY#" etc/liaodong-season.json > "$CONFIG"
grep -q "$DENSITY" "$CONFIG" || die "etc/liaodong-season.json: no \"summation_density\": true, to replace"
t0=$(date +%s)
"$BUILD/sphice" run "$CONFIG" --cycle "$CYCLE" --hours "$HOURS" --out "$OUT/run" --force ||
    die "the run failed"
t1=$(date +%s)
RUN="$OUT/run/$STAMP"
"$BUILD/tools/season_summary" "$RUN" "$BUILD/liaodong-season/ocean_season.nc" > "$OUT/season.dat" ||
    die "season_summary failed"
gnuplot <<GP || die "gnuplot failed"
set terminal pngcairo size 1000,640 font ",11"
set output "$OUT/season-area-volume.png"
set title "Liaodong Bay freeze-up from open water, 2000-12-01 (synthetic scene, sphice)"
set xlabel "days since 2000-12-01 00Z"
set ylabel "ice area (km^2)"
set y2label "ice volume (km^3) x 100, mean depth under new ice (m) x 100"
set ytics nomirror
set y2tics
set key top left
set grid
plot "$OUT/season.dat" using (\$1/24):2 with lines lw 2 title "ice area (km^2)", \
     "$OUT/season.dat" using (\$1/24):(\$3*100) axes x1y2 with lines lw 2 title "ice volume (km^3) x 100", \
     "$OUT/season.dat" using (\$1/24):(\$6*100) axes x1y2 with points pt 7 ps 0.6 title "depth under new particles (m) x 100"
GP
echo "demo-season: $HOURS h in $((t1 - t0)) s; products in $RUN"
grep '^#' "$OUT/season.dat" | sed 's/^# /demo-season: /'
grep -v '^#' "$OUT/season.dat" | tail -n 1 | awk '{printf "demo-season: at %g h: area %g km2, volume %g km3, %d particles\n", $1, $2, $3, $4}'
grep -E '"(energy|water|salt)_budget_residual"|"particles_(start|end)"' "$RUN/cycle.json" | tr -d '\t,"' | sed 's/^/demo-season: /' || true
echo "demo-season: chart $OUT/season-area-volume.png; maps $RUN/sphice_quicklook_*.png"
