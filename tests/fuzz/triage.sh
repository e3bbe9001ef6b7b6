#!/bin/sh
# Replays each crash input a fuzz run left (FUZZ_BUILD/fuzz/crash-NAME-*)
# and prints, per input, the sanitizer's one-line summary and the first
# stack frame in sphice's own code or, if there is none, the library frame
# at the top: which crashes are sphice's and which are libnetcdf's or HDF5's.
# Usage: sh tests/fuzz/triage.sh [NAME...]
set -u
SUPP=$(cd "$(dirname "$0")" && pwd)/lsan.supp
B=${FUZZ_BUILD:-build-fuzz}/fuzz
names=${*:-config raster forcing restart http}
for n in $names; do
    for c in "$B"/crash-"$n"-*; do
        case "$c" in *slow-unit*) continue ;; esac
        [ -e "$c" ] || continue
        out=$(ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1:max_allocation_size_mb=${FUZZ_MAX_ALLOC_MB:-256} \
              UBSAN_OPTIONS=print_stacktrace=1 LSAN_OPTIONS=suppressions=$SUPP OMP_NUM_THREADS=1 "$B/fuzz_$n" -timeout=20 \
              -rss_limit_mb=4096 -malloc_limit_mb=100000 "$c" 2>&1)
        summary=$(echo "$out" | grep -m 1 -E 'SUMMARY|runtime error|ERROR: libFuzzer')
        own=$(echo "$out" | grep -E '^ +#[0-9]+ ' | grep -m 1 -E '(src|tests/fuzz)/[a-z_/]+\.c:[0-9]' | sed -E 's/^ +#[0-9]+ 0x[0-9a-f]+ in //')
        top=$(echo "$out" | grep -E '^ +#[0-9]+ ' | grep -v -E 'sanitizer|interceptor|asan|ubsan|libc\.so|__memcpy|fuzzer::' | head -n 1 |
              sed -E 's/^ +#[0-9]+ 0x[0-9a-f]+ (in )?//')
        echo "$(basename "$c"): ${summary:-no crash on replay}"
        echo "    top: ${top:-?}"
        echo "    first sphice frame: ${own:-none}"
    done
done
