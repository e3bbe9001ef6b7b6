#!/bin/sh
# Free drift, whole `sphice run` against the floor (issue 22; docs/bench.md
# "Free drift"). The Liaodong demo's scene (etc/liaodong-demo.json, cycle
# 1999-02-07T22:00Z, its atmosphere and tide) with model.physics
# free_drift, dt 300 s, thermodynamics off, the particles product and the
# gridded fields file (the forecast's primary product, which cannot be
# turned off; no maps, GeoJSON or stations), seeded at a spacing that gives
# about 1.2e4, 1.2e5 or 1.2e6 particles (FD_SIZES: 1e4 1e5 1e6), for
# FD_HOURS (48) hours, run by:
#   before   the binary FD_BEFORE (default /work/baseline/sphice-r2, main's;
#            empty: skipped) through the SPH path (neighbour lists, density,
#            continuity, PROJ per particle-step); max_neighbours 1000 and
#            health.thickness_limit 1000 so that free drift's clumping at the
#            coasts does not stop it; FD_BEFORE_HOURS (FD_HOURS) hours
#   sph      this build, the same configuration (the SPH path)
#   parcels  this build with model.free_drift_parcels and domain.plane_tables
#   base     the binary FD_BASE (default /tmp/fd-base/build/sphice; empty:
#            skipped), the same configuration as parcels: the baseline of a
#            change to the parcels' path, measured in the same run (build it
#            from main: git archive main | tar -x -C /tmp/fd-base &&
#            make -C /tmp/fd-base -j2 all)
# each with OMP_NUM_THREADS=1, and parcels (and base) again with 2 threads
# at the sizes in FD_THREADS2 (1e5). Each run's CPU (user + system), wall and peak RSS
# come from GNU time; the particle-steps from the run's own log line
# ("S steps, ... N0 -> N1 particles": S (N0 + N1) / 2). The floor
# (build/bench/bench_floor: bilinear interpolation + one 2x2 solve, nothing
# else) runs for the same particle count and steps.
# Output (stdout): one CSV row per run,
#   size,method,threads,particles,steps,cpu_s,wall_s,peak_rss_mb,us_per_particle_step,floor_us,ratio_to_floor,load
# (load: the 1-minute load average, /proc/loadavg, as the run starts; on a
# shared machine a wall time means little above about 1 on 2 cores)
# Environment: BUILD (build), BENCH_OUT (bench/out), FD_SIZES, FD_HOURS,
# FD_BEFORE, FD_BEFORE_HOURS, FD_BASE, FD_METHODS ("before sph parcels"), FD_THREADS2,
# FD_CONFIG_ONLY.
# perf: install linux-perf (Debian) and run
#   perf record -g build/sphice run <BENCH_OUT>/freedrift/1e4_parcels_t1.json --cycle 1999-02-07T22:00Z --hours 48 --out /tmp/x --force
set -eu
BUILD=${BUILD:-build}
OUT=${BENCH_OUT:-bench/out}/freedrift
SIZES=${FD_SIZES:-"1e4 1e5"}
HOURS=${FD_HOURS:-48}
BEFORE=${FD_BEFORE-/work/baseline/sphice-r2}
BHOURS=${FD_BEFORE_HOURS:-$HOURS}
BASE=${FD_BASE-/tmp/fd-base/build/sphice}
METHODS=${FD_METHODS:-"before sph parcels"}
THREADS2=${FD_THREADS2:-1e5}
CONFIG=etc/liaodong-demo.json
CYCLE="1999-02-07T22:00Z"
die() { echo "bench_freedrift: $*" >&2; exit 1; }
[ -f "$CONFIG" ] && [ -d forcing/liaodong-1999 ] || die "run from the repository root"
[ -x "$BUILD/sphice" ] && [ -x "$BUILD/bench/bench_floor" ] || die "build first (make -j2 all $BUILD/bench/bench_floor)"
[ -x /usr/bin/time ] || die "/usr/bin/time (GNU time) is needed"
export OMP_WAIT_POLICY=passive
mkdir -p "$OUT"

spacing() { case $1 in 1e4) echo 0.0063 ;; 1e5) echo 0.002 ;; 1e6) echo 0.00063 ;; *) die "size $1: 1e4, 1e5 or 1e6" ;; esac; }

# config SIZE METHOD THREADS -> path (own output, state and cache folders)
config() {
    f="$OUT/$1_$2_t$3.json"
    extra_model='"max_neighbours": 1000, "health": {"thickness_limit": 1000},'
    extra_domain=''
    if [ "$2" = parcels ] || [ "$2" = base ]; then
        extra_model="$extra_model \"free_drift_parcels\": true,"
        extra_domain=', "plane_tables": true'
    fi
    sed -e 's/"physics": "auto"/"physics": "free_drift"/' -e 's/"dt": 60,/"dt": 300,/' \
        -e "s/\"spacing\": 0.02,/\"spacing\": $(spacing "$1"),/" \
        -e "s/\"sml_factor\": 1.0,/\"sml_factor\": 1.0, $extra_model/" \
        -e "s/\"projection\": \"auto\"/\"projection\": \"auto\"$extra_domain/" \
        -e 's/"dt": 600, "model": "auto"/"dt": 0, "model": "auto"/' \
        -e "s#\"dir\": \"output/liaodong-demo/run\"#\"dir\": \"$OUT/run_$1_$2_t$3\"#" \
        -e "s#output/liaodong-demo/state#$OUT/state_$1_$2_t$3#" -e "s#output/liaodong-demo/cache#$OUT/cache_$1_$2_t$3#" \
        -e 's/"fields": true, "edge": true, "geojson": true, "particles": true, "stations": true, "maps": true/"fields": true, "edge": true, "geojson": false, "particles": true, "stations": false, "maps": false/' \
        "$CONFIG" > "$f"
    for k in '"physics": "free_drift"' '"dt": 300,' '"max_neighbours": 1000' '"particles": true, "stations": false'; do
        grep -q "$k" "$f" || die "$CONFIG: could not write $k into $f"
    done
    echo "$f"
}

# FD_CONFIG_ONLY=1: only write the 1-thread configurations and print their
# paths (bench/bench_mem1e6.sh builds its cases from them)
if [ -n "${FD_CONFIG_ONLY:-}" ]; then
    for size in $SIZES; do for method in $METHODS; do config "$size" "$method" 1; done; done
    exit 0
fi
echo "size,method,threads,particles,steps,cpu_s,wall_s,peak_rss_mb,us_per_particle_step,floor_us,ratio_to_floor,load"
for size in $SIZES; do
    for method in $METHODS; do
        bin="$BUILD/sphice"; hours=$HOURS
        if [ "$method" = before ]; then
            [ -n "$BEFORE" ] || continue
            [ -x "$BEFORE" ] || die "FD_BEFORE=$BEFORE is not executable"
            bin=$BEFORE; hours=$BHOURS
        fi
        if [ "$method" = base ]; then
            [ -n "$BASE" ] || continue
            [ -x "$BASE" ] || die "FD_BASE=$BASE is not executable"
            bin=$BASE
        fi
        threads=1
        { [ "$method" = parcels ] || [ "$method" = base ]; } && case " $THREADS2 " in *" $size "*) threads="1 2" ;; esac
        for th in $threads; do
            cfg=$(config "$size" "$method" "$th")
            log="$OUT/${size}_${method}_t$th.log"
            load=$(cut -d ' ' -f 1 /proc/loadavg 2>/dev/null || echo '')
            if ! OMP_NUM_THREADS=$th /usr/bin/time -o "$log.time" -f "%U %S %e %M" \
                "$bin" run "$cfg" --cycle "$CYCLE" --hours "$hours" --out "$OUT/out_${size}_${method}_t$th" --force \
                > "$log" 2>&1; then
                echo "$size,$method,$th,,,,,,failed: $(tail -n 1 "$log" | tr ',' ';'),,,$load"
                continue
            fi
            read -r us sy wall rss < "$log.time"
            line=$(grep -a -o '[0-9]* steps, [0-9]* output times, [0-9]* -> [0-9]* particles' "$log" | tail -n 1)
            steps=$(echo "$line" | awk '{print $1}')
            parts=$(echo "$line" | awk '{print ($6 + $8) / 2}')
            floor=$("$BUILD/bench/bench_floor" "${parts%.*}" "$steps" 300 | awk '/^floor_ns/ {print $2 / 1000}')
            echo "$size $method $th $parts $steps $us $sy $wall $rss $floor $load" | awk '{
                cpu = $6 + $7; per = 1e6 * cpu / ($4 * $5);
                printf "%s,%s,%s,%.0f,%s,%.2f,%.2f,%.0f,%.4f,%.4f,%.1f,%s\n", $1, $2, $3, $4, $5, cpu, $8, $9 / 1024, per, $10, per / $10, $11 }'
        done
    done
done
