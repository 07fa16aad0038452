"""One ground station, several vehicles: pymavlink listening where QGroundControl listens
(`udpin:0.0.0.0:14550`) while `kestrel run --instance 0` and `--instance 1` fly their missions.

Usage: gcs_fleet.py SECONDS   (run by tests/gcs_instances.rs)

Everything comes from what pymavlink hears on 14550: per system id, its HEARTBEATs (armed or
not), its GLOBAL_POSITION_INT and its MISSION_ITEM_REACHED. A vehicle has landed when, after
climbing above 2 m, it is back below 1 m and either disarmed or silent for 3 s (`--exit-on-land`
ends its run at the disarm). It ends when every vehicle that armed has landed, or after SECONDS. The last line is one JSON object with
each system's figures: `{"systems": {"1": {...}, "2": {...}}}`.
"""

import json
import math
import sys
import time

from pymavlink import mavutil

mav = mavutil.mavlink
LIMIT_S = float(sys.argv[1])


def observe(systems, m, start):
    """Updates the figures of the system `m` came from."""
    s = systems.setdefault(m.get_srcSystem(), {
        "heartbeats": 0, "armed_seen": False, "disarmed_after_flight": False, "landed": False,
        "positions": 0, "first_position": None, "rel_alt_m": None, "max_rel_alt_m": 0.0,
        "reached": [], "east_m_from_first_of_system_1": None, "last_heard": 0.0,
    })
    s["last_heard"] = time.monotonic()
    kind = m.get_type()
    if kind == "HEARTBEAT":
        s["heartbeats"] += 1
        armed = bool(m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
        if armed and not s["armed_seen"]:
            print(f"{time.monotonic() - start:7.2f} system {m.get_srcSystem()} armed", flush=True)
        s["armed_seen"] |= armed
        if s["armed_seen"] and not armed and s["max_rel_alt_m"] > 2.0:
            s["disarmed_after_flight"] = True
    elif kind == "GLOBAL_POSITION_INT":
        s["positions"] += 1
        if s["first_position"] is None:
            s["first_position"] = [m.lat / 1e7, m.lon / 1e7]
        s["rel_alt_m"] = m.relative_alt / 1000.0
        s["max_rel_alt_m"] = max(s["max_rel_alt_m"], s["rel_alt_m"])
    elif kind == "MISSION_ITEM_REACHED":
        s["reached"].append(m.seq)


def main():
    conn = mavutil.mavlink_connection("udpin:0.0.0.0:14550", source_system=255, source_component=190)
    start = time.monotonic()
    systems = {}
    print("LISTENING 14550", flush=True)
    while time.monotonic() - start < LIMIT_S:
        m = conn.recv_match(blocking=True, timeout=0.2)
        if m is not None and m.get_srcComponent() == 1:
            observe(systems, m, start)
        now = time.monotonic()
        for sid, x in systems.items():
            down = x["max_rel_alt_m"] > 2.0 and x["rel_alt_m"] is not None and x["rel_alt_m"] < 1.0
            if down and not x["landed"] and (x["disarmed_after_flight"] or now - x["last_heard"] > 3.0):
                x["landed"] = True
                print(f"{now - start:7.2f} system {sid} landed", flush=True)
        flown = [x for x in systems.values() if x["armed_seen"]]
        if len(systems) >= 2 and len(flown) == len(systems) and all(x["landed"] for x in flown):
            break
    if 1 in systems and systems[1]["first_position"]:
        lat0, lon0 = systems[1]["first_position"]
        for s in systems.values():
            if s["first_position"]:
                lat, lon = s["first_position"]
                s["east_m_from_first_of_system_1"] = round((lon - lon0) * 111_320.0 * math.cos(math.radians(lat0)), 2)
    for s in systems.values():
        s.pop("last_heard")
    print(json.dumps({"systems": {str(k): v for k, v in sorted(systems.items())},
                      "wall_s": round(time.monotonic() - start, 1)}), flush=True)


main()
