#!/usr/bin/env bash
# The test suite, as CI runs it: install what is missing, check formatting and lints, then run
# every test (unit, property, integration, the Python cross-checks).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$repo/scripts/setup.sh" --tests
cd "$repo"

echo "== cargo fmt --check"
cargo fmt --all -- --check
# The Zenoh bridge (`kestrel-bridge`, the binary's `zenoh` feature) and the tests that need it
# are part of the run: one build, with the feature on, rather than a second one that widens
# shared dependencies' features and rebuilds most of the workspace (README, "Zenoh").
# KESTREL_ZENOH=0 leaves them out, for a quicker run that does not touch the bridge.
exclude=()
features=(--features zenoh)
if [[ "${KESTREL_ZENOH:-1}" == "0" ]]; then
    exclude=(--exclude kestrel-bridge)
    features=()
fi
echo "== cargo clippy"
cargo clippy --workspace "${exclude[@]}" "${features[@]}" --all-targets --locked -- -D warnings
echo "== tests"
if cargo nextest --version >/dev/null 2>&1; then
    cargo nextest run --workspace "${exclude[@]}" "${features[@]}" --locked --no-fail-fast
else
    cargo test --workspace "${exclude[@]}" "${features[@]}" --locked --no-fail-fast
fi
