"""The ESC range calibration over MAVLink (tests/gcs_esc_calibration.rs): a pymavlink ground station runs
the ESC range calibration of a simulated vehicle whose four ESCs each have a range of their own
(config/vehicles/quad_x_unequal_escs.toml), as the MAVLink spec defines it: PREFLIGHT_CALIBRATION
param7 = 1.

`ESC_SCENARIO=calibrate`: the SERVOn_MIN/MAX parameters are read (PARAM_REQUEST_READ); the
calibration is refused while armed, with a STATUSTEXT saying so; started, it tells the operator
to remove the propellers; PREFLIGHT_CALIBRATION with every parameter 0 cancels it; an arm request
while it runs is refused and stops it; started again it runs to its end, and the parameters are
read back one by one. `ESC_SCENARIO=no_telemetry` (a graph without ESC telemetry or battery
monitor): refused naming the missing telemetry. The results carry every parameter read and
the STATUSTEXTs that answered; the test compares them with the vehicle file's truth.
"""

import os

from gcs_calibration import wait_text
from gcs_common import Failed, enum_name, main, mav

OUTPUTS = 4
ESC_CAL = [0, 0, 0, 0, 0, 0, 1]
CANCEL = [0, 0, 0, 0, 0, 0, 0]


def servo_params(gcs):
    """Each output's SERVOn_MIN/MAX, read by name."""
    return {f"SERVO{i}_{end}": gcs.read_param(f"SERVO{i}_{end}", f"read SERVO{i}_{end}")
            for i in range(1, OUTPUTS + 1) for end in ("MIN", "MAX")}


def refused(gcs, params, step, needle):
    """COMMAND_LONG PREFLIGHT_CALIBRATION `params` must be refused, with a STATUSTEXT holding
    `needle`; returns that text."""
    gcs.log(f"-> COMMAND_LONG MAV_CMD_PREFLIGHT_CALIBRATION {params} (expect a refusal)")
    gcs.conn.mav.command_long_send(1, 1, mav.MAV_CMD_PREFLIGHT_CALIBRATION, 0, *params)
    ack = gcs.wait_type("COMMAND_ACK", 3.0, step,
                        lambda m: m.command == mav.MAV_CMD_PREFLIGHT_CALIBRATION)
    if ack.result == mav.MAV_RESULT_ACCEPTED:
        raise Failed(step, "accepted")
    text = wait_text(gcs, needle, 3.0, step).text
    gcs.log(f"refused ({enum_name('MAV_RESULT', ack.result)}): {text}")
    return {"result": enum_name("MAV_RESULT", ack.result), "text": text}


def start(gcs, step):
    gcs.command(mav.MAV_CMD_PREFLIGHT_CALIBRATION, ESC_CAL, step)
    return wait_text(gcs, "REMOVE THE PROPELLERS", 3.0, step)


def calibrate(gcs):
    gcs.results["before"] = servo_params(gcs)
    gcs.wait_ready(30.0)
    gcs.set_mode_command("GUIDED", "guided")
    gcs.arm("arm")
    gcs.results["armed_refusal"] = refused(gcs, ESC_CAL, "refused armed", "armed")
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, [0], "disarm")
    gcs.wait_type("HEARTBEAT", 3.0, "disarmed",
                  lambda m: not m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)

    start(gcs, "start to cancel")
    gcs.quiet(1.0)
    gcs.command(mav.MAV_CMD_PREFLIGHT_CALIBRATION, CANCEL, "cancel")
    gcs.results["cancelled"] = wait_text(gcs, "ESC calibration cancelled", 3.0, "cancelled").text

    start(gcs, "start to arm")
    gcs.quiet(1.0)
    gcs.log("-> COMMAND_LONG MAV_CMD_COMPONENT_ARM_DISARM [1] (expect a refusal)")
    gcs.conn.mav.command_long_send(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    seen = {}

    def refused_and_stopped(m):
        # The stop's STATUSTEXT and the refusal's COMMAND_ACK come in either order.
        if not gcs.from_vehicle(m):
            return False
        if m.get_type() == "COMMAND_ACK" and m.command == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            seen["ack"] = enum_name("MAV_RESULT", m.result)
        if m.get_type() == "STATUSTEXT" and "ESC calibration stopped" in m.text:
            seen["text"] = m.text
        return len(seen) == 2

    gcs.pump(refused_and_stopped, 3.0, "arm while running")
    if seen["ack"] == "MAV_RESULT_ACCEPTED":
        raise Failed("arm while running", "arming was accepted during the ESC calibration")
    gcs.results["arm_stopped"] = seen

    start(gcs, "start")
    done = wait_text(gcs, "ESC calibration successful", 60.0, "calibrated")
    gcs.results["success"] = done.text
    gcs.quiet(1.0)
    gcs.results["params"] = servo_params(gcs)


def body(gcs):
    gcs.identify()
    gcs.pump(lambda m: gcs.home is not None, 20.0, "home")
    gcs.quiet(2.0)
    scenario = os.environ.get("ESC_SCENARIO", "calibrate")
    if scenario == "calibrate":
        calibrate(gcs)
    else:
        gcs.results["no_telemetry_refusal"] = refused(gcs, ESC_CAL, "refused", "no ESC telemetry")


if __name__ == "__main__":
    main(body, deadline_s=120.0)
