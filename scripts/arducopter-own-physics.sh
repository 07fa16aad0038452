#!/bin/bash
# Flies tests/python/ardupilot_square.py against ArduCopter SITL on its *own* multicopter physics
# (`--model MODEL:FRAME.json`), to set beside the same flight on Kestrel's physics (`kestrel sitl
# ardupilot`, `kestrel sitl compare`). Run from the repository.
#
#   KESTREL_ARDUCOPTER=../shared/ardupilot/arducopter scripts/arducopter-own-physics.sh \
#       MODEL FRAME.json PARM[,PARM...] [NAME=VALUE ...]
#
# MODEL is SITL's frame (`x`, `hexax`, ...), FRAME.json its mass/inertia/thrust model
# (config/ardupilot/*-frame.json), the PARMs follow ArduPilot's copter.parm, and NAME=VALUE go to
# the script's environment (PLAN, TAKEOFF_M, ENGINE_FAIL_MASK, ENGINE_FAIL_AFTER_S, ESTIMATE, ...:
# see its docstring). The transcript goes to stderr, the script's JSON result line to stdout.
# SITL runs at 10x real time as instance 40 (its ports + 400) in a temporary directory.
set -euo pipefail
if [ $# -lt 3 ] || [ -z "${KESTREL_ARDUCOPTER:-}" ]; then
    sed -n '2,15p' "$0" >&2
    exit 2
fi
model=$1 frame=$2 parms=$3
shift 3
ardu=$KESTREL_ARDUCOPTER
dir=$(mktemp -d)
trap 'kill $sitl 2>/dev/null || true; rm -rf "$dir"' EXIT
cp "$frame" "$dir/frame.json"   # SITL loads the frame model by a relative path only
defaults=$(dirname "$ardu")/copter.parm
for p in ${parms//,/ }; do defaults+=",$(realpath "$p")"; done
env PLAN=config/missions/square.plan "$@" .venv/bin/python -u tests/python/ardupilot_square.py \
    > "$dir/client.log" &
client=$!
for _ in $(seq 100); do grep -q '^PORT' "$dir/client.log" 2>/dev/null && break; sleep 0.1; done
port=$(awk '/^PORT/ {print $2; exit}' "$dir/client.log")
(cd "$dir" && exec "$ardu" --model "$model:frame.json" --speedup 10 --defaults "$defaults" \
    --home 6.79710,79.90170,20,0 -w -I 40 --serial0 "udpclient:127.0.0.1:$port" > sitl.log 2>&1) &
sitl=$!
status=0
wait $client || status=$?
grep -v '^{' "$dir/client.log" >&2 || true
tail -1 "$dir/client.log"
exit $status
