"""Changes the mission of a vehicle flying it in AUTO, as an operator does from a ground station,
and reports what the vehicle then does. Written once, run against ArduCopter SITL and against
`kestrel run` (tests/gcs_mission_change.rs), which compares the two reports.

Usage: mission_change.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)

1. identify the vehicle, ask for its telemetry streams (ArduCopter sends only what is asked for);
2. upload mission A: home, take-off to 10 m, waypoints A1 and A2 (items 2 and 3);
3. GUIDED and arm (each retried until the vehicle's checks pass), take off to 10 m, AUTO
   (ArduCopter on its defaults takes off in AUTO only once the pilot raises the throttle);
4. once MISSION_CURRENT says item 3 (A2) is flown, upload mission B, one item longer, whose
   items 2, 3 and 4 (B1, B2, B3) are elsewhere: record the MISSION_ACK, MISSION_CURRENT after it, the
   next MISSION_ITEM_REACHED and where the vehicle was then (which waypoint it flew to), and
   what a download returns;
5. while flying item 4 of B (B3), upload mission C of 3 items (home, take-off, C1), shorter
   than the index being flown: the same record;
6. LAND, and wait until landed and disarmed.

The last line's `results.change` and `results.shorter` hold each record: `ack` (MAV_MISSION_RESULT
name), `current_before` (MISSION_CURRENT seq when the upload began), `currents_after` (each
MISSION_CURRENT seq from the ACK until the next item is reached) and `current_after` (the last of
them), `reached` (seq of the next MISSION_ITEM_REACHED, or null), `flew_to` (the named waypoint
within 5 m of the vehicle when that item was reached, or when it stopped moving), `download` (the
named waypoint of each item past the take-off that a download returns).
"""

import math
import time

from gcs_common import (ACM_MODES, arm_in_guided, distance_m, download, Failed, item_int, main, mav,
                        upload, VEHICLE)

HOME = (6.79710, 79.90170)
TAKEOFF_M = 10.0
M_PER_DEG = 111_320.0


def offset(north_m, east_m):
    """(lat, lon) `north_m`, `east_m` from HOME (flat earth, as distance_m measures)."""
    return (HOME[0] + north_m / M_PER_DEG,
            HOME[1] + east_m / (M_PER_DEG * math.cos(math.radians(HOME[0]))))


# Far enough apart (60 m legs) that the vehicle is still on its way to A2 when the new mission's
# upload has completed, whatever the speed-up.
WAYPOINTS = {
    "A1": offset(60.0, 0.0),
    "A2": offset(60.0, 60.0),
    "B1": offset(0.0, -60.0),
    "B2": offset(-60.0, -60.0),
    "B3": offset(-60.0, 0.0),
    "C1": offset(-40.0, 30.0),
}


def mission(*names):
    """Home, a take-off to TAKEOFF_M, then a waypoint at TAKEOFF_M for each name."""
    items = [item_int(mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL, at=HOME, alt=20.0),
             item_int(mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, at=HOME,
                      alt=TAKEOFF_M)]
    items += [item_int(mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                       at=WAYPOINTS[n], alt=TAKEOFF_M) for n in names]
    return items


def nearest(position, limit_m=5.0):
    """The named waypoint within `limit_m` of `position`, or None."""
    name, d = min(((n, distance_m(position, p)) for n, p in WAYPOINTS.items()), key=lambda x: x[1])
    return name if d <= limit_m else None


def upload_said(gcs, items, step):
    """The mission upload; the MISSION_ACK's result name and the STATUSTEXTs that came meanwhile."""
    texts_before = len(gcs.statustexts)
    return upload(gcs, items, step), gcs.statustexts[texts_before:]


def download_names(gcs, step):
    """The stored mission's items past the take-off, each as the named waypoint it is at."""
    names = [nearest((m.x / 1e7, m.y / 1e7), 1.0) or f"({m.x},{m.y})" for m in download(gcs, step)[2:]]
    gcs.log(f"downloaded: {names} past the take-off")
    return names


def change(gcs, items, step):
    """Uploads `items` while flying, then follows the vehicle to its next reached item (or to
    where it stops, a mission over)."""
    before = gcs.mission_current
    reached_before = len(gcs.reached)
    ack, texts = upload_said(gcs, items, step)
    gcs.log(f"{step}: MISSION_ACK {ack} while flying item {before}; said {texts}")
    # MISSION_CURRENT from the ACK on: the last one before the item is reached is the item the
    # vehicle flew to.
    currents = []
    stopped_since = None

    def arrived(m):
        nonlocal stopped_since
        if len(gcs.reached) > reached_before:
            return True
        if m.get_type() == "MISSION_CURRENT" and gcs.from_vehicle(m) and currents[-1:] != [m.seq]:
            currents.append(m.seq)
        if m.get_type() == "GLOBAL_POSITION_INT" and gcs.from_vehicle(m):
            if math.hypot(m.vx, m.vy) < 20:  # cm/s
                stopped_since = stopped_since or time.monotonic()
            else:
                stopped_since = None
            return stopped_since is not None and time.monotonic() - stopped_since > 2.0
        return False

    gcs.pump(arrived, 30.0, f"{step}: next waypoint")
    reached = gcs.reached[reached_before] if len(gcs.reached) > reached_before else None
    record = {
        "ack": ack,
        "current_before": before,
        "currents_after": currents,
        "current_after": currents[-1] if currents else before,
        "reached": reached,
        "flew_to": nearest(gcs.position),
        "statustext": texts,
    }
    gcs.log(f"{step}: MISSION_CURRENT {currents}, reached {reached} at {record['flew_to']} "
            f"({ {n: round(distance_m(gcs.position, p), 1) for n, p in WAYPOINTS.items()} })")
    record["download"] = download_names(gcs, f"{step}: download")
    return record


def flight(gcs):
    gcs.identify()
    # ArduCopter streams on a port only what is asked for (REQUEST_DATA_STREAM, 10 Hz).
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 10, 1)
    ack = upload(gcs, mission("A1", "A2"), "upload A")
    if ack != "MAV_MISSION_ACCEPTED":
        raise Failed("upload A", ack)
    arm_in_guided(gcs)
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 1.0, 30.0, "take-off")
    gcs.set_mode_command("AUTO", "auto")
    gcs.log("flying mission A")
    gcs.pump(lambda m: gcs.mission_current == 3, 40.0, "flying to A2")
    gcs.results["reached_before"] = list(gcs.reached)

    gcs.results["change"] = change(gcs, mission("B1", "B2", "B3"), "change")
    gcs.pump(lambda m: gcs.mission_current == 4 and gcs.mode == "AUTO", 5.0, "flying to B3")
    gcs.results["shorter"] = change(gcs, mission("C1"), "shorter")

    gcs.set_mode_command("LAND", "land")
    gcs.pump(lambda m: gcs.heartbeat is not None and not gcs.armed, 40.0, "landed and disarmed")
    gcs.results["reached"] = gcs.reached
    gcs.results["modes"] = [m for m in gcs.modes_seen if m in ACM_MODES]


main(flight, deadline_s=110.0)
