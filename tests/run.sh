#!/bin/sh
# Runs each test program given on the command line and ends with one
# summary line "N passed, N failed" (exit 1 on any failure).
#
# SPHICE_TEST_JOBS programs run at once (default: the number of cores,
# at most 2 -- make check's budget is set on two cores). Each program's
# whole output goes to its own log; one line "-- name: rc=R, S s" is
# printed as each one finishes (progress), and the logs are printed in
# the order given once all have finished, so the output reads the same
# whatever the number of jobs. The longest programs (the SLOW list) start
# first so that the two lanes end together.
# SPHICE_VALGRIND=1 runs each program under valgrind memcheck.
set -u
SLOW="test_demo test_dem_bend test_rheology test_dem_float test_mpi_run test_launcher
      test_dem_sail test_http test_dem_leg test_dem_ridge test_daemon"

if [ "${1:-}" = "--one" ]; then
    # worker: run one program, keep its log and exit status in $dir
    dir=$2; t=$3; name=$(basename "$t")
    start=$(date +%s)
    if [ -n "${SPHICE_VALGRIND:-}" ]; then
        OMP_NUM_THREADS=1 valgrind -q --error-exitcode=99 --leak-check=full \
            --errors-for-leak-kinds=definite "$t" >"$dir/$name.log" 2>&1
    else
        # passive waiting: spinning OpenMP threads starve each other on a busy 2-core box
        OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive} "$t" >"$dir/$name.log" 2>&1
    fi
    rc=$?
    end=$(date +%s)
    echo "-- $name: rc=$rc, $((end - start)) s" >"$dir/$name.end"
    echo "$rc" >"$dir/$name.rc"
    cat "$dir/$name.end"
    exit 0
fi

jobs=${SPHICE_TEST_JOBS:-}
if [ -z "$jobs" ]; then
    jobs=$(nproc 2>/dev/null || echo 1)
    [ "$jobs" -gt 2 ] && jobs=2
fi
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
started=$(date +%s)

# slow programs first (in SLOW's order), then the rest in the order given
{
    for s in $SLOW; do
        for t in "$@"; do [ "$(basename "$t")" = "$s" ] && echo "$t"; done
    done
    for t in "$@"; do
        case " $(echo $SLOW) " in *" $(basename "$t") "*) ;; *) echo "$t" ;; esac
    done
} | xargs -P "$jobs" -n 1 sh "$0" --one "$dir"

pass=0; fail=0; broken=""
for t in "$@"; do
    name=$(basename "$t")
    if [ ! -f "$dir/$name.rc" ]; then
        fail=$((fail + 1)); broken="$broken $name(not run)"
        continue
    fi
    cat "$dir/$name.log" "$dir/$name.end"
    rc=$(cat "$dir/$name.rc")
    line=$(grep -E "^$name: [0-9]+ passed, [0-9]+ failed" "$dir/$name.log" | tail -n 1)
    f=0
    if [ -n "$line" ]; then
        p=$(echo "$line" | sed -E 's/.*: ([0-9]+) passed.*/\1/')
        f=$(echo "$line" | sed -E 's/.* ([0-9]+) failed.*/\1/')
        pass=$((pass + p)); fail=$((fail + f))
    fi
    if [ "$rc" -ne 0 ] && { [ -z "$line" ] || [ "$f" -eq 0 ]; }; then
        fail=$((fail + 1)); broken="$broken $name(rc=$rc)"
    fi
done
[ -n "$broken" ] && echo "programs that crashed, exited non-zero without a failed check, or did not run:$broken"
echo "$# programs, $jobs at once, $(( $(date +%s) - started )) s"
echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
