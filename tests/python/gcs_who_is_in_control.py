"""Who is in control, seen from the ground: `kestrel run` with two ground stations (run by
tests/gcs_who_is_in_control.rs; see gcs_common.py for the transcript).

Usage: gcs_who_is_in_control.py two_stations | stale_sticks

Both print their UDP ports first (`PORT n`, then for `two_stations` the second station's): the
vehicle's config sends MAVLink to each.

two_stations: system 255 (MAV_GCS_SYSID's default) and system 254 both heartbeat at 10 Hz and
both send MANUAL_CONTROL at 10 Hz. 255 sets LOITER (our POSHOLD), arms on a low throttle and
climbs to 5 m on the throttle; then 255 holds full forward and 254 full back: the vehicle must
fly forward (its position in LOCAL_POSITION_NED and GLOBAL_POSITION_INT). Then 255 sets GUIDED
(so no stick mode is flown) and falls silent, while 254 keeps its heartbeats and sticks: the
vehicle must report the GCS failsafe (STATUSTEXT "GCS link lost", HEARTBEAT RTL and CRITICAL).

stale_sticks: system 255 sends one full-deflection MANUAL_CONTROL and then nothing for 8 s of
vehicle time; ACRO and arming must be refused (COMMAND_ACK not ACCEPTED, a STATUSTEXT naming
why); with live sticks and the throttle low, ACRO and arming are accepted and the vehicle arms.
"""

import math
import sys
import time

from pymavlink import mavutil

from gcs_common import ACM_MODES, VEHICLE, Failed, Gcs, enum_name, mav

SCENARIO = sys.argv[1] if len(sys.argv) > 1 else ""
STICK_PERIOD_S = 0.1


class Station(Gcs):
    """Gcs (system 255) that also sends MANUAL_CONTROL at 10 Hz while `sticks` is set, and drives
    a second ground station (system 254, its own UDP socket) with heartbeats and sticks."""

    def __init__(self, second):
        super().__init__(deadline_s=55.0)
        self.sticks = None
        self.last_sticks_sent = 0.0
        self.other = None
        self.other_sticks = None
        self.other_heartbeats_on = True
        self.other_last_sent = 0.0
        if second:
            self.other = mavutil.mavlink_connection(
                "udpin:127.0.0.1:0", source_system=254, source_component=190)
            print("PORT", self.other.port.getsockname()[1], flush=True)

    def manual_control(self, conn, sticks):
        x, y, z, r = sticks
        conn.mav.manual_control_send(VEHICLE[0], x, y, z, r, 0)

    def send_heartbeat_if_due(self):
        super().send_heartbeat_if_due()
        now = time.monotonic()
        if self.sticks is not None and now - self.last_sticks_sent >= STICK_PERIOD_S:
            self.manual_control(self.conn, self.sticks)
            self.last_sticks_sent = now
        if self.other is not None:
            if now - self.other_last_sent >= STICK_PERIOD_S:
                if self.other_heartbeats_on:
                    self.other.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                if self.other_sticks is not None:
                    self.manual_control(self.other, self.other_sticks)
                self.other_last_sent = now
            # The second station reads what the vehicle sends it, as a ground station does.
            while self.other.recv_match(blocking=False) is not None:
                pass

    def set_mode_raw(self, name):
        """SET_MODE; returns the COMMAND_ACK's result name."""
        self.log(f"-> SET_MODE {name} (custom_mode {ACM_MODES[name]})")
        self.conn.mav.set_mode_send(VEHICLE[0], mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES[name])
        ack = self.wait_type("COMMAND_ACK", 3.0, f"mode {name}", lambda m: m.command == mav.MAV_CMD_DO_SET_MODE)
        return enum_name("MAV_RESULT", ack.result)

    def arm_raw(self):
        """COMMAND_LONG arm; returns the COMMAND_ACK's result name."""
        self.log("-> COMMAND_LONG COMPONENT_ARM_DISARM [1]")
        self.conn.mav.command_long_send(*VEHICLE, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        ack = self.wait_type("COMMAND_ACK", 3.0, "arm", lambda m: m.command == mav.MAV_CMD_COMPONENT_ARM_DISARM)
        return enum_name("MAV_RESULT", ack.result)


def track_position(gcs):
    """Keeps the vehicle's newest LOCAL_POSITION_NED and heading in `gcs`."""
    gcs.local = None
    gcs.yaw = None

    def watch(msg):
        if msg.get_type() == "LOCAL_POSITION_NED":
            gcs.local = (msg.x, msg.y, msg.z)
        elif msg.get_type() == "ATTITUDE":
            gcs.yaw = msg.yaw

    gcs.watchers.append(watch)


def forward_m(gcs, start_local, start_global):
    """How far the vehicle moved along its heading since the start, by LOCAL_POSITION_NED and
    by GLOBAL_POSITION_INT (m)."""
    yaw = gcs.yaw or 0.0
    north, east = gcs.local[0] - start_local[0], gcs.local[1] - start_local[1]
    local = north * math.cos(yaw) + east * math.sin(yaw)
    g_north = (gcs.position[0] - start_global[0]) * 111_320.0
    g_east = (gcs.position[1] - start_global[1]) * 111_320.0 * math.cos(math.radians(start_global[0]))
    global_ = g_north * math.cos(yaw) + g_east * math.sin(yaw)
    return local, global_


def two_stations(gcs):
    track_position(gcs)
    gcs.identify()
    gcs.wait_ready()
    gcs.pump(lambda m: gcs.local is not None and gcs.position is not None, 5.0, "position")
    gcs.set_mode_message("LOITER", "loiter")
    # Throttle low to arm; 254 pushes the opposite way all along.
    gcs.sticks = (0, 0, 0, 0)
    gcs.other_sticks = (0, 0, 1000, 0)
    gcs.quiet(0.3)
    gcs.arm()
    gcs.sticks = (0, 0, 1000, 0)
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= 5.0, 15.0, "climb on 255's throttle")
    gcs.sticks = (0, 0, 500, 0)
    gcs.quiet(0.5)
    start_local, start_global, start_t = gcs.local, gcs.position, gcs.boot_s
    gcs.log(f"255 full forward, 254 full back, from {start_local}")
    gcs.sticks = (1000, 0, 500, 0)
    gcs.other_sticks = (-1000, 0, 500, 0)
    gcs.pump(lambda m: gcs.boot_s is not None and gcs.boot_s >= start_t + 6.0, 10.0, "6 s of opposite sticks")
    local, global_ = forward_m(gcs, start_local, start_global)
    gcs.log(f"moved forward {local:.1f} m (LOCAL_POSITION_NED), {global_:.1f} m (GLOBAL_POSITION_INT)")
    if not (local > 10.0 and global_ > 10.0):
        raise Failed("only MAV_GCS_SYSID flies", f"forward {local:.1f} m / {global_:.1f} m in 6 s")
    ignored = [t for t in gcs.statustexts if "Sticks from sysid 254 ignored" in t]
    if not ignored:
        raise Failed("ignored sticks announced", gcs.statustexts)
    gcs.results["opposite_sticks"] = {"forward_local_m": round(local, 2), "forward_global_m": round(global_, 2),
                                      "ignored_text": ignored[0]}

    # 255 leaves the sticks (GUIDED holds without them) and falls silent; 254 goes on.
    gcs.sticks = (0, 0, 500, 0)
    gcs.quiet(0.3)
    gcs.set_mode_message("GUIDED", "guided")
    gcs.sticks = None
    gcs.heartbeats_on = False
    silent_from = gcs.boot_s
    gcs.log(f"255 falls silent at t={silent_from:.2f}s; 254 keeps heartbeating and sending sticks")
    gcs.pump(lambda m: m.get_type() == "STATUSTEXT" and "GCS link lost" in m.text, 12.0, "GCS failsafe STATUSTEXT")
    failsafe_after = gcs.boot_s - silent_from
    gcs.pump(lambda m: gcs.mode == "RTL" and gcs.system_status == "MAV_STATE_CRITICAL", 5.0, "RTL in HEARTBEAT")
    gcs.quiet(0.3)
    if not any("GCS heartbeat lost" in t for t in gcs.statustexts):
        raise Failed("the link's own loss text follows MAV_GCS_SYSID", gcs.statustexts)
    gcs.log(f"GCS failsafe {failsafe_after:.2f} s (vehicle time) after 255's last heartbeat")
    gcs.results["gcs_failsafe"] = {"after_s": round(failsafe_after, 2), "mode": gcs.mode,
                                   "system_status": gcs.system_status}


def stale_sticks(gcs):
    gcs.identify()
    gcs.wait_ready()
    gcs.log("-> one MANUAL_CONTROL, full deflection")
    gcs.manual_control(gcs.conn, (1000, 1000, 1000, 1000))
    sent_at = gcs.boot_s
    # 8 s of silence on the vehicle's clock (telemetry's time_boot_ms lags it by a stream period).
    gcs.pump(lambda m: gcs.boot_s is not None and gcs.boot_s >= sent_at + 8.2, 10.0, "8 s of silence")
    acro = gcs.set_mode_raw("ACRO")
    arm = gcs.arm_raw()
    gcs.quiet(0.5)
    if acro == "MAV_RESULT_ACCEPTED" or arm == "MAV_RESULT_ACCEPTED" or gcs.armed:
        raise Failed("stale sticks refused", f"ACRO {acro}, arm {arm}, armed {gcs.armed}")
    why = [t for t in gcs.statustexts if t.startswith("Arm:")]
    if not why:
        raise Failed("refusal named", gcs.statustexts)
    gcs.results["stale"] = {"acro": acro, "arm": arm, "mode": gcs.mode, "why": why[-1]}
    # Live sticks, throttle low.
    gcs.sticks = (0, 0, 0, 0)
    gcs.quiet(0.5)
    acro = gcs.set_mode_raw("ACRO")
    arm = gcs.arm_raw()
    gcs.pump(lambda m: gcs.armed and gcs.mode == "ACRO", 3.0, "armed in ACRO")
    if (acro, arm) != ("MAV_RESULT_ACCEPTED", "MAV_RESULT_ACCEPTED"):
        raise Failed("live sticks arm", f"ACRO {acro}, arm {arm}")
    gcs.results["live"] = {"acro": acro, "arm": arm, "armed": gcs.armed, "mode": gcs.mode}
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, [0], "disarm")


def run():
    if SCENARIO not in ("two_stations", "stale_sticks"):
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    gcs = Station(second=SCENARIO == "two_stations")
    try:
        (two_stations if SCENARIO == "two_stations" else stale_sticks)(gcs)
    except Failed as e:
        gcs.fail(e.step, e.detail)
    gcs.finish()


run()
