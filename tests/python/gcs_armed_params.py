"""Disarmed-only parameters on `kestrel run`: refused in flight, taken on the ground.

Usage: gcs_armed_params.py   (run by tests/gcs_pymavlink.rs; see gcs_common.py for the transcript)

Takes off in GUIDED to 10 m and, hovering, sets what would move a motor's pulse range or a
sensor's calibration under the estimator (SERVO1_MIN 800 then SERVO1_MAX 900, INS_GYROFFS_X,
COMPASS_OFS_X): each must be answered by a STATUSTEXT "<name>: cannot change while armed" and a
PARAM_VALUE with the value still in force, which a PARAM_REQUEST_READ confirms, while the
vehicle holds its height and mode. A limit (RTL_ALT_M) is still tuned in flight. After landing
and disarming, the same parameters set to calibration-like values are taken: echoed and read
back with the new value.
"""

from gcs_common import Failed, main, mav

TAKEOFF_M = 10.0
# Set in flight: each would stop motor 1, bias the rates or swing the heading if taken.
IN_FLIGHT = [("SERVO1_MIN", 800.0), ("SERVO1_MAX", 900.0), ("INS_GYROFFS_X", 0.2),
             ("COMPASS_OFS_X", 500.0)]
# Set on the ground: what a calibration would write.
ON_GROUND = [("SERVO1_MAX", 1950.0), ("INS_GYROFFS_X", 0.01), ("COMPASS_OFS_X", 100.0)]


def armed_params(gcs):
    gcs.identify()
    gcs.wait_ready()
    before = gcs.fetch_params()
    for name, _ in IN_FLIGHT:
        if name not in before:
            raise Failed("param list", f"{name} is not served")
    gcs.set_mode_message("GUIDED", "guided")
    gcs.arm()
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "takeoff")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= 9.5, 20.0, "take-off climb")
    gcs.quiet(1.0)

    heights = []
    gcs.watchers.append(lambda m: heights.append(m.relative_alt / 1000.0)
                        if m.get_type() == "GLOBAL_POSITION_INT" else None)
    refused = {}
    for name, value in IN_FLIGHT:
        old = before[name]
        texts_before = len(gcs.statustexts)
        gcs.set_param(name, value, f"{name} in flight", expect_echo=old)
        want = f"{name}: cannot change while armed"
        gcs.pump(lambda m: any(want in t for t in gcs.statustexts[texts_before:]), 3.0,
                 f"{name} refusal STATUSTEXT")
        read = gcs.read_param(name, f"{name} read in flight")
        if read != old:
            raise Failed(f"{name} read in flight", f"{read}, wanted the value in force {old}")
        refused[name] = {"set": value, "echo": old, "read": read}
    gcs.set_param("RTL_ALT_M", 20.0, "a limit tuned in flight")
    # Hover on: the refused values must have changed nothing (about 10 s of vehicle time).
    gcs.quiet(2.0)
    if not gcs.armed or gcs.mode != "GUIDED":
        raise Failed("flight unaffected", f"armed {gcs.armed}, mode {gcs.mode}")
    low, high = min(heights), max(heights)
    if low < TAKEOFF_M - 1.0 or high > TAKEOFF_M + 1.0:
        raise Failed("flight unaffected", f"height {low:.2f}..{high:.2f} m while setting")
    gcs.results["in_flight"] = {"refused": refused, "height_min_m": round(low, 3),
                                "height_max_m": round(high, 3), "mode": gcs.mode}

    gcs.set_mode_message("LAND", "land")
    gcs.pump(lambda m: not gcs.armed and gcs.landed_state == "MAV_LANDED_STATE_ON_GROUND",
             40.0, "landed and disarmed")
    gcs.quiet(0.3)
    taken = {}
    for name, value in ON_GROUND:
        gcs.set_param(name, value, f"{name} on the ground")
        read = gcs.read_param(name, f"{name} read on the ground")
        if abs(read - value) > 1e-6 * max(1.0, abs(value)):
            raise Failed(f"{name} read on the ground", f"{read}, wanted {value}")
        taken[name] = read
    gcs.results["on_ground"] = taken
    gcs.results["statustexts"] = gcs.statustexts


main(armed_params)
