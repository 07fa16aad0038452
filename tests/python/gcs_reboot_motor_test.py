"""Motor test and reboot asked for as a ground station does, and what the vehicle answered and
what its SERVO_OUTPUT_RAW showed, reported so that tests/gcs_reboot_motor_test.rs can compare
`kestrel run` with ArduCopter SITL.

Usage: gcs_reboot_motor_test.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)
Environment: DEADLINE_S (wall seconds the session may take); SKIP_ARMED=1 leaves out step 6.

1. identify the vehicle; SERVO_OUTPUT_RAW asked for at 20 Hz (MAV_CMD_SET_MESSAGE_INTERVAL);
   the outputs at rest (`idle`, servos 1-4, µs);
2. `single`: MAV_CMD_DO_MOTOR_TEST motor 1, 30 %, 2 s: its ACK, the servo that rose, its
   pulse and for how long (the messages' own time), and whether every output came back to rest;
3. `sequence`: motors 1-4 (param5 4) at 1300 µs (MOTOR_TEST_THROTTLE_PWM), 1 s each: the servos
   in the order they rose, each one's pulse and time up;
4. `stopped`: motor 3, 20 %, 30 s, then after 1 s a disarm command (COMPONENT_ARM_DISARM 0): how
   long (vehicle s) the outputs took to come back to rest after it, null if not within 3 s;
5. `gcs_lost`: motor 2, 20 %, 30 s, then the heartbeats stop after 0.5 s: how long after the
   last heartbeat the outputs came back to rest, null if not within 10 s; heartbeats resume;
6. armed on the ground in GUIDED: PREFLIGHT_REBOOT_SHUTDOWN 1 and DO_MOTOR_TEST: their ACKs, and
   whether the vehicle is still armed half a second (wall) later; then disarmed;
7. disarmed: PREFLIGHT_REBOOT_SHUTDOWN 1: its ACK; then the longest gap between heartbeats
   over the next 3 s of wall time (`reboot_silence_s`).

The last line's `results` hold `idle`, `acks` (step: MAV_RESULT name) and one object per step.
"""

import os
import time

from gcs_common import arm_in_guided, enum_name, Failed, main, mav, VEHICLE

SERVOS = 4
#: A servo counts as spinning this far above its rest pulse (µs).
RISE_US = 30


def ack_of(gcs, cmd, params, step):
    """COMMAND_LONG once; the MAV_RESULT name of its COMMAND_ACK ("NONE" when none came)."""
    p = list(params) + [0.0] * (7 - len(params))
    gcs.log(f"-> COMMAND_LONG {enum_name('MAV_CMD', cmd)} {p}")
    gcs.conn.mav.command_long_send(*VEHICLE, cmd, 0, *p)
    try:
        ack = gcs.wait_type("COMMAND_ACK", 3.0, step, lambda m: m.command == cmd)
    except Failed:
        return "NONE"
    return enum_name("MAV_RESULT", ack.result)


def servos(m):
    return [m.servo1_raw, m.servo2_raw, m.servo3_raw, m.servo4_raw]


class Outputs:
    """SERVO_OUTPUT_RAW as it comes: (vehicle s, [servo1..4 µs])."""

    def __init__(self, gcs):
        self.gcs = gcs
        self.samples = []
        gcs.watchers.append(self.watch)

    def watch(self, m):
        if m.get_type() == "SERVO_OUTPUT_RAW":
            self.samples.append((m.time_usec / 1e6, servos(m)))

    def now(self):
        return self.samples[-1][0] if self.samples else None

    def record(self, seconds, step, until=lambda s: False):
        """From now, `seconds` of the messages' time (or until `until(sample)`); the samples."""
        start = len(self.samples)
        self.gcs.wait_type("SERVO_OUTPUT_RAW", 5.0, step)
        t0 = self.samples[-1][0]
        self.gcs.pump(lambda m: m.get_type() == "SERVO_OUTPUT_RAW" and self.samples
                      and (self.samples[-1][0] - t0 >= seconds or until(self.samples[-1])),
                      seconds * 3 + 20.0, step)
        return self.samples[start:]


def spinning(sample, idle):
    """The servos (1-based) above rest in one sample."""
    return [i + 1 for i in range(SERVOS) if sample[1][i] > idle[i] + RISE_US]


def runs(samples, idle):
    """Each spell of one servo above rest: [servo, pulse µs (max), seconds up]."""
    out = []
    for t, pwm in samples:
        up = spinning((t, pwm), idle)
        for s in up:
            if out and out[-1][0] == s and out[-1][3] is None:
                out[-1][1] = max(out[-1][1], pwm[s - 1])
                out[-1][2] = t
            else:
                out.append([s, pwm[s - 1], t, None, t])
        for r in out:
            if r[3] is None and r[0] not in up:
                r[3] = t
    return [{"servo": r[0], "pulse_us": r[1], "up_s": round(r[2] - r[4], 2)} for r in out]


def scenario(gcs):
    acks = {}
    gcs.results["acks"] = acks
    gcs.identify(timeout_s=30.0)
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 4, 1)
    acks["servo_interval"] = ack_of(gcs, mav.MAV_CMD_SET_MESSAGE_INTERVAL, [36, 50000], "interval")
    out = Outputs(gcs)
    gcs.quiet(1.0)
    idle = out.record(0.5, "idle")[-1][1]
    gcs.results["idle"] = idle
    gcs.log(f"outputs at rest {idle}")
    rest = lambda s: not spinning(s, idle)

    # 2. One motor at 30 % for 2 s.
    acks["single"] = ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, [1, mav.MOTOR_TEST_THROTTLE_PERCENT, 30, 2, 1], "single")
    samples = out.record(3.5, "single")
    gcs.results["single"] = {"runs": runs(samples, idle), "rest_after": rest(samples[-1])}
    gcs.log(f"single: {gcs.results['single']}")

    # 3. Four motors in sequence at 1300 µs, 1 s each, half of it at rest between.
    acks["sequence"] = ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, [1, mav.MOTOR_TEST_THROTTLE_PWM, 1300, 1, 4], "sequence")
    samples = out.record(7.5, "sequence")
    gcs.results["sequence"] = {"runs": runs(samples, idle), "rest_after": rest(samples[-1])}
    gcs.log(f"sequence: {gcs.results['sequence']}")

    # 4. A long test, then another command.
    acks["stopped"] = ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, [3, mav.MOTOR_TEST_THROTTLE_PERCENT, 20, 30, 1], "stopped")
    out.record(1.0, "stopped")
    was_spinning = spinning(out.samples[-1], idle)
    t_cmd = out.now()
    acks["disarm_during_test"] = ack_of(gcs, mav.MAV_CMD_COMPONENT_ARM_DISARM, [0], "disarm")
    samples = out.record(3.0, "stopped", until=rest)
    gcs.results["stopped"] = {"spinning_before": was_spinning,
                              "rest_after_s": round(samples[-1][0] - t_cmd, 2) if rest(samples[-1]) else None}
    gcs.log(f"stopped: {gcs.results['stopped']}")
    if not rest(samples[-1]):
        ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, [1, 0, 0, 0.1, 1], "end")
        out.record(1.0, "end", until=rest)

    # 5. A long test, then the ground station goes quiet.
    acks["gcs_lost"] = ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, [2, mav.MOTOR_TEST_THROTTLE_PERCENT, 20, 30, 1], "gcs_lost")
    out.record(0.5, "gcs_lost")
    gcs.heartbeats_on = False
    t_last = out.now()
    gcs.log("heartbeats stopped")
    samples = out.record(10.0, "gcs_lost", until=rest)
    gcs.heartbeats_on = True
    gcs.results["gcs_lost"] = {"rest_after_s": round(samples[-1][0] - t_last, 2) if rest(samples[-1]) else None}
    gcs.log(f"gcs_lost: {gcs.results['gcs_lost']}")
    if not rest(samples[-1]):
        ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, [1, 0, 0, 0.1, 1], "end")
        out.record(1.0, "end", until=rest)

    # 6. Armed on the ground: both refused, still armed.
    if os.environ.get("SKIP_ARMED") != "1":
        arm_in_guided(gcs)
        acks["reboot_armed"] = ack_of(gcs, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, [1], "reboot armed")
        acks["motor_test_armed"] = ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, [1, 0, 10, 1, 1], "motor test armed")
        # Half a second of wall time: within the 10 s (vehicle time) auto-disarm of a vehicle
        # armed on the ground (DISARM_DELAY), at 5x.
        gcs.quiet(0.5)
        gcs.results["armed_after_refusals"] = gcs.armed
        acks["disarm"] = ack_of(gcs, mav.MAV_CMD_COMPONENT_ARM_DISARM, [0], "disarm")
        gcs.wait_type("HEARTBEAT", 5.0, "disarmed", lambda m: not m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)

    # 7. Disarmed: reboot.
    acks["reboot"] = ack_of(gcs, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, [1], "reboot")
    last = time.monotonic()
    end = last + 3.0
    gap = 0.0
    while time.monotonic() < end:
        msg = gcs.conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.05)
        now = time.monotonic()
        if msg is not None and gcs.from_vehicle(msg):
            gap = max(gap, now - last)
            last = now
    gcs.results["reboot_silence_s"] = round(max(gap, time.monotonic() - last), 2)
    gcs.log(f"reboot: longest heartbeat gap {gcs.results['reboot_silence_s']} s")


main(scenario, deadline_s=float(os.environ.get("DEADLINE_S", "110")))
