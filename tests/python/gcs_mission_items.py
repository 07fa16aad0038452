"""Survey and DO_JUMP missions as a ground station sends them, written once and run against
ArduCopter SITL and against `kestrel run` (tests/gcs_mission_items.rs), which compares the two.

Usage: gcs_mission_items.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)

1. identify the vehicle, ask for its telemetry streams (ArduCopter sends only what is asked for);
2. upload, one mission each (home, a take-off, the item), items whose answer is not ACCEPTED or
   is worth comparing: CONDITION_GATE, a DO_JUMP to home and one past the end, a gimbal item
   with NaN rates, the camera, ROI, delay, condition and output items MAVSDK and QGroundControl
   send: each MISSION_ACK's result;
3. upload config/missions/survey.plan (QGroundControl's survey, its items as QGC uploads them:
   the complex item's saved `Items` in place) and download it back: the ACK and whether each
   item's command and place came back;
4. upload the jump mission: home, take-off to 10 m, waypoints A (item 2) and B (3), DO_JUMP to
   item 2 repeated once (4), waypoint C (5), LAND (6);
5. GUIDED and arm (each asked for until taken), take off to 10 m, AUTO; follow the flight until
   landed and disarmed: every MISSION_ITEM_REACHED and the sequence of MISSION_CURRENT.

The last line's `results` holds `acks` (probe name: MAV_MISSION_RESULT name), `survey` ({ack,
items, downloaded_identical: each item's command and place as sent}), `jump` ({ack, reached:
the MISSION_ITEM_REACHED seqs from AUTO on, currents: the MISSION_CURRENT seqs, repeats
dropped}).
"""

import json
import math
import os

from gcs_common import arm_in_guided, download, Failed, item_int, main, mav, upload, VEHICLE

HOME = (6.79710, 79.90170)
TAKEOFF_M = 10.0
M_PER_DEG = 111_320.0
REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")


def offset(north_m, east_m):
    return (HOME[0] + north_m / M_PER_DEG,
            HOME[1] + east_m / (M_PER_DEG * math.cos(math.radians(HOME[0]))))


def item(command, frame=mav.MAV_FRAME_MISSION, params=(0.0, 0.0, 0.0, 0.0), at=None, alt=0.0):
    return item_int(command, frame, params, at if at is not None else (0.0, 0.0), alt)


def numbered(items):
    for seq, it in enumerate(items):
        it["seq"] = seq
    return items


def home_and_takeoff():
    return [item(mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL, at=HOME, alt=20.0),
            item(mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, at=HOME, alt=TAKEOFF_M)]


def survey_items():
    """config/missions/survey.plan as QGroundControl uploads it: home, then each SimpleItem and
    each complex item's saved `Items`, in order."""
    with open(os.path.join(REPO, "config", "missions", "survey.plan")) as f:
        plan = json.load(f)["mission"]
    lat, lon, alt = plan["plannedHomePosition"]
    items = [item(mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL, at=(lat, lon), alt=alt)]
    simple = []
    for it in plan["items"]:
        simple += it["TransectStyleComplexItem"]["Items"] if it["type"] == "ComplexItem" else [it]
    for it in simple:
        p = [math.nan if v is None else float(v) for v in it["params"]]
        items.append(item(it["command"], it["frame"], p[:4], (p[4], p[5]), p[6]))
    return numbered(items)


NAN = float("nan")
# (name, command, frame, params, at): each uploaded as item 2 after home and a take-off.
PROBES = [
    ("condition_gate", 4501, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, (0, 1, 0, 0), offset(10, 0)),
    ("jump_to_home", mav.MAV_CMD_DO_JUMP, mav.MAV_FRAME_MISSION, (0, 2, 0, 0), None),
    ("jump_past_end", mav.MAV_CMD_DO_JUMP, mav.MAV_FRAME_MISSION, (9, 2, 0, 0), None),
    ("jump_forever", mav.MAV_CMD_DO_JUMP, mav.MAV_FRAME_MISSION, (1, -1, 0, 0), None),
    ("gimbal_nan_rates", mav.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, mav.MAV_FRAME_MISSION, (-45, 0, NAN, NAN), None),
    ("gimbal", mav.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, mav.MAV_FRAME_MISSION, (-45, 0, 0, 0), None),
    ("mount_control", mav.MAV_CMD_DO_MOUNT_CONTROL, mav.MAV_FRAME_MISSION, (-45, 0, 0, 0), None),
    ("set_servo", mav.MAV_CMD_DO_SET_SERVO, mav.MAV_FRAME_MISSION, (9, 1500, 0, 0), None),
    ("set_relay", mav.MAV_CMD_DO_SET_RELAY, mav.MAV_FRAME_MISSION, (0, 1, 0, 0), None),
    ("cam_trigg_dist", mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST, mav.MAV_FRAME_MISSION, (25, 0, 1, 0), None),
    ("image_start", mav.MAV_CMD_IMAGE_START_CAPTURE, mav.MAV_FRAME_MISSION, (0, 2, 0, 0), None),
    ("image_stop", mav.MAV_CMD_IMAGE_STOP_CAPTURE, mav.MAV_FRAME_MISSION, (0, 0, 0, 0), None),
    ("roi_location", mav.MAV_CMD_DO_SET_ROI_LOCATION, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, (0, 0, 0, 0), offset(30, 30)),
    ("roi_none", mav.MAV_CMD_DO_SET_ROI_NONE, mav.MAV_FRAME_MISSION, (0, 0, 0, 0), None),
    ("nav_delay", mav.MAV_CMD_NAV_DELAY, mav.MAV_FRAME_MISSION, (5, -1, -1, -1), None),
    ("condition_delay", mav.MAV_CMD_CONDITION_DELAY, mav.MAV_FRAME_MISSION, (5, 0, 0, 0), None),
    ("condition_distance", mav.MAV_CMD_CONDITION_DISTANCE, mav.MAV_FRAME_MISSION, (5, 0, 0, 0), None),
    ("condition_yaw", mav.MAV_CMD_CONDITION_YAW, mav.MAV_FRAME_MISSION, (90, 10, 1, 0), None),
    ("land_start", mav.MAV_CMD_DO_LAND_START, mav.MAV_FRAME_MISSION, (0, 0, 0, 0), None),
    ("spline", mav.MAV_CMD_NAV_SPLINE_WAYPOINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, (0, 0, 0, 0), offset(20, 0)),
    ("loiter_turns", mav.MAV_CMD_NAV_LOITER_TURNS, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, (2, 0, 5, 0), offset(20, 0)),
    ("loiter_unlim", mav.MAV_CMD_NAV_LOITER_UNLIM, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, (0, 0, 0, 0), offset(20, 0)),
]


def jump_mission():
    a, b, c = offset(15.0, 0.0), offset(15.0, 15.0), offset(0.0, 15.0)
    wp = lambda at: item(mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, at=at, alt=TAKEOFF_M)
    return numbered(home_and_takeoff() + [
        wp(a), wp(b),
        item(mav.MAV_CMD_DO_JUMP, params=(2, 1, 0, 0)),
        wp(c),
        item(mav.MAV_CMD_NAV_LAND, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, at=c, alt=0.0),
    ])




def flight(gcs):
    gcs.identify()
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 10, 1)
    acks = {}
    for name, command, frame, params, at in PROBES:
        items = numbered(home_and_takeoff() + [item(command, frame, params, at, TAKEOFF_M if at else 0.0)])
        acks[name] = upload(gcs, items, f"probe {name}")
    gcs.results["acks"] = acks

    survey = survey_items()
    ack = upload(gcs, survey, "survey")
    back = [(b.command, b.x, b.y) for b in download(gcs, "survey download")]
    sent = [(it["command"], it["x"], it["y"]) for it in survey[1:]]
    gcs.results["survey"] = {"ack": ack, "items": len(survey),
                             "downloaded_identical": ack == "MAV_MISSION_ACCEPTED" and back[1:] == sent}

    ack = upload(gcs, jump_mission(), "jump mission")
    gcs.results["jump"] = {"ack": ack}
    if ack != "MAV_MISSION_ACCEPTED":
        raise Failed("jump mission", ack)
    arm_in_guided(gcs)
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 1.0, 30.0, "take-off")
    reached_before, currents_before = len(gcs.reached), len(gcs.mission_currents)
    gcs.set_mode_command("AUTO", "auto")
    gcs.pump(lambda m: gcs.armed is False, 90.0, "flown, landed and disarmed")
    # What the vehicle says about the landing item around the disarm.
    gcs.quiet(2.0)
    gcs.results["jump"]["reached"] = gcs.reached[reached_before:]
    currents = []
    for seq in gcs.mission_currents[currents_before:]:
        if currents[-1:] != [seq]:
            currents.append(seq)
    gcs.results["jump"]["currents"] = currents


main(flight, deadline_s=140.0)
