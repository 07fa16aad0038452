"""Offboard body velocity as a companion computer streams it (SET_POSITION_TARGET_LOCAL_NED in
MAV_FRAME_BODY_NED), the same script against `kestrel run` and ArduCopter SITL; reported so that
tests/gcs_offboard.rs can compare the two.

Usage: gcs_offboard.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)

1. GUIDED and armed (each asked for until taken), take off to 10 m;
2. forward: 2 m/s forward in the body frame, velocity only, for 6 s of vehicle time: the way
   flown must point where the nose did (bearing of the displacement vs the heading) and be
   about 12 m long;
3. timeout: the stream stops: the vehicle flies on until the guided timeout (3 s) and stops;
   `flew_on_s` is how long after the last message its speed fell below 1 m/s;
4. yaw rate: no velocity, 0.5 rad/s of yaw rate for 4 s: `turned_deg` (about 115);
5. bad mask: a 2 m/s stream, then one message asking for a position and an acceleration
   without a velocity (a combination ArduCopter does not fly): the vehicle stops at once;
   `stopped_s` is how long after it the speed fell below 0.5 m/s.

Times are the vehicle's (`time_boot_ms`), so the two stacks' speed-ups do not matter.
"""

import math

from gcs_common import arm_in_guided, Failed, main, mav, VEHICLE

TAKEOFF_M = 10.0
SPEED_M_S = 2.0
POS = 0x007
VEL = 0x038
ACC = 0x1C0
YAW = 0x400
YAW_RATE = 0x800
VELOCITY_ONLY = POS | ACC | YAW | YAW_RATE
YAW_RATE_ONLY = POS | ACC | YAW
POSITION_AND_ACCEL = VEL | YAW | YAW_RATE






class State:
    """The newest LOCAL_POSITION_NED and ATTITUDE."""

    def __init__(self, gcs):
        self.position = None
        self.yaw = None
        gcs.watchers.append(self.watch)

    def watch(self, m):
        if m.get_type() == "LOCAL_POSITION_NED":
            self.position = m
        elif m.get_type() == "ATTITUDE":
            self.yaw = m.yaw

    def speed(self):
        return math.hypot(self.position.vx, self.position.vy)


def body(gcs, mask, vx=0.0, yaw_rate=0.0):
    gcs.conn.mav.set_position_target_local_ned_send(0, *VEHICLE, mav.MAV_FRAME_BODY_NED, mask,
                                                    0, 0, 0, vx, 0, 0, 0, 0, 0, 0, yaw_rate)


def stream(gcs, seconds, mask, vx=0.0, yaw_rate=0.0, on_sample=None):
    """Sends the body target every 50 ms of wall time for `seconds` of vehicle time."""
    start = gcs.boot_s
    while gcs.boot_s - start < seconds:
        body(gcs, mask, vx, yaw_rate)
        gcs.quiet(0.05)
        if on_sample:
            on_sample()


def seconds_until(gcs, cond, since_s, timeout_s, step):
    gcs.pump(lambda m: cond(), timeout_s, step)
    return round(gcs.boot_s - since_s, 2)


def flight(gcs):
    state = State(gcs)
    gcs.identify()
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 10, 1)
    arm_in_guided(gcs)
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 1.0, 40.0, "take-off")
    gcs.quiet(1.0)

    # 2. Forward in the body frame.
    p0, yaw0 = state.position, state.yaw
    stream(gcs, 6.0, VELOCITY_ONLY, vx=SPEED_M_S)
    p1 = state.position
    dn, de = p1.x - p0.x, p1.y - p0.y
    bearing_error = math.degrees(math.remainder(math.atan2(de, dn) - yaw0, 2 * math.pi))
    gcs.results["forward"] = {"heading_deg": round(math.degrees(yaw0), 1),
                              "bearing_error_deg": round(bearing_error, 1),
                              "distance_m": round(math.hypot(dn, de), 2)}
    gcs.log(f"forward: {gcs.results['forward']}")

    # 3. The stream stops: flown on until the guided timeout.
    last = gcs.boot_s
    flew_on = seconds_until(gcs, lambda: state.speed() < 1.0, last, 20.0, "timeout stop")
    gcs.results["timeout"] = {"flew_on_s": flew_on}
    gcs.log(f"timeout: {gcs.results['timeout']}")
    gcs.quiet(1.0)

    # 4. Yaw rate only.
    turned = [0.0, state.yaw]

    def track():
        turned[0] += math.remainder(state.yaw - turned[1], 2 * math.pi)
        turned[1] = state.yaw
    stream(gcs, 4.0, YAW_RATE_ONLY, yaw_rate=0.5, on_sample=track)
    gcs.results["yaw_rate"] = {"turned_deg": round(math.degrees(turned[0]), 1)}
    gcs.log(f"yaw rate: {gcs.results['yaw_rate']}")
    gcs.quiet(1.0)

    # 5. A mask ArduCopter does not fly stops the vehicle.
    stream(gcs, 3.0, VELOCITY_ONLY, vx=SPEED_M_S)
    moving = round(state.speed(), 2)
    gcs.conn.mav.set_position_target_local_ned_send(0, *VEHICLE, mav.MAV_FRAME_LOCAL_NED, POSITION_AND_ACCEL,
                                                    0, 0, -TAKEOFF_M, 0, 0, 0, 1, 0, 0, 0, 0)
    sent = gcs.boot_s
    stopped = seconds_until(gcs, lambda: state.speed() < 0.5, sent, 20.0, "bad mask stop")
    gcs.results["bad_mask"] = {"speed_before_m_s": moving, "stopped_s": stopped}
    gcs.log(f"bad mask: {gcs.results['bad_mask']}")
    if moving < 1.0:
        raise Failed("bad mask", f"not moving before the bad message: {moving} m/s")


if __name__ == "__main__":
    main(flight, deadline_s=110.0)
