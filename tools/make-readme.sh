#!/bin/sh
# Assembles README.md from docs/README.head.md, the configuration
# reference generated from the key table (build/sphice config-doc), and
# docs/README.tail.md (with the demo's results in docs/demo-results.md).
# tests/test_config fails when README.md's reference is stale.
set -eu
cd "$(dirname "$0")/.."
[ -x build/sphice ] || make -j2 build/sphice >/dev/null
tmp=README.md.tmp.$$
{
    cat docs/README.head.md
    echo "## Configuration reference"
    echo
    echo "Every key, generated from the one key table (\`sphice config-doc\`; also"
    echo "[docs/config.md](docs/config.md)). Complete examples:"
    echo "[etc/sphice.json](etc/sphice.json) (an operational Liaodong Bay service) and"
    echo "[etc/liaodong-demo.json](etc/liaodong-demo.json) (the demo)."
    echo
    build/sphice config-doc | sed '1s/^# /### /'
    if [ -f docs/demo-results.md ]; then
        awk 'FNR == NR { r = r $0 "\n"; next } /@DEMO_RESULTS@/ { printf "%s", r; next } { print }' \
            docs/demo-results.md docs/README.tail.md
    else
        sed 's/@DEMO_RESULTS@/(run `make demo`)/' docs/README.tail.md
    fi
} >"$tmp"
mv "$tmp" README.md
echo "README.md written"
