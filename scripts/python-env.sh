#!/usr/bin/env bash
# Creates the Python environment the test suite runs reference tools from (the `mcap` reader,
# pyfuzzylite, ...): <repo>/.venv with the pinned packages of scripts/requirements-test.txt.
#
# Idempotent and cheap to re-run: the venv is made only when missing, and pip runs only when
# the requirements file changed since the last successful install (a stamp in the venv holds
# its checksum). Debian's python3-venv is installed with apt-get only when `python3 -m venv`
# fails and we are root; otherwise the script says what to install.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$repo/.venv"
requirements="$repo/scripts/requirements-test.txt"
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

wanted="$(sha256sum "$requirements" | cut -d' ' -f1)"
if [[ -f "$stamp" && "$(cat "$stamp")" == "$wanted" ]]; then
    echo "python-env: $venv is up to date"
    exit 0
fi

"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$requirements"
echo "$wanted" > "$stamp"
echo "python-env: installed $requirements into $venv"
