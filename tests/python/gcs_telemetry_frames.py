"""The telemetry frames SDKs and ground stations read, observed and asked for as they do, and
reported so that tests/gcs_telemetry_frames.rs can compare ArduCopter SITL with `kestrel run`.

Usage: gcs_telemetry_frames.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)

1. identify the vehicle and ask for every stream at 4 Hz (REQUEST_DATA_STREAM ALL, as MAVProxy
   and QGroundControl ask ArduCopter, which sends nothing unasked), then listen for WINDOW_S of
   the vehicle's time: which of FRAMES come, and how often (Hz of vehicle time, `time_boot_ms`);
2. MAV_CMD_REQUEST_MESSAGE for each of FRAMES: the COMMAND_ACK and whether the message came;
3. MAV_CMD_SET_MESSAGE_INTERVAL of ATTITUDE_QUATERNION at 20 Hz: the ACK and the rate then;
4. a TIMESYNC request: whether it is answered, with `tc1` set and our `ts1` mirrored;
5. field checks on what came: each ATTITUDE_QUATERNION unit length and within 0.02 rad of the
   newest ATTITUDE (at most 300 ms older: the vehicle sits on the ground), SYSTEM_TIME's `time_boot_ms` never going back and advancing over the run, SCALED_PRESSURE between
   900 and 1100 hPa, RAW_IMU's acceleration about 1 g (mG);
6. GUIDED and armed (each asked for until taken): SERVO_OUTPUT_RAW's first four outputs within
   1000..2000 µs while armed; then disarmed.

The last line's `results` holds `streamed_hz` (message: Hz, 0 when it never came), `requested`
(message: {ack, came}), `interval` ({ack, hz}), `timesync` ({answered, tc1_set, ts1_mirrored}),
`checks` (check: true/false, or null when there was nothing to check) and `armed_servo`
(the first four outputs of the last SERVO_OUTPUT_RAW while armed).
"""

import math

from gcs_common import arm_in_guided, enum_name, Failed, main, mav, VEHICLE

FRAMES = {
    "ATTITUDE_QUATERNION": 31,
    "RC_CHANNELS": 65,
    "ODOMETRY": 331,
    "SCALED_IMU": 26,
    "RAW_IMU": 27,
    "HIGHRES_IMU": 105,
    "SCALED_PRESSURE": 29,
    "SYSTEM_TIME": 2,
    "SERVO_OUTPUT_RAW": 36,
    "NAV_CONTROLLER_OUTPUT": 62,
    "POSITION_TARGET_LOCAL_NED": 85,
    "POSITION_TARGET_GLOBAL_INT": 87,
}
# The rate every stream is asked for (MAVProxy's default).
STREAM_HZ = 4
# Vehicle seconds each rate is measured over.
WINDOW_S = 6.0


class Frames:
    """Every frame of interest from the vehicle, with the vehicle time it came at."""

    def __init__(self, gcs):
        self.gcs = gcs
        self.seen = []  # (vehicle s, msg)
        self.attitude = None  # the newest ATTITUDE
        self.checks = {"quaternion_unit": None, "quaternion_matches_attitude": None,
                       "system_time_never_back": None, "system_time_advancing": None,
                       "pressure_plausible": None, "raw_imu_one_g": None}
        self.first_system_time = None
        self.last_system_time = None
        gcs.watchers.append(self.watch)

    def check(self, name, ok):
        self.checks[name] = bool(ok) if self.checks[name] is None else self.checks[name] and bool(ok)

    def watch(self, m):
        kind = m.get_type()
        if kind == "ATTITUDE":
            self.attitude = m
        if kind not in FRAMES or self.gcs.boot_s is None:
            return
        self.seen.append((self.gcs.boot_s, m))
        if kind == "ATTITUDE_QUATERNION":
            norm = math.sqrt(m.q1 ** 2 + m.q2 ** 2 + m.q3 ** 2 + m.q4 ** 2)
            self.check("quaternion_unit", abs(norm - 1.0) < 1e-3)
            a = self.attitude
            # The vehicle sits on the ground: an ATTITUDE of the last 300 ms says the same.
            if a is not None and abs(m.time_boot_ms - a.time_boot_ms) <= 300:
                w, x, y, z = m.q1, m.q2, m.q3, m.q4
                roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
                pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
                yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
                diff = max(abs(math.remainder(p - q, 2 * math.pi))
                           for p, q in ((roll, a.roll), (pitch, a.pitch), (yaw, a.yaw)))
                self.check("quaternion_matches_attitude", diff < 0.02)
        elif kind == "SYSTEM_TIME":
            # A streamed one and a requested one can leave at the same instant with the same
            # time: equal is not a stopped clock, going back is a fault, and over the run the
            # clock must have moved on from the first.
            if self.last_system_time is not None:
                self.check("system_time_never_back", m.time_boot_ms >= self.last_system_time)
            if self.first_system_time is None:
                self.first_system_time = m.time_boot_ms
            self.checks["system_time_advancing"] = m.time_boot_ms > self.first_system_time
            self.last_system_time = m.time_boot_ms
        elif kind == "SCALED_PRESSURE":
            self.check("pressure_plausible", 900.0 < m.press_abs < 1100.0)
        elif kind == "RAW_IMU":
            g = math.sqrt(m.xacc ** 2 + m.yacc ** 2 + m.zacc ** 2)
            self.check("raw_imu_one_g", 800.0 < g < 1200.0)

    def rates(self, since_s):
        """Hz of vehicle time of each frame seen since `since_s`."""
        out = {}
        for name in FRAMES:
            times = [t for t, m in self.seen if t >= since_s and m.get_type() == name]
            span = (times[-1] - times[0]) if len(times) > 1 else 0.0
            out[name] = round((len(times) - 1) / span, 2) if span > 0 else 0.0
        return out

    def came_since(self, name, index):
        return any(m.get_type() == name for _, m in self.seen[index:])


def wait_vehicle_s(gcs, seconds, step):
    """Receives until `seconds` of the vehicle's time have passed."""
    start = gcs.boot_s
    gcs.pump(lambda m: gcs.boot_s is not None and gcs.boot_s - start >= seconds, 30.0, step)




def flight(gcs):
    frames = Frames(gcs)
    gcs.identify(timeout_s=20.0)

    # 1. Every stream at 4 Hz, as a ground station asks.
    gcs.log("-> REQUEST_DATA_STREAM ALL 4 Hz")
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, STREAM_HZ, 1)
    gcs.pump(lambda m: gcs.boot_s is not None, 10.0, "clock")
    wait_vehicle_s(gcs, 1.0, "streams starting")
    start = gcs.boot_s
    wait_vehicle_s(gcs, WINDOW_S, "streams")
    gcs.results["streamed_hz"] = frames.rates(start)
    gcs.log(f"streamed rates: {gcs.results['streamed_hz']}")

    # 2. Each frame asked for once.
    requested = {}
    for name, msg_id in FRAMES.items():
        index = len(frames.seen)
        gcs.conn.mav.command_long_send(*VEHICLE, mav.MAV_CMD_REQUEST_MESSAGE, 0, msg_id,
                                       0, 0, 0, 0, 0, 0)
        ack = gcs.wait_type("COMMAND_ACK", 3.0, f"request {name}",
                            lambda m: m.command == mav.MAV_CMD_REQUEST_MESSAGE)
        # What comes for it comes right after the ACK, or with the next stream tick.
        gcs.quiet(0.3)
        requested[name] = {"ack": enum_name("MAV_RESULT", ack.result),
                           "came": frames.came_since(name, index)}
    gcs.results["requested"] = requested
    gcs.log(f"requested: {requested}")

    # 3. A rate asked for.
    gcs.conn.mav.command_long_send(*VEHICLE, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                   FRAMES["ATTITUDE_QUATERNION"], 50_000, 0, 0, 0, 0, 0)
    ack = gcs.wait_type("COMMAND_ACK", 3.0, "interval",
                        lambda m: m.command == mav.MAV_CMD_SET_MESSAGE_INTERVAL)
    gcs.quiet(0.2)
    start = gcs.boot_s
    wait_vehicle_s(gcs, WINDOW_S / 2, "interval")
    gcs.results["interval"] = {"ack": enum_name("MAV_RESULT", ack.result),
                               "hz": frames.rates(start)["ATTITUDE_QUATERNION"]}
    gcs.log(f"ATTITUDE_QUATERNION at 20 Hz asked: {gcs.results['interval']}")

    # 4. Time synchronisation, as MAVROS and MAVSDK ask.
    ts1 = 123_456_789
    gcs.conn.mav.timesync_send(0, ts1)
    try:
        answer = gcs.wait_type("TIMESYNC", 3.0, "timesync", lambda m: m.ts1 == ts1)
        gcs.results["timesync"] = {"answered": True, "tc1_set": answer.tc1 != 0,
                                   "ts1_mirrored": answer.ts1 == ts1}
    except Failed:
        gcs.results["timesync"] = {"answered": False, "tc1_set": False, "ts1_mirrored": False}
    gcs.log(f"timesync: {gcs.results['timesync']}")

    # 6. Armed on the ground: the motor outputs.
    arm_in_guided(gcs)
    start = gcs.boot_s
    wait_vehicle_s(gcs, 1.0, "armed")
    servo = [m for t, m in frames.seen if t > start and m.get_type() == "SERVO_OUTPUT_RAW"]
    gcs.results["armed_servo"] = ([servo[-1].servo1_raw, servo[-1].servo2_raw, servo[-1].servo3_raw,
                                   servo[-1].servo4_raw] if servo else None)
    gcs.log(f"SERVO_OUTPUT_RAW armed: {gcs.results['armed_servo']}")
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, [0], "disarm")
    gcs.results["checks"] = frames.checks
    gcs.log(f"checks: {frames.checks}")


if __name__ == "__main__":
    main(flight, deadline_s=55.0)
