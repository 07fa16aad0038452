"""FOLLOW asked for as a ground station does, with the target's FOLLOW_TARGET sent from this
script's own system id, and what the vehicle answered and flew, reported so that
tests/gcs_follow.rs can compare ArduCopter SITL with `kestrel run`.

Usage: gcs_follow.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)
Environment: DEADLINE_S (wall seconds the session may take).

1. identify the vehicle and ask for its streams at 4 Hz;
2. GUIDED, armed, take off to TAKEOFF_M;
3. mode FOLLOW (23) with FOLL_ENABLE 0: its ACK, the STATUSTEXT and the mode kept; then
   FOLL_ENABLE 1 (PARAM_SET);
4. the target appears on the ground AHEAD_M north of the vehicle: FOLLOW_TARGET (position and
   velocity bits) every 0.2 s of the vehicle's time, stamped with the vehicle's own boot time;
   mode FOLLOW: its ACK; the target walks north at SPEED_M_S for WALK_S and stops; FOLL_OFS_* are
   0, so the vehicle keeps the place it had relative to the target when FOLLOW started;
5. the reports stop: the vehicle's ground speed 6 s later (past the 3 s timeout).

The last line's `results` hold `acks`, `modes`, `texts` and `follow` ({lag_m: mean distance
behind its place while walking, side_m, height_m: worst off the line and off TAKEOFF_M,
final_m: distance from its place once the target stopped, flown_m: north flown}) and
`lost_speed_m_s`.
"""

import math
import os

from gcs_common import ACM_MODES, arm_in_guided, enum_name, Failed, main, mav, VEHICLE

TAKEOFF_M = 10.0
AHEAD_M = 5.0
SPEED_M_S = 3.0
WALK_S = 15.0
REPORT_S = 0.2
M_PER_DEG_LAT = 110_574.0


def ack_of(gcs, cmd, params, step):
    """COMMAND_LONG once; the MAV_RESULT name of its COMMAND_ACK ("NONE" when none came)."""
    p = list(params) + [0.0] * (7 - len(params))
    gcs.conn.mav.command_long_send(*VEHICLE, cmd, 0, *p)
    try:
        ack = gcs.wait_type("COMMAND_ACK", 3.0, step, lambda m: m.command == cmd)
    except Failed:
        return "NONE"
    result = enum_name("MAV_RESULT", ack.result)
    gcs.log(f"COMMAND_ACK {enum_name('MAV_CMD', cmd)} {result}")
    return result


def follow_mode(gcs, step):
    return ack_of(gcs, mav.MAV_CMD_DO_SET_MODE, [mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES["FOLLOW"]], step)


def scenario(gcs):
    acks, modes = {}, {}
    gcs.results["acks"], gcs.results["modes"] = acks, modes
    gcs.identify(timeout_s=30.0)
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 4, 1)
    gcs.quiet(1.0)
    arm_in_guided(gcs)
    while ack_of(gcs, mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off") != "MAV_RESULT_ACCEPTED":
        if not gcs.armed:
            raise Failed("take-off", gcs.statustexts[-3:])
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 0.5, 40.0, "take-off")
    # With a position (ArduCopter checks that first, "requires position"): refused for FOLL_ENABLE.
    texts_before = len(gcs.statustexts)
    acks["follow_disabled"] = follow_mode(gcs, "follow disabled")
    gcs.quiet(0.5)
    gcs.results["texts"] = [t for t in gcs.statustexts[texts_before:] if "FOLL" in t]
    modes["after_follow_disabled"] = gcs.mode
    gcs.set_param("FOLL_ENABLE", 1.0, "FOLL_ENABLE")
    gcs.quiet(1.5)
    lat0, lon0 = gcs.position
    home_alt = None

    def track(m):
        nonlocal home_alt
        if m.get_type() == "GLOBAL_POSITION_INT":
            home_alt = (m.alt - m.relative_alt) / 1000.0

    gcs.watchers.append(track)
    gcs.wait_type("GLOBAL_POSITION_INT", 3.0, "home altitude")
    # t0: the vehicle's time the walk starts (when FOLLOW is accepted); until then the target
    # stands AHEAD_M north of the vehicle.
    state = {"t0": None, "last": None, "sending": True}
    samples = []

    def walked(t):
        return SPEED_M_S * min(max(t, 0.0), WALK_S)

    def send(m):
        if gcs.boot_s is None or not state["sending"]:
            return
        t = 0.0 if state["t0"] is None else gcs.boot_s - state["t0"]
        if m.get_type() == "GLOBAL_POSITION_INT" and state["t0"] is not None:
            north = (m.lat / 1e7 - lat0) * M_PER_DEG_LAT
            east = (m.lon / 1e7 - lon0) * M_PER_DEG_LAT * math.cos(math.radians(lat0))
            samples.append((t, walked(t) - north, east, m.relative_alt / 1000.0))
        if state["last"] is not None and gcs.boot_s - state["last"] < REPORT_S:
            return
        state["last"] = gcs.boot_s
        lat = lat0 + (AHEAD_M + walked(t)) / M_PER_DEG_LAT
        v_n = SPEED_M_S if 0.0 <= t < WALK_S else 0.0
        gcs.conn.mav.follow_target_send(
            int(gcs.boot_s * 1000), 0b11, int(round(lat * 1e7)), int(round(lon0 * 1e7)), home_alt,
            [v_n, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0)

    gcs.watchers.append(send)
    gcs.quiet(1.0)
    acks["follow"] = follow_mode(gcs, "follow")
    state["t0"] = start = gcs.boot_s
    gcs.quiet(0.5)
    modes["after_follow"] = gcs.mode
    gcs.pump(lambda m: gcs.boot_s - start >= WALK_S + 8.0, 60.0, "walk")
    modes["after_walk"] = gcs.mode
    walking = [s for s in samples if 5.0 < s[0] < WALK_S]
    stopped = [s for s in samples if s[0] > WALK_S + 5.0]
    if walking and stopped:
        north_end = walked(samples[-1][0]) - samples[-1][1]
        gcs.results["follow"] = {
            "lag_m": round(sum(s[1] for s in walking) / len(walking), 2),
            "side_m": round(max(abs(s[2]) for s in walking + stopped), 2),
            "height_m": round(max(abs(s[3] - TAKEOFF_M) for s in walking + stopped), 2),
            "final_m": round(sum(abs(s[1]) for s in stopped) / len(stopped), 2),
            "flown_m": round(north_end, 1),
        }
        gcs.log(f"follow flown: {gcs.results['follow']}")
    state["sending"] = False
    speeds = []

    def watch(m):
        if m.get_type() == "GLOBAL_POSITION_INT":
            speeds.append(math.hypot(m.vx, m.vy) / 100.0)

    gcs.watchers.append(watch)
    lost = gcs.boot_s
    gcs.pump(lambda m: gcs.boot_s - lost >= 6.0, 30.0, "target lost")
    last = speeds[-4:]
    gcs.results["lost_speed_m_s"] = round(sum(last) / len(last), 3) if last else None
    modes["after_lost"] = gcs.mode


main(scenario, deadline_s=float(os.environ.get("DEADLINE_S", "110")))
