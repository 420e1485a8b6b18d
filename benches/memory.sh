#!/usr/bin/env bash
# Peak memory of the nightly pipeline, measured as the peak resident set size
# (`/usr/bin/time -v`, "Maximum resident set size") of the fleetdyn process:
#   (a) one 10-hour synthetic drive (fleetdyn synth drive, MCAP as CAN delivers it, and the
#       canonical Parquet of the same drive) through pipelines/nightly.toml, one job;
#   (b) a batch of 1 000 small synthetic drives (about 1.5 min each) through the same pipeline
#       with 2 jobs, from a manifest.
# Not part of `cargo test` (it takes minutes and a few GB of scratch disk).
#
#   bash benches/memory.sh [--drives N] [--hours H] [--keep DIR]
#
# Prints one line per measurement. Bound for (a): 1 GB. Results: docs/validation/benchmarks.md.
set -euo pipefail
cd "$(dirname "$0")/.."

DRIVES=1000
HOURS=10
KEEP=""
while [ $# -gt 0 ]; do
    case "$1" in
        --drives) DRIVES="$2"; shift 2 ;;
        --hours) HOURS="$2"; shift 2 ;;
        --keep) KEEP="$2"; shift 2 ;;
        *) echo "usage: $0 [--drives N] [--hours H] [--keep DIR]" >&2; exit 2 ;;
    esac
done
[ -x /usr/bin/time ] || { echo "needs GNU time at /usr/bin/time (apt-get install time)" >&2; exit 2; }
cargo build --release >&2
BIN=$PWD/target/release/fleetdyn
if [ -n "$KEEP" ]; then
    WORK=$KEEP
    mkdir -p "$WORK"
else
    WORK=$(mktemp -d)
    trap 'rm -rf "$WORK"' EXIT
fi

# Peak RSS (MiB) and wall time (s) of a command; its own output goes to $WORK/last.log.
measure() {
    local label=$1
    shift
    /usr/bin/time -v -o "$WORK/time.txt" "$@" >"$WORK/last.log" 2>&1 || {
        local rc=$?
        # `fleetdyn run` exits 1 when a drive failed; that is reported, not fatal here
        [ "$rc" = 1 ] || { cat "$WORK/last.log" >&2; exit "$rc"; }
    }
    local kb wall
    kb=$(awk -F: '/Maximum resident set size/ {gsub(/ /, "", $2); print $2}' "$WORK/time.txt")
    wall=$(awk '/Elapsed \(wall clock\)/ {print $NF}' "$WORK/time.txt")
    printf '%-58s peak RSS %7.1f MiB   wall %s\n' "$label" "$(echo "$kb / 1024" | bc -l)" "$wall"
}

nightly() {
    # nightly.toml with a default vehicle file (the synthetic drives carry their own ids) and its
    # physics stages only: the diagnose and fleet stages and their tables left out (the
    # diagnosis's own cost is benches/diagnose.rs)
    sed -e 's|^\[vehicles\]|vehicle = "fixtures/vehicles/truck-40t.toml"\n[vehicles]|' \
        -e 's/"validate", "diagnose", "write", "fleet"/"validate", "write"/' \
        -e 's/"mismatch", "findings", "parameter_estimates", //' \
        -e '/^\[diagnose\]/,/^$/d' \
        pipelines/nightly.toml >"$WORK/nightly.toml"
    echo "$WORK/nightly.toml"
}
PIPE=$(nightly)

# ---- (a) one long drive ------------------------------------------------------------------
# highway-se road, a stop every 25 km, until the drive has lasted HOURS hours: about 78 km/h
# average, so 78 * HOURS km (the duration check below prints the real figure)
LEN_KM=$((78 * HOURS))
if [ ! -f "$WORK/long/drive.mcap" ]; then
    measure "synth drive ${LEN_KM} km (generator, for reference)" \
        "$BIN" synth drive --vehicle fixtures/vehicles/truck-40t.toml --rules highway-se \
        --length-km "$LEN_KM" --stop-every-km 25 --seed 9 --max-duration-s $((HOURS * 3600 + 7200)) \
        --drive-id long-drive --vehicle-id TRK-0001 -o "$WORK/long"
fi
"$BIN" ingest "$WORK/long/drive.parquet" | grep -E '^(duration|distance)' | sed 's/^/  long drive: /'
ls -l "$WORK/long/drive.mcap" "$WORK/long/drive.parquet" | awk '{printf "  %s %.1f MB\n", $NF, $5/1e6}'
for f in drive.mcap drive.parquet; do
    measure "(a) nightly, 1 job, long drive $f" \
        "$BIN" run "$PIPE" --input "$WORK/long/$f" --out "$WORK/out-long-${f//./-}" --jobs 1 --force
    grep -E 'processed|FAILED' "$WORK/last.log" | sed 's/^/  /'
done
measure "    ingest alone, long drive drive.mcap" \
    "$BIN" ingest "$WORK/long/drive.mcap" --stages slope,driveline

# ---- (b) many small drives -----------------------------------------------------------------
mkdir -p "$WORK/small"
if [ ! -f "$WORK/small/drives.csv" ]; then
    echo "path,vehicle_id" >"$WORK/small/drives.csv.tmp"
    for i in $(seq 1 "$DRIVES"); do
        id=$(printf 'small-%04d' "$i")
        "$BIN" synth drive --vehicle fixtures/vehicles/truck-40t.toml --rules highway-se \
            --length-km 1.5 --stop-every-km 0 --seed "$i" --drive-id "$id" \
            --vehicle-id "TRK-$((i % 50))" -o "$WORK/small/$id" >/dev/null
        mv "$WORK/small/$id/drive.mcap" "$WORK/small/$id.mcap"
        rm -rf "${WORK:?}/small/$id"
        echo "$id.mcap,TRK-$((i % 50))" >>"$WORK/small/drives.csv.tmp"
    done
    mv "$WORK/small/drives.csv.tmp" "$WORK/small/drives.csv"
fi
du -sh "$WORK/small" | awk '{print "  small drives: " $1}'
measure "(b) nightly, 2 jobs, $DRIVES small drives" \
    "$BIN" run "$PIPE" --input "$WORK/small/drives.csv" --out "$WORK/out-small" --jobs 2 --force
grep -E 'processed' "$WORK/last.log" | sed 's/^/  /'
