#!/usr/bin/env bash
# The main job: install what is missing, build Kestrel, and fly the full graph on the built-in
# simulator (config/sim.toml). Extra arguments go to `kestrel run`, e.g. `--duration 60`.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$repo/scripts/setup.sh"
cd "$repo"
exec cargo run --release --quiet --bin kestrel -- run "$@"
