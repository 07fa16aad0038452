"""The flood benchmark: does 5000 inbound MAVLink messages per second slow the control loop?

Usage: link_flood_bench.py KESTREL [--rate 5000] [--duration 40] [--plan config/missions/square.plan]
(scripts/link-flood-bench.sh builds KESTREL in release mode and calls this.)

Flies the same mission twice on the simulator with the wall clock (`clock = "realtime"`) and the
controller on its own 400 Hz thread (`loop_mode = "thread"`), so the loop period is real time,
not simulated time: once quiet, once while a sender floods the link's UDP server with valid
HEARTBEAT (as a ground station), PARAM_REQUEST_READ (each answered) and MANUAL_CONTROL frames.
Prints the control period p50/p99/max and overruns of both runs (from `--report`), the ratio of
the p99s, and the link's own counters, then one JSON line with everything.
"""

import argparse
import json
import os
import pathlib
import re
import socket
import subprocess
import sys
import tempfile
import threading
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

REPO = pathlib.Path(__file__).resolve().parent.parent


def config_text(port):
    """config/sim.toml on the wall clock, the controller on its thread, and the link serving UDP
    on 127.0.0.1:`port` only (no telemetry to 14550, which a ground station on this machine may
    be using)."""
    text = (REPO / "config/sim.toml").read_text()
    config_dir = REPO / "config"
    out, section = [], ""
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("["):
            section = stripped
        if section == "[run]" and stripped.startswith("clock ="):
            line = 'clock = "realtime"'
        if section == "[actors.controller]" and stripped.startswith("params ="):
            line = 'params = { loop_mode = "thread" }'
        if section == "[actors.sim]" and stripped.startswith("params ="):
            for key in ("vehicle", "world"):
                line = line.replace(f'{key} = "', f'{key} = "{config_dir}/')
        out.append(line)
        if section == "[actors.link]" and stripped.startswith("type ="):
            out.append(f'params.endpoints = [ {{ type = "udp_in", bind = "127.0.0.1:{port}" }} ]')
    return "\n".join(out) + "\n"


def flood_frames():
    """One of each flood message, encoded once (MAVLink 2, from a ground station 255/190)."""
    mav = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    msgs = [
        mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0),
        mav.param_request_read_encode(1, 1, b"RTL_ALT_M", -1),
        mav.manual_control_encode(1, 0, 0, 500, 0, 0),
    ]
    return [bytes(m.pack(mav)) for m in msgs]


def flood(port, rate, stop, counts):
    """Sends `rate` frames per second to 127.0.0.1:`port` in bursts every 10 ms until `stop`."""
    frames = flood_frames()
    per_tick = max(1, rate // 100)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sent, started = 0, time.monotonic()
    next_tick = started
    while not stop.is_set():
        for _ in range(per_tick):
            sock.sendto(frames[sent % len(frames)], ("127.0.0.1", port))
            sent += 1
        next_tick += 0.01
        delay = next_tick - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    counts["sent"] = sent
    counts["seconds"] = time.monotonic() - started


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def fly(kestrel, plan, duration_s, rate, workdir, label):
    port = free_udp_port()
    config = workdir / f"{label}.toml"
    config.write_text(config_text(port))
    report = workdir / f"{label}.json"
    log = workdir / f"{label}.log"
    with open(log, "w") as err:
        proc = subprocess.Popen(
            [kestrel, "run", "--quiet", "--config", str(config), "--mission", str(plan), "--auto",
             "--duration", str(duration_s), "--report", str(report)],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err, cwd=workdir)
        counts, stop = {}, threading.Event()
        sender = None
        if rate > 0:
            time.sleep(1.0)  # the endpoint is open well within a second
            sender = threading.Thread(target=flood, args=(port, rate, stop, counts))
            sender.start()
        code = proc.wait(timeout=duration_s + 60)
        stop.set()
        if sender:
            sender.join()
    text = log.read_text()
    if code != 0 or not report.exists():
        sys.exit(f"{label}: kestrel exited {code}\n" + "\n".join(text.splitlines()[-20:]))
    result = json.loads(report.read_text())
    links = re.findall(r"MAVLink link counters link=(.*?) stats=LinkStats \{ (.*?) \}", text)
    return {
        "control": result["control"],
        "mission": result["mission"],
        "flood": {
            "sent": counts.get("sent", 0),
            "rate_msg_s": round(counts["sent"] / counts["seconds"]) if counts else 0,
        },
        "links": [f"{name}: {stats}" for name, stats in links],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kestrel")
    ap.add_argument("--rate", type=int, default=5000, help="flood messages per second")
    ap.add_argument("--duration", type=float, default=40.0, help="seconds per run")
    ap.add_argument("--plan", default=str(REPO / "config/missions/square.plan"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="kestrel-flood-") as tmp:
        workdir = pathlib.Path(tmp)
        quiet = fly(args.kestrel, args.plan, args.duration, 0, workdir, "quiet")
        flooded = fly(args.kestrel, args.plan, args.duration, args.rate, workdir, "flood")
    print(f"{'run':<8} {'p50 us':>9} {'p99 us':>9} {'max us':>9} {'overruns':>9}  mission reached")
    for label, r in (("quiet", quiet), ("flood", flooded)):
        c, m = r["control"], r["mission"]
        print(f"{label:<8} {c['period_p50_us']:>9.1f} {c['period_p99_us']:>9.1f} "
              f"{c.get('period_max_us', float('nan')):>9.1f} {c['overruns']:>9}  "
              f"{m['items_reached']}/{m['items_total']}")
    ratio = flooded["control"]["period_p99_us"] / quiet["control"]["period_p99_us"]
    print(f"flood: {flooded['flood']['sent']} frames at {flooded['flood']['rate_msg_s']} msg/s")
    for line in flooded["links"]:
        print(f"  link {line}")
    print(f"p99 ratio flood/quiet: {ratio:.3f}")
    print(json.dumps({"quiet": quiet, "flood": flooded, "p99_ratio": round(ratio, 4)}))


if __name__ == "__main__":
    main()
