#!/bin/sh
# The Liaodong Bay 1999 demo (sh tools/demo.sh, or make demo; docs/demo.md),
# from any folder. Installs missing Debian packages (as root, or through
# sudo), builds, runs the synthetic 1999-02-08..12 scene twice
# (with internal stress, as etc/liaodong-demo.json says, and in free drift),
# times each run and prints the thick patch's numbers
# (build/tools/demo_summary) and where the quick-look maps are.
#
# Environment:
#   DEMO_HOURS   forecast length in hours (default 96, the seed's case);
#                a shorter run for a quick look, e.g. DEMO_HOURS=24
#   DEMO_OUT     output folder (default output/liaodong-demo)
#   DEMO_CONFIG  configuration (default etc/liaodong-demo.json)
#   DEMO_SKIP_DEPS=1  do not look at the Debian packages
#   OMP_NUM_THREADS, OMP_WAIT_POLICY  OpenMP threads (default: all cores)
#                and waiting (default here: passive; the model's many short
#                parallel regions make spinning threads very slow on a busy
#                machine, docs/demo.md)
set -eu
: "${OMP_WAIT_POLICY:=passive}"
export OMP_WAIT_POLICY

CYCLE="1999-02-07T22:00Z"
HOURS="${DEMO_HOURS:-96}"
OUT="${DEMO_OUT:-output/liaodong-demo}"
CONFIG="${DEMO_CONFIG:-etc/liaodong-demo.json}"

die() { echo "demo: $*" >&2; exit 1; }

cd "$(dirname "$0")/.."
if [ ! -f "$CONFIG" ] || [ ! -d forcing/liaodong-1999 ]; then
    die "$CONFIG or forcing/liaodong-1999 not found under $(pwd)"
fi
case "$HOURS" in
    ''|*[!0-9.]*) die "DEMO_HOURS=\"$HOURS\": expected a number of hours (1 to 96)" ;;
esac
awk -v h="$HOURS" 'BEGIN { exit !(h > 0 && h <= 96) }' ||
    die "DEMO_HOURS=$HOURS: the scene's forcing covers 96 hours (1 to 96)"

# 1. packages (only when something is missing; as root, or through sudo)
if [ -z "${DEMO_SKIP_DEPS:-}" ]; then
    sh tools/install-deps.sh || die "the Debian packages could not be installed (tools/install-deps.sh)"
fi

# 2. build (a no-op after make demo)
make -j2 >/dev/null || die "build failed (make -j2)"

# Wall clock with sub-second resolution where date has %N (GNU).
now() {
    t=$(date +%s.%N 2>/dev/null || true)
    case "$t" in
        *N*|'') date +%s ;;
        *) echo "$t" ;;
    esac
}

mkdir -p "$OUT"
# The free-drift copy: the one key model.physics changed. The config
# writes it on one known line; refuse to guess if that line moved.
FD_CONFIG="$OUT/liaodong-demo-freedrift.json"
n=$(grep -c '^ *"physics": *"[a-z_]*",$' "$CONFIG" || true)
[ "$n" = 1 ] || die "$CONFIG: expected exactly one line '\"physics\": \"auto\",' to switch to free drift"
# (its own state folder too, so both runs can go at once)
sed -e 's/^\( *"physics": *\)"[a-z_]*",$/\1"free_drift",/' \
    -e 's#^\( *"state_dir": *"[^"]*\)"#\1-freedrift"#' "$CONFIG" >"$FD_CONFIG.tmp"
grep -q '"physics": "free_drift",' "$FD_CONFIG.tmp" || die "could not write the free-drift config"
mv "$FD_CONFIG.tmp" "$FD_CONFIG"

run_scene() { # LABEL CONFIG: writes the wall time to $OUT/LABEL.wall
    label=$1; cfg=$2
    echo "demo: $label: build/sphice run $cfg --cycle $CYCLE --hours $HOURS --out $OUT/$label --force"
    t0=$(now)
    if ! build/sphice run "$cfg" --cycle "$CYCLE" --hours "$HOURS" --out "$OUT/$label" --force \
            >"$OUT/$label.log" 2>&1; then
        tail -n 20 "$OUT/$label.log" >&2
        echo "demo: $label run failed (log: $OUT/$label.log)" >&2
        return 1
    fi
    t1=$(now)
    awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f\n", b - a }' >"$OUT/$label.wall"
    echo "demo: $label: done in $(cat "$OUT/$label.wall") s (log: $OUT/$label.log)"
}

# The two runs are independent: on two or more cores they go at once,
# one thread each (the model threads only above a few thousand particles).
if [ "$(nproc 2>/dev/null || echo 1)" -ge 2 ] && [ -z "${OMP_NUM_THREADS:-}" ]; then
    OMP_NUM_THREADS=1 run_scene freedrift "$FD_CONFIG" &
    fd_pid=$!
    OMP_NUM_THREADS=1 run_scene stress "$CONFIG" || { wait "$fd_pid" || true; die "stress run failed"; }
    wait "$fd_pid" || die "free-drift run failed"
else
    run_scene stress "$CONFIG" || die "stress run failed"
    run_scene freedrift "$FD_CONFIG" || die "free-drift run failed"
fi
WALL_STRESS=$(cat "$OUT/stress.wall")
WALL_FREE=$(cat "$OUT/freedrift.wall")

# 3. summary
build/tools/demo_summary --config "$CONFIG" --json "$OUT/summary.json" \
    stress "$OUT/stress" "$WALL_STRESS" freedrift "$OUT/freedrift" "$WALL_FREE" ||
    die "summary failed"

echo
echo "quick-look maps:"
for label in stress freedrift; do
    for f in "$OUT/$label"/latest/*.png; do
        [ -f "$f" ] && echo "  $f"
    done
done
echo "products: $OUT/stress/latest/ and $OUT/freedrift/latest/ (docs/products.md); summary: $OUT/summary.json"
