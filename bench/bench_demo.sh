#!/bin/sh
# The Liaodong Bay demo against a converged reference run of itself
# (issue 7; docs/bench.md "Liaodong demo"). Called by bench/run.sh
# (BENCH_ONLY=demo); prints CSV rows (bench/bench_common.h) on stdout.
#
# Runs the demo's scene (etc/liaodong-demo.json, cycle 1999-02-07T22:00Z)
# for 96 h (DEMO_HOURS) with variant configurations written here with sed
# from the demo's own:
#   reference  physics full, dt 30 s, 300 mEVP iterations, initial.spacing
#              0.014 deg (about 2x the particles); computed once per bench
#              output folder and reused while the scene, the settings and
#              the sphice binary are the same
#              ($BENCH_OUT/demo/h<HOURS>_ref_<settings>/reference.key)
#   full, auto the seed's settings (dt 60 s, 120 iterations, spacing 0.02)
#   full, auto dt 0: auto time stepping (model.dt = 0, the service's
#              default; 200 s here), labelled dt=auto:<step used>
#   full, auto dt 180 s (inside the adaptive-EVP envelope, 0.2 s/m x spacing)
#   free_drift the seed's settings: the floor of what auto can save (no
#              stress anywhere) and its error
# or the runs DEMO_VARIANTS lists,
# "PHYSICS:DT[:ITERATIONS[:SPACING[:AUTO_TOLERANCE[:REL_TOL[:GC[:KERNEL]]]]]]] ...", e.g.
# "full:30:300 full:60:120:0.014" (the reference's time settings at the
# seed's spacing and the reverse: how the error splits between them) or
# "auto:60:120:0.02:0.1" (model.auto_tolerance 0.1) or
# "auto:0:120:0.02:0.01:1e-3:1" (model.evp.rel_tol 1e-3 and
# model.gradient_correction on; issue 22) or
# "auto:0:120:0.02:0.01:0:0:wendland_c2" (model.kernel; empty fields keep
# the demo's values).
# 96 h, the issue's and the demo's length (until the coast-ghost fixes of
# the core no refined run reached 96 h and the default was 36 h; those rows
# are kept as demo_36h in docs/bench/results.csv). A run that fails is a
# row with its status. The problem column is "demo" for 96 h against the
# default reference, else demo_<H>h and/or _ref_<settings>.
# The method column is the physics with _gc (gradient correction on),
# _rel<REL_TOL> (the residual rule on) and _<KERNEL> (not the Gaussian)
# appended. Products: fields, edge and particles only (no maps, GeoJSON, stations), so
# that CPU time is the model's and the products' it is compared on.
# Each run's CPU (user + system), wall and peak RSS come from GNU time
# (/usr/bin/time) of the sphice process. Errors (build/tools/demo_compare)
# at the last hour against the reference: err = IIEE (15 % threshold, km^2),
# err2 = RMSE of sivol (ice volume per cell area, m) over cells where either
# run has ice, err3 = distance between the thick patch's centres (km).
#
# Environment: BUILD (build), BENCH_OUT (bench/out), BENCH_QUICK=1 (6 h,
# seed dt only), DEMO_HOURS (forecast length, 1-96; default 96, 6 quick),
# DEMO_CONFIG (etc/liaodong-demo.json), DEMO_REF_PHYSICS (full or auto),
# DEMO_REF_DT, DEMO_REF_ITERATIONS, DEMO_REF_SPACING (the reference's
# settings), DEMO_VARIANTS (above). Runs one process at a time with
# OMP_NUM_THREADS=1 (bench/run.sh sets it; set here too).
set -eu
BUILD=${BUILD:-build}
OUT=${BENCH_OUT:-bench/out}
REF_PHYSICS=${DEMO_REF_PHYSICS:-full}
CONFIG=${DEMO_CONFIG:-etc/liaodong-demo.json}
CYCLE="1999-02-07T22:00Z"
QUICK=0
case "${BENCH_QUICK:-0}" in ''|0) ;; *) QUICK=1 ;; esac
if [ -n "${DEMO_HOURS:-}" ]; then HOURS=$DEMO_HOURS; elif [ $QUICK = 1 ]; then HOURS=6; else HOURS=96; fi
REF_DT=${DEMO_REF_DT:-30}
REF_ITER=${DEMO_REF_ITERATIONS:-300}
REF_SPACING=${DEMO_REF_SPACING:-0.014}
W="$OUT/demo/h${HOURS}_ref_${REF_PHYSICS}_dt${REF_DT}_it${REF_ITER}_s$REF_SPACING"
# the problem's name: demo (96 h against the default reference), else with
# the hours and the reference's settings, so charts never mix them
PROBLEM=demo
[ "$HOURS" = 96 ] || PROBLEM="${PROBLEM}_${HOURS}h"
[ "$REF_PHYSICS:$REF_DT:$REF_ITER:$REF_SPACING" = full:30:300:0.014 ] ||
    PROBLEM="${PROBLEM}_ref_${REF_PHYSICS}_dt${REF_DT}_it${REF_ITER}_s$REF_SPACING"
export OMP_NUM_THREADS=1
: "${OMP_WAIT_POLICY:=passive}"
export OMP_WAIT_POLICY

die() { echo "bench_demo: $*" >&2; exit 1; }
case "$REF_PHYSICS" in full|auto) ;; *) die "DEMO_REF_PHYSICS=$REF_PHYSICS: expected full or auto" ;; esac
case "$HOURS" in ''|*[!0-9]*) die "DEMO_HOURS=\"$HOURS\": expected whole hours 1 to 96" ;; esac
[ "$HOURS" -ge 1 ] && [ "$HOURS" -le 96 ] || die "DEMO_HOURS=$HOURS: the scene's forcing covers 96 hours"
[ -f "$CONFIG" ] && [ -d forcing/liaodong-1999 ] || die "run from the repository root ($CONFIG, forcing/liaodong-1999)"
[ -x "$BUILD/sphice" ] && [ -x "$BUILD/tools/demo_compare" ] || die "build first (make -j2)"
[ -x /usr/bin/time ] || die "/usr/bin/time (GNU time, Debian package time) is needed for the CPU times"
mkdir -p "$W"

# The seed's settings, read from the lines the variants rewrite (each must
# occur exactly once, in the form the demo's config writes it).
one() { # PATTERN: the line must occur exactly once
    n=$(grep -c "$1" "$CONFIG" || true)
    [ "$n" = 1 ] || die "$CONFIG: expected one line matching '$1', found $n"
}
one '^ *"dt": *[0-9.]*,$'
one '^ *"physics": *"[a-z_]*",$'
one '^ *"kernel": *"[a-z_0-9]*",$'
one '^ *"solver": *"mevp",$'
one '^ *"spacing": *[0-9.]*,$'
one '^ *"products": *{'
one '^ *"state_dir": *"[^"]*",$'
one '^ *"cache_dir": *"[^"]*",$'
grep -q '"evp"' "$CONFIG" && die "$CONFIG: sets model.evp already; this script adds it"
SEED_DT=$(sed -n 's/^ *"dt": *\([0-9.]*\),$/\1/p' "$CONFIG")
SEED_SPACING=$(sed -n 's/^ *"spacing": *\([0-9.]*\),$/\1/p' "$CONFIG")
SEED_ITER=$("$BUILD/sphice" config-doc | sed -n 's/^| `model.evp.iterations` | int | `\([0-9]*\)`.*/\1/p')
[ -n "$SEED_ITER" ] || die "could not read the default of model.evp.iterations from sphice config-doc"

# write_config NAME PHYSICS DT ITERATIONS SPACING [AUTO_TOLERANCE [REL_TOL [GC [KERNEL]]]] -> $W/NAME.json
write_config() {
    tol_line=""
    [ -n "${6:-}" ] && tol_line=" \"auto_tolerance\": $6,"
    [ -n "${8:-}" ] && [ "$8" = 1 ] && tol_line="$tol_line \"gradient_correction\": true,"
    rel_item=""
    [ -n "${7:-}" ] && rel_item=", \"rel_tol\": $7"
    kernel_expr=""
    [ -n "${9:-}" ] && kernel_expr="s/^\( *\"kernel\": *\)\"[a-z_0-9]*\",\$/\1\"$9\",/"
    sed -e "s/^\( *\"physics\": *\)\"[a-z_]*\",\$/\1\"$2\",$tol_line/" \
        -e "${kernel_expr:-s/^//}" \
        -e "s/^\( *\"dt\": *\)[0-9.]*,\$/\1$3,/" \
        -e "s/^\( *\"solver\": *\"mevp\",\)\$/\1 \"evp\": { \"iterations\": $4$rel_item },/" \
        -e "s/^\( *\"spacing\": *\)[0-9.]*,\$/\1$5,/" \
        -e '/^ *"products": *{/s/"\(maps\|geojson\|stations\)": *true/"\1": false/g' \
        -e "s#^\( *\"state_dir\": *\"\)[^\"]*\"#\1$W/$1.state\"#" \
        -e "s#^\( *\"cache_dir\": *\"\)[^\"]*\"#\1$W/$1.cache\"#" "$CONFIG" >"$W/$1.json.tmp"
    grep -q "\"physics\": \"$2\"," "$W/$1.json.tmp" && grep -q "\"dt\": $3," "$W/$1.json.tmp" &&
        grep -q "\"iterations\": $4$rel_item }" "$W/$1.json.tmp" && grep -q "\"spacing\": $5," "$W/$1.json.tmp" &&
        { [ -z "${6:-}" ] || grep -q "\"auto_tolerance\": $6," "$W/$1.json.tmp"; } &&
        { [ -z "${9:-}" ] || grep -q "\"kernel\": \"$9\"," "$W/$1.json.tmp"; } ||
        die "could not write $W/$1.json"
    mv "$W/$1.json.tmp" "$W/$1.json"
}

# run_model NAME: runs $W/NAME.json into $W/NAME; sets CPU WALL RSS STATUS
run_model() {
    rm -rf "$W/$1" "$W/$1.state" "$W/$1.cache"
    echo "bench_demo: $1: sphice run $W/$1.json --hours $HOURS" >&2
    if /usr/bin/time -f '%U %S %e %M' -o "$W/$1.time" \
            "$BUILD/sphice" run "$W/$1.json" --cycle "$CYCLE" --hours "$HOURS" --out "$W/$1" --force \
            >"$W/$1.log" 2>&1; then
        STATUS=ok
    elif grep -q 'refused' "$W/$1.log"; then
        STATUS=refused
    else
        STATUS=failed
    fi
    # GNU time writes "Command exited with non-zero status N" first on failure
    set -- $(tail -n 1 "$W/$1.time")
    CPU=$(awk -v u="$1" -v s="$2" 'BEGIN { printf "%.2f", u + s }')
    WALL=$3
    RSS=$(awk -v k="$4" 'BEGIN { printf "%.1f", k / 1024 }')
}

row() { # METHOD CONFIG_STRING IIEE RMSE CENTRE
    echo "$PROBLEM,$1,$2,$CPU,$WALL,$RSS,$STATUS,iiee_km2,$3,hbar_rmse_m,$4,patch_centre_km,$5"
}

# 1. the reference (once per output folder, scene, settings and binary)
write_config reference "$REF_PHYSICS" "$REF_DT" "$REF_ITER" "$REF_SPACING"
# (the key leaves out the state and cache folders, which name $W)
KEY="hours=$HOURS $(grep -v '"state_dir"\|"cache_dir"' "$W/reference.json" | sha256sum | cut -c1-16) $(sha256sum <"$BUILD/sphice" | cut -c1-16)"
REF_CFG="physics=$REF_PHYSICS;dt=$REF_DT;iterations=$REF_ITER;spacing=$REF_SPACING;hours=$HOURS"
REF_OK=1
if [ -f "$W/reference.key" ] && [ "$(cat "$W/reference.key")" = "$KEY" ] && [ -f "$W/reference.time" ]; then
    echo "bench_demo: reusing the reference run in $W/reference ($KEY)" >&2
    set -- $(tail -n 1 "$W/reference.time")
    CPU=$(awk -v u="$1" -v s="$2" 'BEGIN { printf "%.2f", u + s }')
    WALL=$3
    RSS=$(awk -v k="$4" 'BEGIN { printf "%.1f", k / 1024 }')
    STATUS=ok
else
    rm -f "$W/reference.key"
    run_model reference
    if [ "$STATUS" = ok ]; then
        echo "$KEY" >"$W/reference.key"
    else
        # a reference that fails is a result too: its row says so, the
        # other runs are still made (their rows: status no_reference)
        tail -n 2 "$W/reference.log" >&2
        echo "bench_demo: reference run $STATUS (log $W/reference.log)" >&2
        REF_OK=0
    fi
fi
# the reference's own row: status "reference" (left out of the charts)
[ $REF_OK = 1 ] && STATUS=reference || STATUS="reference_$STATUS"
row reference "$REF_CFG" "" "" ""

# 2. the runs compared with it
if [ -n "${DEMO_VARIANTS:-}" ]; then
    VARIANTS=$DEMO_VARIANTS
elif [ $QUICK = 1 ]; then
    VARIANTS="full:$SEED_DT auto:$SEED_DT"
else
    VARIANTS="full:$SEED_DT auto:0 auto:$SEED_DT full:0 full:180 auto:180 free_drift:$SEED_DT"
fi
for v in $VARIANTS; do
    # PHYSICS:DT[:ITERATIONS[:SPACING[:AUTO_TOLERANCE]]], the seed's values
    # (and the configured auto_tolerance) where left out
    IFS=: read -r phys dt iter spacing tol rel gc kern <<EOV
$v
EOV
    iter=${iter:-$SEED_ITER}
    spacing=${spacing:-$SEED_SPACING}
    case "$phys:$dt:$iter:$spacing:$tol" in
        *[!a-z_0-9.:]*|:*|*::?*) die "DEMO_VARIANTS entry \"$v\": expected PHYSICS:DT[:ITERATIONS[:SPACING[:AUTO_TOLERANCE[:REL_TOL[:GC[:KERNEL]]]]]]]" ;;
    esac
    case "$kern" in ''|gaussian|wendland_c2|cubic_spline) ;; *) die "DEMO_VARIANTS entry \"$v\": kernel \"$kern\": expected gaussian, wendland_c2 or cubic_spline" ;; esac
    name="${phys}_dt${dt}_it${iter}_s$spacing${tol:+_tol$tol}${rel:+_rel$rel}${gc:+_gc$gc}${kern:+_$kern}"
    write_config "$name" "$phys" "$dt" "$iter" "$spacing" "$tol" "$rel" "$gc" "$kern"
    run_model "$name"
    dtl=$dt
    if [ "$dt" = 0 ]; then # auto time stepping: the step the run took (cycle.json)
        used=$(sed -n 's/^[[:space:]]*"dt":[[:space:]]*\([0-9.]*\),*$/\1/p' "$W/$name"/*/cycle.json 2>/dev/null | head -1)
        dtl="auto${used:+:$used}"
    fi
    # the method (the charts' colour): the physics, and the solver keys the
    # variant sets away from their defaults
    method=$phys
    [ "${gc:-0}" = 1 ] && method="${method}_gc"
    case "${rel:-0}" in 0|0.0) ;; *) method="${method}_rel$rel" ;; esac
    [ -n "$kern" ] && [ "$kern" != gaussian ] && method="${method}_$kern"
    cfg="dt=$dtl;iterations=$iter;spacing=$spacing;hours=$HOURS${tol:+;auto_tolerance=$tol}${rel:+;rel_tol=$rel}${gc:+;gradient_correction=$gc}${kern:+;kernel=$kern}"
    if [ "$STATUS" = ok ] && [ $REF_OK = 0 ]; then
        STATUS=no_reference
        row "$method" "$cfg" "" "" ""
    elif [ "$STATUS" = ok ]; then
        # the representation floor: the same comparison at the first output
        # time (the seeding spacings differ), for the log only
        "$BUILD/tools/demo_compare" --hours 0 "$W/reference" "$W/$name" 2>&1 >/dev/null | sed 's/^/at t0: /' >&2 || true
        if errs=$("$BUILD/tools/demo_compare" --hours "$HOURS" "$W/reference" "$W/$name" 2>"$W/$name.compare.txt"); then
            cat "$W/$name.compare.txt" >&2
            row "$method" "$cfg" "$(echo "$errs" | cut -d, -f1)" "$(echo "$errs" | cut -d, -f2)" \
                "$(echo "$errs" | cut -d, -f3)"
        else
            cat "$W/$name.compare.txt" >&2
            STATUS=compare_failed
            row "$method" "$cfg" "" "" ""
        fi
    else
        tail -n 1 "$W/$name.log" >&2
        row "$method" "$cfg" "" "" ""
    fi
done
