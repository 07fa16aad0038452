#!/usr/bin/env bash
# Installs what building and testing Kestrel needs on a Debian machine, skipping whatever is
# already there: Debian packages with apt-get (as root, or through sudo), and, with --tests,
# the Python reference tools in <repo>/.venv.
#
#   scripts/setup.sh           # what `kestrel run` needs
#   scripts/setup.sh --tests   # plus what the test suite needs (the Python tools, mdbook)
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

# Debian packages: a C toolchain for crates with C parts (zstd), pkg-config, OpenCV 4.6 with
# clang/libclang for the `opencv` crate's bindings (stereo vision), python3-venv for the test
# references, socat for the serial-link tests (two joined pseudo-terminals), util-linux's
# `unshare` and iproute2's `ip` for the tests that fly the default config on its fixed UDP ports,
# each in a network namespace of its own (tests/gcs_mavsdk.rs, tests/gcs_instances.rs).
packages=(build-essential pkg-config python3 python3-venv clang libclang-dev libopencv-dev socat util-linux iproute2)
# The tests also check the shipped systemd unit with `systemd-analyze verify`
# (tests/process_service_manager.rs), and redraw the guide's graph pictures with Graphviz's `dot`
# (tests/docs_graphs.rs, under KESTREL_UPDATE_DOCS=1).
if [[ "${1:-}" == "--tests" ]]; then
    packages+=(systemd graphviz)
fi

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
    echo "setup: installing Debian packages: ${missing[*]}"
    if [[ "$(id -u)" -eq 0 ]]; then sudo=(); else sudo=(sudo); fi
    "${sudo[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

if ! command -v cargo >/dev/null 2>&1; then
    echo "setup: no Rust toolchain found; install one with rustup (https://rustup.rs), Rust ≥ 1.95" >&2
    exit 1
fi

if [[ "${1:-}" == "--tests" ]]; then
    "$repo/scripts/python-env.sh"
    # mdBook builds the user guide (docs/), pinned so that every machine renders and checks it
    # alike; built without its `serve` and `watch` features (a web server and a file watcher the
    # test run does not use, and most of its dependencies).
    mdbook_version=0.5.4
    if [[ "$(mdbook --version 2>/dev/null)" != "mdbook v$mdbook_version" ]]; then
        echo "setup: installing mdbook $mdbook_version"
        cargo install mdbook --version "$mdbook_version" --locked --no-default-features --features search
    fi
fi
