"""Glare injected from a ground station mid-leg: the stereo camera goes blind in flight.

Usage: gcs_camera_fault.py   (run by tests/gcs_camera_fault.rs; see gcs_common.py for the transcript)

On the graph of config/sim-forest.toml flying config/worlds/wall-textured.toml (a textured wall
across the leg, 20 m north of home): SYS_FAILURE_EN = 1, GUIDED, armed, a 6 m take-off, then a
DO_REPOSITION 40 m north, through the wall's line. Once the vehicle is 10 m north (about 10 m
short of the wall) the ground station sends MAV_CMD_INJECT_FAILURE on the avoidance unit
(FAILURE_UNIT_SYSTEM_AVOIDANCE, FAILURE_TYPE_WRONG: glare over the middle of both images), as
PX4's failure injection is driven. It asserts what it receives: the COMMAND_ACK ACCEPTED, the
STATUSTEXT naming the injected fault, the one naming what the camera now shows
(`camera_blind: glare`, the stereo actor's health), the vehicle holding short of the wall, then
landing (the `avoidance_lost` failsafe, LAND) and disarming short of it.
"""

import math

from gcs_common import Failed, arm_in_guided, enum_name, main, mav, VEHICLE

HOME = (6.79710, 79.90170)
M_PER_DEG_LAT = 110_574.0  # near the equator: good to a metre over these distances
TAKEOFF_M = 6.0
INJECT_AT_NORTH_M = 10.0
WALL_NORTH_M = 20.0


def north_m(gcs):
    return (gcs.position[0] - HOME[0]) * M_PER_DEG_LAT if gcs.position else None


def camera_fault(gcs):
    gcs.identify(timeout_s=20.0)
    gcs.wait_ready(timeout_s=20.0)
    gcs.set_param("SYS_FAILURE_EN", 1.0, "failure injection on")
    arm_in_guided(gcs)
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 0.5, 30.0, "climb")
    lat = int(round((HOME[0] + 40.0 / M_PER_DEG_LAT) * 1e7))
    lon = int(round(HOME[1] * 1e7))
    gcs.log("-> COMMAND_INT DO_REPOSITION 40 m N")
    gcs.conn.mav.command_int_send(*VEHICLE, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                  mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, math.nan, lat, lon, TAKEOFF_M)
    ack = gcs.wait_type("COMMAND_ACK", 3.0, "reposition", lambda m: m.command == mav.MAV_CMD_DO_REPOSITION)
    if ack.result != mav.MAV_RESULT_ACCEPTED:
        raise Failed("reposition", enum_name("MAV_RESULT", ack.result))
    gcs.pump(lambda m: (north_m(gcs) or 0.0) >= INJECT_AT_NORTH_M, 30.0, "leg to 10 m north")
    injected_at = north_m(gcs)
    gcs.log(f"-> MAV_CMD_INJECT_FAILURE avoidance WRONG at {injected_at:.2f} m north")
    gcs.command(mav.MAV_CMD_INJECT_FAILURE,
                [mav.FAILURE_UNIT_SYSTEM_AVOIDANCE, mav.FAILURE_TYPE_WRONG, 0], "inject glare")
    # The health text is longer than one STATUSTEXT: its chunks are read joined.
    gcs.pump(lambda m: m.get_type() == "STATUSTEXT" and "camera_blind: glare" in "".join(gcs.statustexts[-4:]),
             10.0, "glare named")
    named_at = north_m(gcs)
    gcs.pump(lambda m: gcs.mode == "LAND", 60.0, "avoidance_lost: LAND")
    held_at = north_m(gcs)
    gcs.pump(lambda m: not gcs.armed and gcs.landed_state == "MAV_LANDED_STATE_ON_GROUND",
             60.0, "landed and disarmed")
    landed_at = north_m(gcs)
    if not any(t.startswith("Failure injected: camera_glare") for t in gcs.statustexts):
        raise Failed("injection STATUSTEXT", gcs.statustexts)
    if not landed_at < WALL_NORTH_M - 1.0:
        raise Failed("short of the wall", f"landed {landed_at:.2f} m north; the wall is at {WALL_NORTH_M} m")
    if not held_at - named_at < 5.0:
        raise Failed("held", f"went on {held_at - named_at:.2f} m after the glare was named")
    gcs.results["camera_fault"] = {
        "injected_north_m": round(injected_at, 2),
        "named_north_m": round(named_at, 2),
        "land_from_north_m": round(held_at, 2),
        "landed_north_m": round(landed_at, 2),
        "modes": gcs.modes_seen,
    }


main(camera_fault, deadline_s=140.0)
