#!/usr/bin/env bash
# Creates the Python environment the test suite runs reference tools from (the `mcap` reader,
# pyfuzzylite, pymavlink, MAVProxy, ...): <repo>/.venv with the pinned packages of
# scripts/requirements-test.txt, then those of scripts/requirements-mavproxy.txt without their
# declared dependencies (see that file for why).
#
# Idempotent and cheap to re-run: the venv is made only when missing, and pip runs only when
# a requirements file changed since the last successful install (a stamp in the venv holds
# their checksums). Debian's python3-venv is installed with apt-get only when `python3 -m venv`
# fails and we are root; otherwise the script says what to install.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$repo/.venv"
requirements="$repo/scripts/requirements-test.txt"
no_deps_requirements="$repo/scripts/requirements-mavproxy.txt"
stamp="$venv/.requirements-test.sha256"

make_venv() {
    python3 -m venv "$venv"
}

if [[ ! -x "$venv/bin/python" ]]; then
    rm -rf "$venv"
    if ! make_venv; then
        rm -rf "$venv"
        if [[ "$(id -u)" -ne 0 ]]; then
            echo "python-env: 'python3 -m venv' failed; install Debian's python3-venv (sudo apt-get install python3-venv) and re-run" >&2
            exit 1
        fi
        echo "python-env: 'python3 -m venv' failed; installing python3-venv with apt-get" >&2
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv
        make_venv
    fi
fi

wanted="$(cat "$requirements" "$no_deps_requirements" | sha256sum | cut -d' ' -f1)"
if [[ -f "$stamp" && "$(cat "$stamp")" == "$wanted" ]]; then
    echo "python-env: $venv is up to date"
    exit 0
fi

"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$requirements"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps -r "$no_deps_requirements"
echo "$wanted" > "$stamp"
echo "python-env: installed $requirements and $no_deps_requirements into $venv"
