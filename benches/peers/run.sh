#!/usr/bin/env bash
# The side-by-side comparison of fleetdyn with its Python peers, in one command:
#   bash benches/peers/run.sh [--repeats R] [--n N] [--driveline-s T] [--only S,S] [--markdown FILE]
# Makes its own venv (.venv-peers, ignored) with the pinned peers, builds fleetdyn's side
# (benches/peers/peer_side.rs, release), runs the same inputs through both, checks the outputs
# agree and prints the table (benches/peers/peers.py says what is compared and how).
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=.venv-peers
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
# a no-op when the pinned versions are already there
"$VENV/bin/pip" install --quiet --disable-pip-version-check -r benches/peers/requirements.txt
cargo build --release --quiet --example peer_side
exec "$VENV/bin/python" benches/peers/peers.py --fleetdyn target/release/examples/peer_side "$@"
