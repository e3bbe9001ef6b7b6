#!/bin/sh
# Compares two published cycles bit for bit, apart from what names the run
# rather than the forecast (creation dates, git revision, version, paths,
# wall times). Used to show that a refactoring changes no product.
# Usage: tools/same-products.sh DIR_A DIR_B   (each one cycle's folder)
# Exit 0 when every product is identical, 1 with the differing files listed.
set -eu
[ $# -eq 2 ] || { echo "usage: $0 DIR_A DIR_B" >&2; exit 2; }
a=$1; b=$2
volatile='date_created|date_modified|date_issued|history|git|software_version|sphice_version|wall|elapsed|created|seconds_cpu|run_seconds|config_path|_NCProperties|config_sha256'
strip() { grep -vE "$volatile" | sed -e "s#$a#DIR#g" -e "s#$b#DIR#g"; }
rc=0; n=0
for fa in "$a"/*; do
    f=$(basename "$fa"); fb="$b/$f"; n=$((n + 1))
    if [ ! -e "$fb" ]; then echo "only in $a: $f"; rc=1; continue; fi
    case "$f" in
    *.nc)   ncdump -p 17,17 "$fa" | sed 1d | strip >/tmp/same.$$.a
            ncdump -p 17,17 "$fb" | sed 1d | strip >/tmp/same.$$.b ;;
    # binary products (images, GeoTIFF, GeoPackage) byte for byte: grep
    # would print only "binary file matches" for both and hide a change
    *.png|*.tif|*.tiff|*.gpkg)
            cmp -s "$fa" "$fb" || { echo "differs: $f"; rc=1; }; continue ;;
    manifest.json) # file checksums cover the volatile attributes above
            grep -vE '"(sha256|size|bytes)"' "$fa" | strip >/tmp/same.$$.a
            grep -vE '"(sha256|size|bytes)"' "$fb" | strip >/tmp/same.$$.b ;;
    *)      strip <"$fa" >/tmp/same.$$.a; strip <"$fb" >/tmp/same.$$.b ;;
    esac
    if ! cmp -s /tmp/same.$$.a /tmp/same.$$.b; then
        echo "differs: $f"; diff /tmp/same.$$.a /tmp/same.$$.b | head -8; rc=1
    fi
done
for fb in "$b"/*; do [ -e "$a/$(basename "$fb")" ] || { echo "only in $b: $(basename "$fb")"; rc=1; }; done
rm -f /tmp/same.$$.a /tmp/same.$$.b
[ $rc -eq 0 ] && echo "same-products: $n files identical"
exit $rc
