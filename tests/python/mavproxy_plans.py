"""MAVProxy's plan and log commands as an operator types them, written once and run against
`kestrel run` and ArduCopter SITL (tests/gcs_mavproxy_plans.rs compares the two).

Usage: mavproxy_plans.py   (prints `PORT <n>` first; see mavproxy_session.py for the transcript)

1. MAVProxy detects the vehicle and fetches its parameters by itself;
2. GUIDED and `arm throttle` (typed again until taken, once SYS_STATUS says the vehicle is
   armable), a moment armed, `disarm`: one log on the vehicle;
3. `log list`, `log download latest FILE`: the file MAVProxy writes, opened with the reader of
   its format (the `mcap` reader for an MCAP log, pymavlink's DFReader for a DataFlash `.bin`)
   and, with LOG_DIR set (the vehicle's log directory, when the test can read it), compared
   with the newest log there byte for byte;
4. `fence load` of a fence file (an inclusion square, an exclusion circle and triangle, an
   inclusion circle and a return point), `rally load` of two rally points and `wp load` of
   config/missions/survey.plan converted to the waypoint file MAVProxy loads (QGroundControl's
   `QGC WPL 110`, the survey's camera items in place): each upload's MISSION_ACK as MAVProxy
   prints it; then `fence list`, `rally list` and `wp list`, which download the plan and save
   it in MAVProxy's log directory: each saved file compared item by item with the file loaded.

The last line's `results` holds `params` (count MAVProxy received), `plans` (per kind: `ack`,
`loaded`, `listed`, `differences`: what a listed item has that the loaded one has not) and
`log` (`entries` as `log list` printed them, `bytes`, `format`, what the reader found, and with
LOG_DIR `equal`).
"""

import json
import math
import os
import struct
import time

from mavproxy_session import Failed, run
from read_mcap import topic_span

REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
HOME = (6.79710, 79.90170)
M_PER_DEG = 111_320.0
# MAV_FRAME and MAV_CMD numbers of the plan files (QGC WPL 110 holds numbers).
GLOBAL, GLOBAL_RELATIVE_ALT = 0, 3
POLY_INCLUSION, POLY_EXCLUSION, CIRCLE_INCLUSION, CIRCLE_EXCLUSION, RETURN_POINT = 5001, 5002, 5004, 5003, 5000
RALLY_POINT = 5100
# MAV_SYS_STATUS_PREARM_CHECK: SYS_STATUS's health bit for "the pre-arm checks pass".
PREARM_CHECK = 0x10000000
# MAVProxy writes a listed plan with `%f`: positions to 1e-6 degree (11 cm), values to 1e-6.
SAVED_DEG = 1.01e-6
SAVED_VALUE = 1.01e-6


def offset(north_m, east_m):
    """(lat, lon) `north_m`, `east_m` from HOME (flat earth)."""
    return (HOME[0] + north_m / M_PER_DEG,
            HOME[1] + east_m / (M_PER_DEG * math.cos(math.radians(HOME[0]))))


def line(seq, frame, command, params, at, alt, current=0, autocontinue=1):
    """One QGC WPL 110 line: seq, current, frame, command, param1..4, lat, lon, alt, autocontinue."""
    values = [seq, current, frame, command, *params, *at, alt, autocontinue]
    return "\t".join(str(v) if isinstance(v, int) else f"{v:.8f}" for v in values)


def fence_lines():
    square = [offset(n, e) for n, e in ((-100, -100), (100, -100), (100, 100), (-100, 100))]
    triangle = [offset(n, e) for n, e in ((-60, 40), (-40, 60), (-60, 60))]
    items = [(POLY_INCLUSION, (4, 0, 0, 0), at) for at in square]
    items += [(CIRCLE_EXCLUSION, (15, 0, 0, 0), offset(50, 0))]
    items += [(POLY_EXCLUSION, (3, 0, 0, 0), at) for at in triangle]
    items += [(CIRCLE_INCLUSION, (250, 0, 0, 0), HOME), (RETURN_POINT, (0, 0, 0, 0), offset(10, 10))]
    return [line(seq, GLOBAL, cmd, params, at, 0.0) for seq, (cmd, params, at) in enumerate(items)]


def rally_lines():
    points = [(offset(40, 0), 15.0), (offset(-30, 20), 12.0)]
    return [line(seq, GLOBAL_RELATIVE_ALT, RALLY_POINT, (0, 0, 0, 0), at, alt)
            for seq, (at, alt) in enumerate(points)]


def survey_lines():
    """config/missions/survey.plan as the waypoint file QGroundControl exports: home as item 0
    (current), then each SimpleItem and each complex item's saved `Items`, in order; a `null`
    parameter (QGroundControl's "unchanged") as NaN."""
    with open(os.path.join(REPO, "config", "missions", "survey.plan")) as f:
        plan = json.load(f)["mission"]
    lat, lon, alt = plan["plannedHomePosition"]
    lines = [line(0, GLOBAL, 16, (0, 0, 0, 0), (lat, lon), float(alt), current=1)]
    simple = []
    for it in plan["items"]:
        simple += it["TransectStyleComplexItem"]["Items"] if it["type"] == "ComplexItem" else [it]
    for seq, it in enumerate(simple, start=1):
        p = [math.nan if v is None else float(v) for v in it["params"]]
        lines.append(line(seq, it["frame"], it["command"], p[:4], (p[4], p[5]), p[6],
                          autocontinue=int(it["autoContinue"])))
    return lines


def write_plan(path, lines):
    with open(path, "w") as f:
        f.write("QGC WPL 110\n" + "\n".join(lines) + "\n")


def read_plan(path):
    """A QGC WPL 110 file: per item (frame, command, [param1..4], lat, lon, alt)."""
    with open(path) as f:
        rows = [l.split() for l in f.read().splitlines()[1:] if l.strip() and not l.startswith("#")]
    return [(int(r[2]), int(r[3]), [float(v) for v in r[4:8]], float(r[8]), float(r[9]), float(r[10]))
            for r in rows]


def f32(v):
    return struct.unpack("<f", struct.pack("<f", v))[0]


def same(a, b, tol):
    return (math.isnan(a) and math.isnan(b)) or abs(a - b) <= tol


def differences(loaded, listed):
    """What each listed item has that the loaded one had not: a value sent as float32 and
    written back with `%f`, or a position MAVProxy sent as 1e-7 degree (truncating) and wrote
    back to 1e-6, counts as the same."""
    if len(loaded) != len(listed):
        return [f"{len(listed)} items listed, {len(loaded)} loaded"]
    out = []
    for seq, (a, b) in enumerate(zip(loaded, listed)):
        if a[:2] != b[:2]:
            out.append(f"item {seq}: frame, command {b[:2]}, loaded {a[:2]}")
            continue
        for i, (p, q) in enumerate(zip(a[2], b[2]), start=1):
            if not same(f32(p), q, SAVED_VALUE + abs(q) * 1e-7):
                out.append(f"item {seq}: param{i} {q}, loaded {p}")
        for name, p, q, tol in (("lat", a[3], b[3], SAVED_DEG), ("lon", a[4], b[4], SAVED_DEG),
                                ("alt", f32(a[5]), b[5], SAVED_VALUE + abs(a[5]) * 1e-7)):
            if not same(p, q, tol):
                out.append(f"item {seq}: {name} {q}, loaded {p}")
    return out


PLANS = [
    # (module, MAVProxy's word for its items, MISSION_ACK's mission type, file, lines)
    ("fence", "fence items", "TYPE_FENCE", "fence.txt", fence_lines),
    ("rally", "rally items", "TYPE_RALLY", "rally.txt", rally_lines),
    ("wp", "waypoints", "TYPE_MISSION", "survey.waypoints", survey_lines),
]


def plan_round_trip(mp, module, items, mission_type, path):
    """`MODULE load PATH` and its MISSION_ACK, `MODULE list` and the file it saves."""
    mp.type(f"{module} load {path}")
    loaded = int(mp.expect(rf"^Loaded (\d+) {items} from", 5.0, f"{module} load").group(1))
    # The vehicle's answer to the whole upload is the ACK after the last item went out; one
    # before it answers an item repeated while the vehicle asked again (ArduCopter at 10x
    # speed-up asks again sooner than MAVProxy answers, and says INVALID_SEQUENCE to the late one).
    mp.expect(rf"^Sent all {loaded} {items}", 10.0, f"{module} upload")
    ack = mp.expect(rf"^Got MISSION_ACK: {mission_type}: (\w+)", 10.0, f"{module} ack").group(1)
    mp.type(f"{module} list")
    saved = mp.expect(rf"^Saved (\d+) {items} to (\S+)", 10.0, f"{module} list")
    listed = read_plan(saved.group(2))
    return {"ack": ack, "loaded": loaded, "listed": int(saved.group(1)),
            "differences": differences(read_plan(path), listed)}


def arm(mp, timeout_s):
    """GUIDED (typed again until taken); then, once SYS_STATUS says the vehicle is armable (its
    pre-arm check bit, what MAVProxy's console shows as "pre-arm good"), `arm throttle`, typed
    again until taken. Waiting first matters: ArduCopter logs from an arming attempt on, and
    keeps logging 15 s after one fails, so arming early would make the log to download long."""
    end = time.monotonic() + timeout_s
    while True:
        mp.type("mode GUIDED")
        # The ACK, or the mode shown (a vehicle already in GUIDED shows no change).
        shown = mp.expect(r"^Got COMMAND_ACK: DO_SET_MODE: (\w+)|^Mode GUIDED", 5.0, "guided")
        if shown.group(1) in (None, "ACCEPTED"):
            break
        if time.monotonic() > end:
            raise Failed("guided", f"refused for {timeout_s} s: {mp.seen[-3:]}")
        time.sleep(1.0)
    # The bit is worked out once a second of the vehicle's time (ArduCopter), the first one after
    # the mode change may still be for the mode before.
    time.sleep(0.5)
    while True:
        mp.type("status SYS_STATUS")
        health = int(mp.expect(r"SYS_STATUS \{.*onboard_control_sensors_health : (\d+)", 5.0,
                               "armable").group(1))
        if health & PREARM_CHECK:
            break
        if time.monotonic() > end:
            raise Failed("armable", f"SYS_STATUS health 0x{health:x} for {timeout_s} s")
        time.sleep(0.5)
    while True:
        mp.type("arm throttle")
        if mp.expect(r"^Got COMMAND_ACK: COMPONENT_ARM_DISARM: (\w+)", 5.0, "arm").group(1) == "ACCEPTED":
            break
        if time.monotonic() > end:
            raise Failed("arm", f"refused for {timeout_s} s: {mp.seen[-3:]}")
        time.sleep(1.0)
    mp.expect(r"^ARMED", 5.0, "armed shown")


def open_log(path):
    """What the reader of the log's format finds in it."""
    with open(path, "rb") as f:
        magic = f.read(8)
    if magic == b"\x89MCAP0\r\n":
        span = topic_span(path, "vehicle_status")
        return {"format": "mcap", "topics": len(span["topics"]),
                "first_armed": (span["first"] or {}).get("armed"),
                "last_armed": (span["last"] or {}).get("armed")}
    if magic[:2] == b"\xa3\x95":
        from pymavlink import DFReader
        log = DFReader.DFReader_binary(path)
        kinds = {}
        while True:
            m = log.recv_msg()
            if m is None:
                break
            kinds[m.get_type()] = kinds.get(m.get_type(), 0) + 1
        return {"format": "dataflash", "types": len(kinds), "messages": sum(kinds.values()),
                "params": kinds.get("PARM", 0), "arm_events": kinds.get("ARM", 0)}
    return {"format": f"unknown magic {magic!r}"}


def plans(mp, results):
    mp.expect(r"^Detected vehicle 1:1 on link 0", 20.0, "detect")
    results["params"] = int(mp.expect(r"^Received (\d+) parameters", 30.0, "parameter download").group(1))

    arm(mp, 40.0)
    # A short log: ArduCopter logs some 100 kB per second of its time, which MAVProxy downloads
    # from SITL at tens of kB per second of ours.
    time.sleep(0.3)
    mp.type("disarm")
    mp.expect(r"^DISARMED", 5.0, "disarmed shown")

    mp.type("log list")
    entries = []
    while not entries or entries[-1]["id"] != entries[-1]["last"]:
        m = mp.expect(r"^Log (\d+)\s+numLogs (\d+) lastLog (\d+) size (\d+)", 5.0, "log list")
        entries.append(dict(zip(("id", "num", "last", "size"), map(int, m.groups()))))
    log_path = os.path.join(mp.state_dir, "latest.log")
    mp.type(f"log download latest {log_path}")
    done = None
    end = time.monotonic() + 60.0
    while done is None:
        try:
            done = mp.expect(rf"^Finished downloading {log_path} \((\d+) bytes", 5.0, "log download")
        except Failed:
            if time.monotonic() > end:
                raise
            # What an operator watching a long download types: the bytes so far, in the transcript.
            mp.type("log status")
    log = {"entries": entries, "bytes": int(done.group(1))}
    log.update(open_log(log_path))
    log_dir = os.environ.get("LOG_DIR")
    if log_dir:
        newest = sorted(n for n in os.listdir(log_dir) if n.endswith(".mcap"))[-1]
        with open(os.path.join(log_dir, newest), "rb") as a, open(log_path, "rb") as b:
            log["equal"] = a.read() == b.read()
    results["log"] = log

    results["plans"] = {}
    for module, items, mission_type, name, lines in PLANS:
        path = os.path.join(mp.state_dir, name)
        write_plan(path, lines())
        results["plans"][module] = plan_round_trip(mp, module, items, mission_type, path)


if __name__ == "__main__":
    run(plans, 120.0)
