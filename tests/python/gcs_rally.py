"""Rally points and RTL as a ground station uses them, written once and run against ArduCopter
SITL and against `kestrel run` (tests/gcs_rally.rs compares the two).

Usage: gcs_rally.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)

1. identify the vehicle, ask for its telemetry streams; read RALLY_LIMIT_KM and RALLY_INCL_HOME
   (left on their defaults);
2. a rally plan holding a waypoint: its MISSION_ACK;
3. the rally points: R1 40 m north of home, 15 m up, and R2 400 m east, 20 m up (beyond
   RALLY_LIMIT_KM of anywhere the vehicle flies); the MISSION_ACK and the download;
4. GUIDED and armed (asked again until taken), take-off to 10 m, DO_REPOSITION 60 m north: from
   there R1 is 20 m away and home 60 m, so R1 is where RTL goes (home counts, and is farther);
5. RTL: its ACK, then followed until landed and disarmed: where the vehicle came down (its
   distance from R1 and from home) and the highest it flew on the way.

The last line's `results` holds `params` (name: value), `acks` (step: MISSION_ACK or
COMMAND_ACK result name), `downloaded` (each rally point as [lat 1e-7 deg, lon, alt m]),
`rtl_from_m` (where RTL started: distance from R1 and home), `landed` (distance from R1 and
home, m) and `max_alt_m`.
"""

import math

from gcs_common import (ACM_MODES, arm_in_guided, distance_m, download, enum_name, Failed,
                        item_int, main, mav, upload, VEHICLE)

HOME = (6.79710, 79.90170)
TAKEOFF_M = 10.0
M_PER_DEG = 111_320.0


def offset(north_m, east_m):
    """(lat, lon) `north_m`, `east_m` from HOME (flat earth, as distance_m measures)."""
    return (HOME[0] + north_m / M_PER_DEG,
            HOME[1] + east_m / (M_PER_DEG * math.cos(math.radians(HOME[0]))))


R1 = offset(40.0, 0.0)
R2 = offset(0.0, 400.0)
AWAY = offset(60.0, 0.0)
RALLY = [item_int(mav.MAV_CMD_NAV_RALLY_POINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, at=R1, alt=15.0),
         item_int(mav.MAV_CMD_NAV_RALLY_POINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, at=R2, alt=20.0)]
NOT_RALLY = [item_int(mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, at=R1, alt=15.0)]


def command_ack(gcs, cmd, params, step):
    """COMMAND_LONG and its COMMAND_ACK's result name."""
    p = list(params) + [0.0] * (7 - len(params))
    gcs.log(f"-> COMMAND_LONG {enum_name('MAV_CMD', cmd)} {p}")
    gcs.conn.mav.command_long_send(*VEHICLE, cmd, 0, *p)
    ack = gcs.wait_type("COMMAND_ACK", 3.0, step, lambda m: m.command == cmd)
    return enum_name("MAV_RESULT", ack.result)


def reposition(gcs, at, alt_m, step):
    """DO_REPOSITION (COMMAND_INT, relative altitude) as QGroundControl's "Go to location"."""
    gcs.log(f"-> COMMAND_INT DO_REPOSITION {at} {alt_m} m")
    gcs.conn.mav.command_int_send(*VEHICLE, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                  mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, math.nan,
                                  int(round(at[0] * 1e7)), int(round(at[1] * 1e7)), alt_m)
    ack = gcs.wait_type("COMMAND_ACK", 3.0, step, lambda m: m.command == mav.MAV_CMD_DO_REPOSITION)
    return enum_name("MAV_RESULT", ack.result)


def read_params(gcs, names):
    return {name: gcs.read_param(name, f"read {name}") for name in names}


def rally(gcs):
    gcs.identify(timeout_s=20.0)
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 10, 1)
    gcs.results["params"] = read_params(gcs, ["RALLY_LIMIT_KM", "RALLY_INCL_HOME"])
    acks = gcs.results["acks"] = {}

    acks["waypoint_in_rally"] = upload(gcs, NOT_RALLY, "waypoint in rally", mav.MAV_MISSION_TYPE_RALLY)
    acks["rally_upload"] = upload(gcs, RALLY, "rally upload", mav.MAV_MISSION_TYPE_RALLY)
    if acks["rally_upload"] != "MAV_MISSION_ACCEPTED":
        raise Failed("rally upload", acks["rally_upload"])
    back = download(gcs, "rally download", mav.MAV_MISSION_TYPE_RALLY)
    gcs.results["downloaded"] = [[m.x, m.y, m.z] for m in back]

    arm_in_guided(gcs)
    acks["takeoff"] = command_ack(gcs, mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "takeoff")
    # The take-off done: at its height and no longer climbing (Kestrel refuses targets while its
    # take-off runs; ArduCopter takes one and leaves the climb).
    gcs.pump(lambda m: m.get_type() == "GLOBAL_POSITION_INT" and gcs.from_vehicle(m)
             and gcs.rel_alt_m >= TAKEOFF_M - 0.5 and abs(m.vz) < 20, 30.0, "climb")
    gcs.quiet(0.3)
    acks["reposition"] = reposition(gcs, AWAY, TAKEOFF_M, "reposition")
    gcs.pump(lambda m: m.get_type() == "GLOBAL_POSITION_INT" and gcs.from_vehicle(m)
             and distance_m(gcs.position, AWAY) < 2.0 and math.hypot(m.vx, m.vy) < 50, 40.0,
             "at the reposition target")
    gcs.results["rtl_from_m"] = {"r1": round(distance_m(gcs.position, R1), 1),
                                 "home": round(distance_m(gcs.position, HOME), 1)}

    acks["rtl"] = command_ack(gcs, mav.MAV_CMD_DO_SET_MODE,
                              [mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES["RTL"]], "rtl")
    highest = [gcs.rel_alt_m]

    def landed(m):
        if m.get_type() == "GLOBAL_POSITION_INT" and gcs.from_vehicle(m):
            highest[0] = max(highest[0], gcs.rel_alt_m)
        return gcs.armed is False

    gcs.pump(landed, 60.0, "returned, landed and disarmed")
    gcs.quiet(0.5)
    gcs.results["landed"] = {"r1": round(distance_m(gcs.position, R1), 2),
                             "home": round(distance_m(gcs.position, HOME), 2)}
    gcs.results["max_alt_m"] = round(highest[0], 1)
    gcs.results["modes"] = [m for m in gcs.modes_seen if m in ACM_MODES]


main(rally, deadline_s=120.0)
