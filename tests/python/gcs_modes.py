"""CIRCLE, DO_ORBIT, BRAKE, reboot and motor test asked for as a ground station does, and what
the vehicle answered and flew, reported so that tests/gcs_modes.rs can compare ArduCopter SITL
with `kestrel run`.

Usage: gcs_modes.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)
Environment: DEADLINE_S (wall seconds the session may take).

1. identify the vehicle and ask for its streams at 4 Hz;
2. disarmed on the ground: MAV_CMD_DO_MOTOR_TEST (motor 1, 10 %, 0.5 s): its ACK;
3. GUIDED, armed (retried until taken), take off to TAKEOFF_M;
4. in the air: MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN 1 and MAV_CMD_DO_MOTOR_TEST: their ACKs; then
   the sticks centred by RC_CHANNELS_OVERRIDE (`centre_sticks`);
5. MAV_CMD_DO_ORBIT (radius ORBIT_M, default speed and yaw, centre here): its ACK, and the mode;
6. mode CIRCLE (custom mode 7): its ACK; then CIRCLE_S of the vehicle's time of
   GLOBAL_POSITION_INT, to which a circle is fitted (least squares): its radius, the RMS of the
   distances from it, and the mean angular rate (deg/s, positive clockwise);
7. mode BRAKE (17): its ACK, and the mean ground speed over the last second of the CIRCLE_S/4
   after it.

The last line's `results` hold `acks` (step: MAV_RESULT name), `modes` (step: mode shown after),
`circle` ({radius_m, rms_m, rate_deg_s, samples}) and `brake_speed_m_s`.
"""

import math
import os
import time

from gcs_common import ACM_MODES, arm_in_guided, enum_name, Failed, main, mav, VEHICLE

TAKEOFF_M = 10.0
ORBIT_M = 10.0
CIRCLE_S = 24.0
NAN = float("nan")


def ack_of(gcs, cmd, params, step):
    """COMMAND_LONG once; the MAV_RESULT name of its COMMAND_ACK ("NONE" when none came)."""
    p = list(params) + [0.0] * (7 - len(params))
    gcs.log(f"-> COMMAND_LONG {enum_name('MAV_CMD', cmd)} {p}")
    gcs.conn.mav.command_long_send(*VEHICLE, cmd, 0, *p)
    try:
        ack = gcs.wait_type("COMMAND_ACK", 3.0, step, lambda m: m.command == cmd)
    except Failed:
        return "NONE"
    result = enum_name("MAV_RESULT", ack.result)
    gcs.log(f"COMMAND_ACK {enum_name('MAV_CMD', cmd)} {result}")
    return result




def centre_sticks(gcs):
    """From now on, RC_CHANNELS_OVERRIDE with channels 1-4 at 1500 µs every 0.1 s of wall
    time, as a radio held at mid-stick: ArduCopter's CIRCLE and BRAKE take the climb rate from
    the throttle, and SITL's own RC input holds the throttle low, which would land it. Kestrel
    does not read RC_CHANNELS_OVERRIDE (its CIRCLE holds the height it was entered at)."""
    last = [0.0]

    def send(_msg):
        now = time.monotonic()
        if now - last[0] >= 0.1:
            gcs.conn.mav.rc_channels_override_send(*VEHICLE, 1500, 1500, 1500, 1500, 0, 0, 0, 0)
            last[0] = now

    gcs.watchers.append(send)


def mode_after(gcs, seconds=1.0):
    gcs.quiet(seconds)
    return gcs.mode


def fit_circle(points):
    """Kasa's algebraic least-squares circle through (x, y) points: centre and radius."""
    n = len(points)
    mx = sum(p[0] for p in points) / n
    my = sum(p[1] for p in points) / n
    u = [(p[0] - mx, p[1] - my) for p in points]
    suu = sum(a * a for a, _ in u)
    svv = sum(b * b for _, b in u)
    suv = sum(a * b for a, b in u)
    suuu = sum(a ** 3 for a, _ in u)
    svvv = sum(b ** 3 for _, b in u)
    suvv = sum(a * b * b for a, b in u)
    svuu = sum(b * a * a for a, b in u)
    r1 = 0.5 * (suuu + suvv)
    r2 = 0.5 * (svvv + svuu)
    det = suu * svv - suv * suv
    uc = (r1 * svv - r2 * suv) / det
    vc = (r2 * suu - r1 * suv) / det
    radius = math.sqrt(uc * uc + vc * vc + (suu + svv) / n)
    return (uc + mx, vc + my), radius


def flown_circle(gcs, seconds):
    """GLOBAL_POSITION_INT for `seconds` of the vehicle's time, as local north/east (m)."""
    samples = []

    def watch(m):
        if m.get_type() == "GLOBAL_POSITION_INT":
            samples.append((m.time_boot_ms / 1000.0, m.lat * 1e-7, m.lon * 1e-7))

    gcs.watchers.append(watch)
    start = gcs.boot_s
    gcs.pump(lambda m: gcs.boot_s is not None and gcs.boot_s - start >= seconds, seconds + 30.0, "circle")
    gcs.watchers.remove(watch)
    lat0, lon0 = samples[0][1], samples[0][2]
    k = 6378137.0 * math.pi / 180.0
    pts = [(t, (lat - lat0) * k, (lon - lon0) * k * math.cos(math.radians(lat0))) for t, lat, lon in samples]
    (cn, ce), radius = fit_circle([(n, e) for _, n, e in pts])
    rms = math.sqrt(sum((math.hypot(n - cn, e - ce) - radius) ** 2 for _, n, e in pts) / len(pts))
    angles = [math.atan2(e - ce, n - cn) for _, n, e in pts]
    unwrapped = [angles[0]]
    for a in angles[1:]:
        d = (a - unwrapped[-1] + math.pi) % (2 * math.pi) - math.pi
        unwrapped.append(unwrapped[-1] + d)
    rate = math.degrees(unwrapped[-1] - unwrapped[0]) / (pts[-1][0] - pts[0][0])
    return {"radius_m": round(radius, 3), "rms_m": round(rms, 3), "rate_deg_s": round(rate, 3),
            "samples": len(pts)}


def scenario(gcs):
    acks, modes = {}, {}
    gcs.results["acks"], gcs.results["modes"] = acks, modes
    gcs.identify(timeout_s=30.0)
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 4, 1)
    gcs.quiet(1.0)
    # Motor 1 at 10 % for 0.5 s, one motor (param5), ArduCopter's numbering of the test order.
    motor_test = [1, mav.MOTOR_TEST_THROTTLE_PERCENT, 10, 0.5, 1, mav.MOTOR_TEST_ORDER_DEFAULT]
    acks["motor_test_disarmed"] = ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, motor_test, "motor test")
    gcs.quiet(1.5)
    arm_in_guided(gcs)
    end = time.monotonic() + 10.0
    while ack_of(gcs, mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off") != "MAV_RESULT_ACCEPTED":
        if time.monotonic() > end or not gcs.armed:
            raise Failed("take-off", gcs.statustexts[-3:])
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 0.5, 40.0, "take-off")
    gcs.quiet(1.0)
    acks["reboot_armed"] = ack_of(gcs, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, [1], "reboot")
    acks["motor_test_armed"] = ack_of(gcs, mav.MAV_CMD_DO_MOTOR_TEST, motor_test, "motor test armed")
    modes["after_reboot_and_motor_test"] = mode_after(gcs)
    centre_sticks(gcs)
    # DO_ORBIT as MAVSDK's `action.do_orbit` sends it: radius, velocity NaN (default), yaw
    # behaviour 0 (face the centre), orbits NaN, centre NaN (here).
    acks["do_orbit"] = ack_of(gcs, mav.MAV_CMD_DO_ORBIT, [ORBIT_M, NAN, 0, NAN, NAN, NAN, NAN], "orbit")
    modes["after_do_orbit"] = mode_after(gcs, 2.0)
    acks["mode_circle"] = ack_of(
        gcs, mav.MAV_CMD_DO_SET_MODE, [mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES["CIRCLE"]], "circle")
    modes["after_mode_circle"] = mode_after(gcs, 0.5)
    if modes["after_mode_circle"] == "CIRCLE":
        gcs.results["circle"] = flown_circle(gcs, CIRCLE_S)
        gcs.log(f"circle flown: {gcs.results['circle']}")
    acks["mode_brake"] = ack_of(
        gcs, mav.MAV_CMD_DO_SET_MODE, [mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES["BRAKE"]], "brake")
    speeds = []

    def watch(m):
        if m.get_type() == "GLOBAL_POSITION_INT":
            speeds.append(math.hypot(m.vx, m.vy) / 100.0)

    gcs.watchers.append(watch)
    start = gcs.boot_s
    gcs.pump(lambda m: gcs.boot_s - start >= CIRCLE_S / 4, 30.0, "brake")
    gcs.watchers.remove(watch)
    modes["after_mode_brake"] = gcs.mode
    # The mean of the last second's reports (4 Hz): one report carries the estimator's noise.
    last = speeds[-4:]
    gcs.results["brake_speed_m_s"] = round(sum(last) / len(last), 3) if last else None


main(scenario, deadline_s=float(os.environ.get("DEADLINE_S", "110")))
