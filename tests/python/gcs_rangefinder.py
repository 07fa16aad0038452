"""A take-off under a slab, as a ground station sees it: DISTANCE_SENSOR up and down, and the
STATUSTEXT that says the climb is held.

Usage: gcs_rangefinder.py   (run by tests/gcs_pymavlink.rs on a world with a slab whose underside is 6 m
above home; see gcs_common.py for the transcript)

The ground station arms in GUIDED and asks for a 10 m take-off. The vehicle's upward rangefinder
sees the slab: the climb must stop about AVOID_MARGIN_M (2 m) below it, the vehicle must say so
in a STATUSTEXT, DISTANCE_SENSOR with orientation 24 (up) must read about 2 m and orientation
25 (down) the height. Then LAND, and the vehicle must disarm on the ground.
"""

from gcs_common import Failed, main, mav

TAKEOFF_M = 10.0
SLAB_M = 6.0
MARGIN_M = 2.0
SETTLE_S = 8.0


def rangefinder(gcs):
    gcs.identify()
    gcs.wait_ready()
    gcs.set_mode_message("GUIDED", "guided")
    gcs.arm()
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "takeoff")
    gcs.pump(lambda m: any(t.startswith("Climb held") for t in gcs.statustexts), 20.0, "climb held")
    settled_from = gcs.boot_s
    gcs.pump(lambda m: gcs.boot_s is not None and gcs.boot_s >= settled_from + SETTLE_S, 20.0, "settle")
    readings = {}
    for orientation, name in [(mav.MAV_SENSOR_ROTATION_PITCH_90, "up"), (mav.MAV_SENSOR_ROTATION_PITCH_270, "down")]:
        m = gcs.wait_type("DISTANCE_SENSOR", 5.0, f"DISTANCE_SENSOR {name}", lambda m, o=orientation: m.orientation == o)
        readings[name] = {"cm": m.current_distance, "min_cm": m.min_distance, "max_cm": m.max_distance,
                          "type": m.type, "id": m.id}
        gcs.log(f"DISTANCE_SENSOR {name}: {m.current_distance} cm ({m.min_distance}..{m.max_distance} cm)")
    height_m = gcs.rel_alt_m
    gcs.results["rangefinder"] = {"height_m": round(height_m, 2), **readings}
    if height_m > SLAB_M - MARGIN_M + 0.5 or height_m < SLAB_M - MARGIN_M - 1.0:
        raise Failed("held height", f"{height_m:.2f} m under a slab at {SLAB_M} m")
    if abs(readings["up"]["cm"] / 100.0 - (SLAB_M - height_m)) > 0.3:
        raise Failed("up reading", f"{readings['up']} at {height_m:.2f} m")
    if abs(readings["down"]["cm"] / 100.0 - height_m) > 0.3:
        raise Failed("down reading", f"{readings['down']} at {height_m:.2f} m")
    if readings["up"]["type"] != mav.MAV_DISTANCE_SENSOR_LASER:
        raise Failed("sensor type", readings)
    gcs.set_mode_message("LAND", "land")
    gcs.pump(lambda m: not gcs.armed and gcs.landed_state == "MAV_LANDED_STATE_ON_GROUND", 30.0, "landed and disarmed")


main(rangefinder)
