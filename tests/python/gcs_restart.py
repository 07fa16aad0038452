"""A restart keeps what a ground station gave the vehicle: uploads a mission, a fence and rally
points and sets two parameters, downloads them, says RESTART (the test stops `kestrel run` and
starts it again on the same config, so the same state directory), waits for the vehicle to go
quiet and come back, then downloads everything again. Prints one JSON line: what was sent and
what each download gave, field by field."""
from pymavlink import mavutil

from gcs_common import Failed, download, main, mav_f32, upload

mav = mavutil.mavlink

HOME = (6.79710, 79.90170)


def item(seq, command, frame, lat, lon, alt, params=(0.0, 0.0, 0.0, 0.0)):
    return dict(seq=seq, command=command, frame=frame, params=list(params),
                x=int(round(lat * 1e7)), y=int(round(lon * 1e7)), alt=alt, autocontinue=1)


PLANS = {
    mav.MAV_MISSION_TYPE_MISSION: [
        item(0, mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL, *HOME, 20.0),
        item(1, mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, *HOME, 10.0),
        item(2, mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, 6.79760, 79.90170, 12.5,
             (1.5, 2.0, 0.0, float("nan"))),
        item(3, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, mav.MAV_FRAME_MISSION, 0.0, 0.0, 0.0),
    ],
    mav.MAV_MISSION_TYPE_FENCE: [
        item(0, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mav.MAV_FRAME_GLOBAL, *HOME, 0.0,
             (150.0, 0.0, 0.0, 0.0)),
    ],
    mav.MAV_MISSION_TYPE_RALLY: [
        item(0, mav.MAV_CMD_NAV_RALLY_POINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, 6.79740, 79.90190, 15.0),
        item(1, mav.MAV_CMD_NAV_RALLY_POINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, 6.79680, 79.90150, 8.0),
    ],
}
PARAMS = {"RTL_ALT_M": 33.0, "RALLY_LIMIT_KM": 1.5, "RALLY_INCL_HOME": 0.0}
NAMES = {mav.MAV_MISSION_TYPE_MISSION: "mission", mav.MAV_MISSION_TYPE_FENCE: "fence",
         mav.MAV_MISSION_TYPE_RALLY: "rally"}


def upload_plan(gcs, t, items):
    result = upload(gcs, items, f"{NAMES[t]} upload", t)
    if result != "MAV_MISSION_ACCEPTED":
        raise Failed(f"{NAMES[t]} upload", result)


def download_plan(gcs, t):
    # NaN is not JSON: its text form compares as well.
    return [[m.seq, m.command, m.frame, m.autocontinue]
            + [repr(v) for v in (m.param1, m.param2, m.param3, m.param4)] + [m.x, m.y, repr(m.z)]
            for m in download(gcs, f"{NAMES[t]} download", t)]


def sent(items):
    return [[it["seq"], it["command"], it["frame"], it["autocontinue"]]
            + [repr(mav_f32(v)) for v in it["params"]] + [it["x"], it["y"], repr(mav_f32(it["alt"]))]
            for it in items]


def snapshot(gcs):
    return {"plans": {NAMES[t]: download_plan(gcs, t) for t in PLANS},
            "params": {n: gcs.read_param(n, f"read {n}") for n in PARAMS}}


def body(gcs):
    gcs.wait_ready()
    for t, items in PLANS.items():
        upload_plan(gcs, t, items)
    for name, value in PARAMS.items():
        gcs.set_param(name, value, f"set {name}")
    before = snapshot(gcs)
    latest = {"ms": gcs.wait_type("ATTITUDE", 3.0, "attitude").time_boot_ms}
    print("RESTART", flush=True)

    def rebooted(m):
        # The vehicle stops and boots again: its boot clock starts over. ATTITUDE is streamed
        # from boot, before the position is known, so the first one of the new run is well
        # behind the last one of the old, however long either ran.
        if m.time_boot_ms + 500 < latest["ms"]:
            return True
        latest["ms"] = max(latest["ms"], m.time_boot_ms)
        return False
    gcs.wait_type("ATTITUDE", 60.0, "restart", rebooted)
    gcs.log("vehicle restarted")
    gcs.sensors_healthy, gcs.home = False, None
    gcs.wait_ready(timeout_s=30.0)
    after = snapshot(gcs)
    gcs.results.update({"sent": {NAMES[t]: sent(items) for t, items in PLANS.items()},
                        "params_set": PARAMS, "before": before, "after": after,
                        "statustexts": gcs.statustexts})


main(body, deadline_s=120.0)
