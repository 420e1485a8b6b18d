#!/usr/bin/env bash
# Behaviour snapshot: the outputs a refactoring must leave byte for byte unchanged.
#
#   scripts/behaviour.sh snapshot BIN DIR   run BIN (a fleetdyn binary) on the bundled fixtures:
#                                           the nightly pipeline, `diagnose` of every 40 t fixture
#                                           drive, and a fixed-seed proof (17 drives, 3-4 km);
#                                           writes DIR/sha256sums.txt over every output file
#   scripts/behaviour.sh rehash DIR         hash a snapshot's outputs again
#   scripts/behaviour.sh compare DIR1 DIR2  diff two snapshots; exit 1 when any file differs
#
# Typical use: snapshot the binary of the base revision and of the working tree, then compare:
#   git stash; cargo build --release; cp target/release/fleetdyn /tmp/fleetdyn-base; git stash pop
#   cargo build --release
#   scripts/behaviour.sh snapshot /tmp/fleetdyn-base out/snap-base
#   scripts/behaviour.sh snapshot target/release/fleetdyn out/snap-new
#   scripts/behaviour.sh compare out/snap-base out/snap-new
#
# Every run writes under the same relative path (out/behaviour-run), since outputs record the
# paths they were made from; DIR receives the outputs afterwards. Wall-clock times are left out
# of the hashes (scripts/behaviour_canon.py for the JSON files): the run report's Markdown
# summary and logs are not hashed, the proof summary's Markdown without its timing lines and its
# case table's seconds column, its Parquet case table not at all (the cases of proof.json with
# their times). Every other file is hashed as written.
set -euo pipefail
cd "$(dirname "$0")/.."
canon=$PWD/scripts/behaviour_canon.py

hashes() {
    (
        cd "$1"
        find fleet diagnose proof -type f ! -path '*/_state/*' ! -name summary.md |
            LC_ALL=C sort | while read -r f; do
            case "$f" in
            */run_report.json | proof/proof.json)
                echo "$(python3 "$canon" "$f" | sha256sum | cut -c1-64)  $f (times removed)"
                ;;
            proof/proof.md)
                echo "$(grep -avE 'drive-hour|time per drive' "$f" |
                    sed -E 's/\| [0-9.]+ \|$/|/' | sha256sum | cut -c1-64)  $f (times removed)"
                ;;
            proof/proof_cases.parquet) ;;
            *) sha256sum "$f" ;;
            esac
        done
    )
}

snapshot() {
    local bin dir work
    bin=$(realpath "$1")
    dir=$2
    work=out/behaviour-run
    rm -rf "$work" "$dir"
    mkdir -p "$work"
    "$bin" run pipelines/nightly.toml --out "$work/fleet" --jobs 2 >"$work/run.log" 2>&1
    for f in truck-0001.mcap truck-0002-lz4.mcap truck-0003-export.parquet truck-0004-long.parquet; do
        "$bin" diagnose --drive "fixtures/drives/$f" --vehicle fixtures/vehicles/truck-40t.toml \
            -o "$work/diagnose/${f%%.*}" >>"$work/diagnose.log" 2>&1
    done
    "$bin" prove --seed 1 --drives 17 --min-km 3 --max-km 4 --jobs 2 -o "$work/proof" \
        >"$work/proof.log" 2>&1
    hashes "$work" >"$work/sha256sums.txt"
    mkdir -p "$(dirname "$dir")"
    mv "$work" "$dir"
    echo "$(wc -l <"$dir/sha256sums.txt") files hashed into $dir/sha256sums.txt"
}

case "${1:-}" in
snapshot) snapshot "$2" "$3" ;;
rehash) hashes "$2" >"$2/sha256sums.txt" ;;
compare)
    if diff "$2/sha256sums.txt" "$3/sha256sums.txt"; then
        echo "identical: $(wc -l <"$2/sha256sums.txt") files"
    else
        exit 1
    fi
    ;;
*)
    sed -n '2,9p' "$0"
    exit 2
    ;;
esac
