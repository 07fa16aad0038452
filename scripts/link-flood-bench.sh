#!/usr/bin/env bash
# The flood benchmark: the control loop's period p50/p99 while the vehicle flies the square
# mission on the wall clock, quiet and under a 5000 msg/s inbound MAVLink flood, and their p99
# ratio (scripts/link_flood_bench.py says how). Extra arguments go to that script, e.g.
# `--rate 10000 --duration 60`. Builds `kestrel` in release mode and the Python venv first.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$repo/scripts/python-env.sh" >/dev/null
cd "$repo"
cargo build --release --quiet --bin kestrel
target="${CARGO_TARGET_DIR:-$repo/target}"
exec "$repo/.venv/bin/python" "$repo/scripts/link_flood_bench.py" "$target/release/kestrel" "$@"
