#!/usr/bin/env bash
# Seeds a target's corpus from the repository's fixtures and fuzzes it for SECONDS (default
# 600), niced, with libFuzzer's final statistics; crashes land in fuzz/artifacts/TARGET/.
# Run from anywhere; the fuzzer's working folder is the repository top (pipeline_toml reads the
# vehicle files a pipeline names relative to it).
#
#   cargo +nightly fuzz build            # once (nightly, ASan + libFuzzer)
#   bash fuzz/run.sh TARGET [SECONDS [LIBFUZZER FLAGS…]]   # ingest_mcap | ingest_parquet | pipeline_toml | vehicle_toml | ingest_mdf4 | dbc_parse
set -euo pipefail
cd "$(dirname "$0")/.."
T=${1:?target}
SECS=${2:-600}
BIN=fuzz/target/x86_64-unknown-linux-gnu/release/$T
[ -x "$BIN" ] || cargo +nightly fuzz build "$T"
C=fuzz/corpus/$T
mkdir -p "$C" "fuzz/artifacts/$T"
case "$T" in
    ingest_mcap) cp -n fixtures/bad/*.mcap "$C"/ ;;
    ingest_parquet) cp -n fixtures/bad/*.parquet "$C"/ ;;
    pipeline_toml) cp -n pipelines/*.toml fixtures/bad/pipeline-*.toml "$C"/ ;;
    vehicle_toml) cp -n fixtures/vehicles/*.toml fixtures/bad/vehicle-*.toml "$C"/ ;;
    ingest_mdf4) for f in fixtures/bad/*.MF4 $(find fixtures/real -name '*.MF4'); do
            cp -n "$f" "$C/$(echo "$f" | tr / _)"; done ;;
    dbc_parse) for f in fixtures/bad/*.dbc $(find fixtures/real -name '*.dbc'); do
            cp -n "$f" "$C/$(echo "$f" | tr / _)"; done ;;
    *) echo "unknown target $T" >&2; exit 2 ;;
esac
echo "target $T, $(date -u +%FT%TZ), $SECS s, seed corpus $(ls "$C" | wc -l) files"
nice -n 10 "$BIN" "$C" -max_total_time="$SECS" -timeout=20 -rss_limit_mb=2048 -malloc_limit_mb=8192 \
    -print_final_stats=1 -artifact_prefix="fuzz/artifacts/$T/" "${@:3}"
echo "corpus after: $(ls "$C" | wc -l) files, $(du -sh "$C" | cut -f1)"
