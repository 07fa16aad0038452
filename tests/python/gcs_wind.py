"""The wind the vehicle learns, as a ground station reads it from ArduPilot's WIND message.

Usage: gcs_wind.py   (run by tests/gcs_pymavlink.rs; see gcs_common.py for the transcript)

As with ArduPilot SITL, the ground station sets the simulator's wind (SIM_WIND_SPD 3 m/s,
SIM_WIND_DIR 225: from the south-west), takes off in GUIDED to 10 m and hovers. The estimator
learns the wind from the drag its accelerometer reads while GPS velocity is fused; WIND must say
where it blows from and how fast. Then LAND, and the vehicle must disarm on the ground.
"""

from gcs_common import Failed, main, mav

TAKEOFF_M = 10.0
SPEED_M_S = 3.0
FROM_DEG = 225.0
HOVER_S = 12.0


def angle_between_deg(a, b):
    return abs((a - b + 180.0) % 360.0 - 180.0)


def wind(gcs):
    gcs.identify()
    gcs.wait_ready()
    gcs.set_param("SIM_WIND_SPD", SPEED_M_S, "wind speed")
    gcs.set_param("SIM_WIND_DIR", FROM_DEG, "wind direction")
    gcs.set_mode_message("GUIDED", "guided")
    gcs.arm()
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "takeoff")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 0.5, 20.0, "take-off climb")
    hover_from = gcs.boot_s
    last = gcs.pump(lambda m: m.get_type() == "WIND" and gcs.from_vehicle(m) and gcs.boot_s >= hover_from + HOVER_S,
                    10.0, "WIND after the hover")
    gcs.log(f"WIND direction {last.direction:.1f} deg, speed {last.speed:.2f} m/s, speed_z {last.speed_z:.2f}")
    gcs.results["wind"] = {"direction_deg": round(last.direction, 1), "speed_m_s": round(last.speed, 2)}
    if angle_between_deg(last.direction, FROM_DEG) > 15.0 or abs(last.speed - SPEED_M_S) > 0.6:
        raise Failed("WIND", f"{last.direction:.1f} deg at {last.speed:.2f} m/s, set {FROM_DEG} deg at {SPEED_M_S}")
    gcs.set_mode_message("LAND", "land")
    gcs.pump(lambda m: not gcs.armed and gcs.landed_state == "MAV_LANDED_STATE_ON_GROUND", 30.0, "landed and disarmed")


main(wind)
