#!/bin/sh
# `make fuzz`: runs each libFuzzer harness of $FUZZ_BUILD/fuzz/ for
# $FUZZ_SECONDS (default 60) on its corpus, $FUZZ_BUILD/fuzz/corpus/NAME
# (kept between runs, started from the seeds in $FUZZ_BUILD/fuzz/seeds/NAME),
# and prints one line per harness: executions, corpus size, findings.
# A crash, sanitizer report, leak or timeout leaves its input as
# $FUZZ_BUILD/fuzz/crash-NAME-* and makes the run fail.
# FUZZ_RUNS=N stops each harness after N executions (FUZZ_SECONDS still
# caps the time). FUZZ_KEEP_GOING=1 runs in libFuzzer's fork mode and goes
# on after a crash (for inputs that crash inside libnetcdf or HDF5, which
# the harness cannot avoid: triage the crash-* files it leaves with
# tests/fuzz/triage.sh). Allocations over FUZZ_MAX_ALLOC_MB (default 256)
# fail (NULL), as on a machine short of memory: libnetcdf allocates what a
# header declares before checking it (netcdf-c PR 3377). FUZZ_ONLY="config http" runs only those; FUZZ_JOBS>1 runs that many
# processes per harness (-fork). Exit 1 if any harness found something.
set -u
SUPP=$(cd "$(dirname "$0")" && pwd)/lsan.supp
B=${FUZZ_BUILD:-build-fuzz}/fuzz
S=${FUZZ_SECONDS:-60}
fail=0
names=${FUZZ_ONLY:-$(for f in "$B"/fuzz_*; do [ -x "$f" ] && basename "$f" | sed 's/^fuzz_//'; done)}
for n in $names; do
    mkdir -p "$B/corpus/$n"
    log="$B/fuzz_$n.log"
    fork=""
    [ -n "${FUZZ_RUNS:-}" ] && fork="-runs=$FUZZ_RUNS"
    [ -n "${FUZZ_KEEP_GOING:-}" ] && fork="-fork=${FUZZ_JOBS:-1} -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1"
    [ -z "${FUZZ_KEEP_GOING:-}" ] && [ "${FUZZ_JOBS:-1}" -gt 1 ] && fork="$fork -fork=${FUZZ_JOBS}"
    # shellcheck disable=SC2086
    ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1:max_allocation_size_mb=${FUZZ_MAX_ALLOC_MB:-256}} \
        UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1} LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$SUPP} OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive \
        nice -n 10 "$B/fuzz_$n" -max_total_time="$S" -timeout=20 -rss_limit_mb=4096 -malloc_limit_mb=100000 \
        -print_final_stats=1 -artifact_prefix="$B/crash-$n-" $fork \
        "$B/corpus/$n" "$B/seeds/$n" >"$log" 2>&1
    rc=$?
    execs=$(grep -E '^stat::number_of_executed_units' "$log" | tail -n 1 | awk '{ print $2 }')
    [ -z "$execs" ] && execs=$(grep -oE '^#[0-9]+' "$log" | tail -n 1 | tr -d '#')
    crashes=$(ls "$B"/crash-"$n"-crash-* "$B"/crash-"$n"-leak-* "$B"/crash-"$n"-oom-* "$B"/crash-"$n"-timeout-* 2>/dev/null | wc -l)
    units=$(ls "$B/corpus/$n" | wc -l)
    if [ $rc -ne 0 ]; then
        fail=1
        echo "fuzz_$n: FOUND something after ${execs:-?} executions (rc=$rc), see $log:"
        grep -E 'ERROR: |runtime error|SUMMARY|Test unit written' "$log" | head -n 8
    else
        secs=$(grep -oE 'Done [0-9]+ runs in [0-9]+ second' "$log" | awk '{ print $5 }')
        if [ "$crashes" -gt 0 ]; then
            fail=1
            echo "fuzz_$n: ${execs:-?} executions, corpus $units inputs, $crashes crash inputs kept ($B/crash-$n-*)"
        else
            echo "fuzz_$n: ${execs:-?} executions in ${secs:-$S} s, corpus $units inputs, no crash, no sanitizer report"
        fi
    fi
done
exit $fail
