"""Flies config/missions/square.plan with ArduCopter as a ground station would, and reports what
ArduCopter says it did. Run against ArduCopter SITL on Kestrel's physics (`kestrel sitl
ardupilot`) and on its own `--model +` physics (tests/sitl_ardupilot.rs).

Usage: ardupilot_square.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)
Environment: PLAN (the .plan file), DEADLINE_S (wall seconds the session may take), TAKEOFF_M
(the GUIDED take-off height, default 10 m), ESTIMATE=1 (also report ArduCopter's estimate: every
LOCAL_POSITION_NED and ATTITUDE seen, stamped with its time_boot_ms; tests/sitl_side_by_side.rs
compares them with the simulator's truth at the same instants), GROUND_DISARM_S (a vehicle still
armed that long on the ground after the mission is disarmed by force, and the results say so),
ENGINE_FAIL_MASK and ENGINE_FAIL_AFTER_S (SIM_ENGINE_MUL 0 and SIM_ENGINE_FAIL set to the mask
of servos that long, of its time, after the vehicle first rose 0.2 m above home: SITL cuts those
motors on its own physics and on Kestrel's alike; the results hold `engine_failed_s`, seconds
after that take-off).

1. identify the vehicle, ask for its telemetry streams (ArduCopter sends only what is asked for);
2. upload the plan (home as item 0, as ArduPilot numbers it);
3. GUIDED and arm (each retried until ArduCopter's checks pass), take off to 10 m;
4. AUTO: the square, then the plan's RTL, which lands at home and disarms;
5. read MOT_THST_HOVER, the hover throttle ArduCopter learned in flight.

The last line's `results` hold `max_rel_alt_m`, `reached` (MISSION_ITEM_REACHED seqs),
`mission_currents` (each new MISSION_CURRENT seq),
`landed_from_home_m` (GLOBAL_POSITION_INT against HOME_POSITION once disarmed), `modes`,
`hover_throttle` and the simulated seconds each phase took.
"""

import os
import time

from gcs_common import (accepted, ACM_MODES, arm_in_guided, distance_m, enum_name, Failed, main,
                        mav, mavutil, plan_items, VEHICLE)

TAKEOFF_M = float(os.environ.get("TAKEOFF_M", "10"))
GROUND_DISARM_S = float(os.environ["GROUND_DISARM_S"]) if "GROUND_DISARM_S" in os.environ else None


def upload(gcs, items):
    """MISSION_COUNT, then each item ArduCopter asks for (MISSION_REQUEST_INT, or the legacy
    MISSION_REQUEST it uses with a client it has not heard ask for INT) as MISSION_ITEM_INT."""
    gcs.log(f"-> MISSION_COUNT {len(items)}")
    gcs.conn.mav.mission_count_send(*VEHICLE, len(items), mav.MAV_MISSION_TYPE_MISSION)
    while True:
        m = gcs.pump(lambda m: gcs.from_vehicle(m)
                     and m.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"),
                     5.0, "mission upload")
        if m.get_type() == "MISSION_ACK":
            if m.type != mav.MAV_MISSION_ACCEPTED:
                raise Failed("mission upload", enum_name("MAV_MISSION_RESULT", m.type))
            gcs.log("MISSION_ACK ACCEPTED")
            return len(items)
        it = items[m.seq]
        gcs.conn.mav.mission_item_int_send(
            *VEHICLE, m.seq, it["frame"], it["command"], 0, it["autocontinue"],
            *it["params"], it["x"], it["y"], it["alt"], mav.MAV_MISSION_TYPE_MISSION)




def until_mode(gcs, name, timeout_s=20.0):
    """DO_SET_MODE until HEARTBEAT shows `name` (a lost COMMAND_ACK is asked again)."""
    end = time.monotonic() + timeout_s
    gcs.log(f"-> mode {name}")
    while gcs.mode != name:
        if time.monotonic() > end:
            raise Failed(name, f"not in {name} after {timeout_s} s: {gcs.statustexts[-3:]}")
        if accepted(gcs, mav.MAV_CMD_DO_SET_MODE,
                    [mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ACM_MODES[name]], name):
            try:
                gcs.wait_type("HEARTBEAT", 3.0, name, lambda m: mavutil.mode_string_v10(m) == name)
            except Failed:
                pass




def wait_disarmed_or_force(gcs, ground_s):
    """Waits for the vehicle to disarm itself; one that has sat below 0.3 m for `ground_s` of its
    time still armed (its land detector has not tripped) is disarmed by force, as a pilot would,
    and `forced_disarm_after_s` says so."""
    low_since = [None]

    def ground_timer(m):
        if gcs.rel_alt_m is None or gcs.boot_s is None:
            return False
        if gcs.rel_alt_m > 0.3:
            low_since[0] = None
        elif low_since[0] is None:
            low_since[0] = gcs.boot_s
        return low_since[0] is not None and gcs.boot_s - low_since[0] >= ground_s

    gcs.pump(lambda m: (gcs.heartbeat is not None and not gcs.armed) or ground_timer(m), 60.0,
             "landed and disarmed")
    if gcs.armed:
        gcs.results["forced_disarm_after_s"] = ground_s
        gcs.log(f"-> force disarm: armed {ground_s} s on the ground")
        while gcs.armed:
            accepted(gcs, mav.MAV_CMD_COMPONENT_ARM_DISARM, [0, 21196], "force disarm")
            gcs.quiet(0.3)


def record_estimate(gcs):
    """Keeps every LOCAL_POSITION_NED ([t_ms, x, y, z, vx, vy, vz], m and m/s from EKF3's origin),
    ATTITUDE ([t_ms, roll, pitch, yaw], rad) and, on SITL's own physics, SIMSTATE ([t_ms, lat,
    lon (deg), roll, pitch, yaw (rad)]: its truth) in the results."""
    positions = gcs.results.setdefault("local_position_ned", [])
    attitudes = gcs.results.setdefault("attitude", [])
    truth = gcs.results.setdefault("simstate", [])

    def watch(m):
        kind = m.get_type()
        if kind == "LOCAL_POSITION_NED":
            positions.append([m.time_boot_ms, m.x, m.y, m.z, m.vx, m.vy, m.vz])
        elif kind == "ATTITUDE":
            attitudes.append([m.time_boot_ms, m.roll, m.pitch, m.yaw])
        elif kind == "SIMSTATE" and gcs.boot_s is not None:
            # SITL's physics state (its own model's truth), stamped with the last boot time seen.
            truth.append([round(gcs.boot_s * 1000), m.lat * 1e-7, m.lng * 1e-7, m.roll, m.pitch,
                          m.yaw])

    gcs.watchers.append(watch)


def fail_engines_after_take_off(gcs, mask, after_s):
    """SIM_ENGINE_MUL 0 then SIM_ENGINE_FAIL `mask` once `after_s` of the vehicle's time have
    passed since it first rose 0.2 m above home: SITL scales those servos' pulses towards 1000 us
    (no thrust, no reaction torque), as Kestrel's `motor_lost` fault takes a motor's."""
    state = {"take_off_s": None, "sent": False}

    def watch(m):
        if gcs.boot_s is None or state["sent"]:
            return
        if state["take_off_s"] is None:
            if gcs.armed and (gcs.rel_alt_m or 0.0) > 0.2:
                state["take_off_s"] = gcs.boot_s
            return
        if gcs.boot_s - state["take_off_s"] >= after_s:
            state["sent"] = True
            gcs.log(f"-> SIM_ENGINE_MUL 0, SIM_ENGINE_FAIL {mask}")
            gcs.conn.mav.param_set_send(*VEHICLE, b"SIM_ENGINE_MUL", 0.0, mav.MAV_PARAM_TYPE_REAL32)
            gcs.conn.mav.param_set_send(*VEHICLE, b"SIM_ENGINE_FAIL", float(mask),
                                        mav.MAV_PARAM_TYPE_INT32)
            gcs.results["engine_failed_s"] = round(gcs.boot_s - state["take_off_s"], 2)

    gcs.watchers.append(watch)


def flight(gcs):
    if os.environ.get("ESTIMATE") == "1":
        record_estimate(gcs)
    if "ENGINE_FAIL_MASK" in os.environ:
        fail_engines_after_take_off(gcs, int(os.environ["ENGINE_FAIL_MASK"]),
                                    float(os.environ["ENGINE_FAIL_AFTER_S"]))
    gcs.identify(timeout_s=30.0, types=(mav.MAV_TYPE_QUADROTOR, mav.MAV_TYPE_HEXAROTOR))
    # 4 Hz of ArduCopter's time: at ten times real time and more, faster streams overrun a Python
    # client's socket and lose COMMAND_ACKs.
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 4, 1)
    items = plan_items(os.environ["PLAN"])
    gcs.results["items"] = upload(gcs, items)
    arm_in_guided(gcs)
    armed_at = gcs.boot_s
    while not accepted(gcs, mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off"):
        if not gcs.armed or (gcs.rel_alt_m or 0.0) > 1.0:
            break
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 0.5, 40.0, "take-off")
    gcs.results["takeoff_s"] = round(gcs.boot_s - armed_at, 2)
    until_mode(gcs, "AUTO")
    auto_at = gcs.boot_s
    last = len(items) - 2  # the last waypoint; the final item is the RTL
    # Reached, or MISSION_CURRENT past it: at many times real time a UDP datagram to a Python
    # client can be lost, MISSION_ITEM_REACHED as well as any other.
    # A vehicle that disarms on the way (a crash check after a lost motor) ends the mission there.
    gcs.pump(lambda m: last in gcs.reached or (gcs.mission_current or 0) > last or not gcs.armed,
             60.0, "square")
    gcs.results["square_s"] = round(gcs.boot_s - auto_at, 2)
    if GROUND_DISARM_S is None:
        gcs.pump(lambda m: gcs.heartbeat is not None and not gcs.armed, 60.0, "landed and disarmed")
    else:
        wait_disarmed_or_force(gcs, GROUND_DISARM_S)
    gcs.quiet(0.5)
    gcs.results["flight_s"] = round(gcs.boot_s - armed_at, 2)
    gcs.results["max_rel_alt_m"] = round(gcs.max_rel_alt_m, 2)
    gcs.results["reached"] = gcs.reached
    gcs.results["mission_currents"] = gcs.mission_currents
    gcs.results["modes"] = [m for m in gcs.modes_seen if m in ACM_MODES]
    home = gcs.home or (items[0]["lat"], items[0]["lon"])
    gcs.results["landed_from_home_m"] = round(distance_m(gcs.position, home), 2)
    gcs.results["landed_rel_alt_m"] = gcs.rel_alt_m
    gcs.results["hover_throttle"] = round(gcs.read_param("MOT_THST_HOVER", "hover throttle"), 4)


main(flight, deadline_s=float(os.environ.get("DEADLINE_S", "110")))
