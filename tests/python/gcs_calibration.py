"""The sensor calibration over MAVLink (tests/gcs_calibration.rs): a pymavlink ground station runs the
accelerometer, level and compass calibrations of a simulated vehicle with sensor errors as
MAVProxy's `accelcal`, `calibrate level` and `magcal` drive ArduPilot, and checks the pre-arm.

`CAL_SCENARIO=calibrate`: arming is refused with the STATUSTEXT naming the missing step;
PREFLIGHT_CALIBRATION param5=1 and each COMMAND_LONG(ACCELCAL_VEHICLE_POS) the vehicle sends is
answered with the same position once "placed" (the simulator places it); param5=2 for level;
DO_START_MAG_CAL, MAG_CAL_PROGRESS until MAG_CAL_REPORT, DO_ACCEPT_MAG_CAL; a bad command is
refused with a reason; then the parameters are read and, without a restart, the vehicle flies
the plan in `CAL_PLAN` (PX4's way: the estimator aligns again on the new calibration while
disarmed; ArduPilot would ask for a reboot). `CAL_SCENARIO=verify` (after a restart): the
parameters are read and arming is accepted. `CAL_SCENARIO=reference`: the plan flown by a
vehicle without sensor errors, for the yaw error to compare with.

In flight, the estimator's yaw (ATTITUDE) is compared with the simulator's true yaw (SIMSTATE,
which ArduPilot SITL sends too), each ATTITUDE with the SIMSTATE sent beside it.
The results carry every parameter read and the flight's RMS yaw error; the test compares them
with the vehicle file's truth.
"""

import math
import os

from gcs_common import Failed, distance_m, enum_name, main, mav, plan_items, upload_and_download

CALIBRATION_PREFIXES = ("COMPASS_", "INS_ACC", "INS_GYR", "AHRS_TRIM")


def calibration_params(gcs):
    params = gcs.fetch_params()
    return {k: v for k, v in params.items() if k.startswith(CALIBRATION_PREFIXES)}


def texts(gcs):
    return list(gcs.statustexts)


def wait_text(gcs, needle, timeout_s, step):
    """Waits for a STATUSTEXT containing `needle` (chunked texts are joined by their id)."""
    chunks = {}

    def seen(m):
        if m.get_type() != "STATUSTEXT" or not gcs.from_vehicle(m):
            return False
        text = m.text
        if m.id:
            chunks.setdefault(m.id, {})[m.chunk_seq] = text
            text = "".join(chunks[m.id][k] for k in sorted(chunks[m.id]))
        if "FAILED" in text and needle not in text and len(m.text) < 50:
            raise Failed(step, text)
        return needle in text

    return gcs.pump(seen, timeout_s, step)


def arm_refused(gcs):
    gcs.log("-> COMMAND_LONG MAV_CMD_COMPONENT_ARM_DISARM [1] (expect a refusal)")
    gcs.conn.mav.command_long_send(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    ack = gcs.wait_type("COMMAND_ACK", 3.0, "arm refused",
                        lambda m: m.command == mav.MAV_CMD_COMPONENT_ARM_DISARM)
    if ack.result == mav.MAV_RESULT_ACCEPTED:
        raise Failed("arm refused", "arming was accepted before calibration")
    text = gcs.wait_type("STATUSTEXT", 3.0, "arm refused", lambda m: "PreArm" in m.text)
    gcs.results["prearm_refusal"] = text.text


def accelcal(gcs):
    gcs.command(mav.MAV_CMD_PREFLIGHT_CALIBRATION, [0, 0, 0, 0, 1, 0, 0], "accelcal start")
    positions = []
    while True:
        m = gcs.wait_type("COMMAND_LONG", 20.0, "accelcal position",
                          lambda m: m.command == mav.MAV_CMD_ACCELCAL_VEHICLE_POS)
        pos = int(m.param1)
        if pos == mav.ACCELCAL_VEHICLE_POS_SUCCESS:
            break
        if pos == mav.ACCELCAL_VEHICLE_POS_FAILED:
            raise Failed("accelcal", texts(gcs)[-3:])
        gcs.log(f"vehicle asks for position {enum_name('ACCELCAL_VEHICLE_POS', pos)}: placed")
        positions.append(pos)
        gcs.command(mav.MAV_CMD_ACCELCAL_VEHICLE_POS, [pos], f"accelcal position {pos}")
    gcs.results["accel_positions"] = positions


def level(gcs):
    gcs.command(mav.MAV_CMD_PREFLIGHT_CALIBRATION, [0, 0, 0, 0, 2, 0, 0], "level start")
    wait_text(gcs, "level calibration successful", 10.0, "level")


def magcal(gcs):
    gcs.command(mav.MAV_CMD_DO_START_MAG_CAL, [0, 0, 0, 0, 0], "magcal start")
    progress = []

    def report(m):
        if m.get_type() == "MAG_CAL_PROGRESS" and gcs.from_vehicle(m):
            if not progress or m.completion_pct != progress[-1]:
                gcs.log(f"MAG_CAL_PROGRESS {m.completion_pct} %")
            progress.append(m.completion_pct)
        return m.get_type() == "MAG_CAL_REPORT" and gcs.from_vehicle(m)

    r = gcs.pump(report, 60.0, "magcal report")
    gcs.log(f"MAG_CAL_REPORT {enum_name('MAG_CAL_STATUS', r.cal_status)} fitness {r.fitness:.1f} mG "
            f"ofs ({r.ofs_x:.1f}, {r.ofs_y:.1f}, {r.ofs_z:.1f}) autosaved {r.autosaved}")
    if r.cal_status != mav.MAG_CAL_SUCCESS:
        raise Failed("magcal", texts(gcs)[-3:])
    gcs.results["mag_fitness_mgauss"] = r.fitness
    gcs.results["mag_progress_max"] = max(progress) if progress else None
    gcs.command(mav.MAV_CMD_DO_ACCEPT_MAG_CAL, [0], "magcal accept")
    wait_text(gcs, "accepted", 5.0, "magcal accept")


def bad_commands(gcs):
    """Values the commands do not define are refused with a reason, and nothing starts."""
    gcs.command(mav.MAV_CMD_PREFLIGHT_CALIBRATION, [0, 0, 0, 0, 3, 0, 0], "bad param5",
                expect=mav.MAV_RESULT_UNSUPPORTED)
    gcs.command(mav.MAV_CMD_PREFLIGHT_CALIBRATION, [float("nan"), 0, 0, 0, 1, 0, 0], "nan param1",
                expect=mav.MAV_RESULT_DENIED)
    gcs.command(mav.MAV_CMD_ACCELCAL_VEHICLE_POS, [1], "position without a calibration",
                expect=mav.MAV_RESULT_DENIED)
    gcs.command(mav.MAV_CMD_DO_ACCEPT_MAG_CAL, [0], "accept without a fit", expect=mav.MAV_RESULT_DENIED)


class YawError:
    """RMS of ATTITUDE.yaw − SIMSTATE.yaw while the vehicle is armed and 1 m up."""

    def __init__(self, gcs):
        self.gcs = gcs
        self.truth = None
        self.sum_sq = 0.0
        self.samples = 0

    def __call__(self, m):
        if m.get_type() == "SIMSTATE":
            self.truth = m.yaw
        elif m.get_type() == "ATTITUDE" and self.truth is not None and self.gcs.armed \
                and (self.gcs.rel_alt_m or 0.0) > 1.0:
            error = math.remainder(m.yaw - self.truth, 2.0 * math.pi)
            self.sum_sq += error * error
            self.samples += 1

    def rms_deg(self):
        if self.samples == 0:
            raise Failed("yaw error", "no ATTITUDE paired with a SIMSTATE in flight")
        return math.degrees(math.sqrt(self.sum_sq / self.samples))


def fly_plan(gcs):
    """Uploads CAL_PLAN, arms, flies it in AUTO to its RTL and landing; returns the flight."""
    items = plan_items(os.environ["CAL_PLAN"])
    home = (items[0]["lat"], items[0]["lon"])
    upload_and_download(gcs, items)
    gcs.wait_ready(30.0)
    yaw = YawError(gcs)
    gcs.watchers.append(yaw)
    gcs.set_mode_command("GUIDED", "guided")
    gcs.arm("arm after calibration")
    gcs.set_mode_command("AUTO", "auto")
    waypoints = len(items) - 2  # all but home and the final RTL
    gcs.pump(lambda m: len(gcs.reached) >= waypoints, 60.0, "waypoints reached")
    gcs.pump(lambda m: gcs.heartbeat is not None and not gcs.armed
             and gcs.landed_state == "MAV_LANDED_STATE_ON_GROUND", 60.0, "landed and disarmed")
    flight = {"rms_yaw_deg": yaw.rms_deg(), "yaw_samples": yaw.samples,
              "landed_from_home_m": distance_m(gcs.position, home), "reached": gcs.reached}
    gcs.log(f"flight: {flight}")
    return flight


def body(gcs):
    gcs.identify()
    # Not `wait_ready`: SYS_STATUS shows the pre-arm check failing until calibrated.
    gcs.pump(lambda m: gcs.home is not None, 20.0, "home")
    gcs.quiet(2.0)
    scenario = os.environ.get("CAL_SCENARIO", "calibrate")
    if scenario == "calibrate":
        gcs.results["before"] = calibration_params(gcs)
        arm_refused(gcs)
        bad_commands(gcs)
        accelcal(gcs)
        level(gcs)
        magcal(gcs)
        gcs.quiet(1.0)
        gcs.results["params"] = calibration_params(gcs)
        gcs.results["flight"] = fly_plan(gcs)
        return
    if scenario == "reference":
        gcs.results["flight"] = fly_plan(gcs)
        return
    gcs.results["params"] = calibration_params(gcs)
    gcs.wait_ready(30.0)
    gcs.arm("arm after calibration")
    gcs.results["armed"] = True
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, [0], "disarm")


if __name__ == "__main__":
    main(body, deadline_s=150.0)
