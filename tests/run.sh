#!/bin/sh
# Runs each test program given on the command line, prints its output,
# and ends with one summary line "N passed, N failed" (exit 1 on any failure).
# SPHICE_VALGRIND=1 runs each program under valgrind memcheck.
set -u
pass=0; fail=0; broken=""
log=$(mktemp)
for t in "$@"; do
    name=$(basename "$t")
    start=$(date +%s)
    if [ -n "${SPHICE_VALGRIND:-}" ]; then
        OMP_NUM_THREADS=1 valgrind -q --error-exitcode=99 --leak-check=full \
            --errors-for-leak-kinds=definite "$t" >"$log" 2>&1
    else
        # passive waiting: spinning OpenMP threads starve each other on a busy 2-core box
        OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive} "$t" >"$log" 2>&1
    fi
    rc=$?
    end=$(date +%s)
    cat "$log"
    line=$(grep -E "^$name: [0-9]+ passed, [0-9]+ failed" "$log" | tail -n 1)
    if [ -n "$line" ]; then
        p=$(echo "$line" | sed -E 's/.*: ([0-9]+) passed.*/\1/')
        f=$(echo "$line" | sed -E 's/.* ([0-9]+) failed.*/\1/')
        pass=$((pass + p)); fail=$((fail + f))
    fi
    if [ $rc -ne 0 ] && { [ -z "$line" ] || [ "${f:-0}" -eq 0 ]; }; then
        fail=$((fail + 1)); broken="$broken $name(rc=$rc)"
    fi
    echo "-- $name: rc=$rc, $((end - start)) s"
done
rm -f "$log"
[ -n "$broken" ] && echo "programs that crashed or exited non-zero without a failed check:$broken"
echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
