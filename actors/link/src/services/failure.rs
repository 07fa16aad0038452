//! MAV_CMD_INJECT_FAILURE (PX4's failure injection, MAVSDK's Failure plugin): param1 the
//! `FAILURE_UNIT`, param2 the `FAILURE_TYPE`, param3 the instance (0 all, else 1-based).
//!
//! The link checks the numbers and passes the request to the injector (the simulator), whose
//! answer is the COMMAND_ACK: ACCEPTED, DENIED while `SYS_FAILURE_EN` is 0 (as PX4, failure
//! injection is off until a ground station switches it on), UNSUPPORTED for what it cannot
//! break. In a graph without an injector — nobody declares `SYS_FAILURE_EN`, as on hardware —
//! the command is UNSUPPORTED at once.

use kestrel_proto::messages::{
    FAILURE_INJECTION_ENABLE, FailureInjectionResult, FailureType, FailureUnit, InjectionOutcome,
};
use mavlink::dialects::ardupilotmega::{MavMessage, MavResult, MavSeverity};

use super::command::{CommandRequest, whole};
use super::events::statustext;

/// The unit, type and instance of a request; or its ACK and the reason.
pub fn request(
    request: &CommandRequest,
    injector: bool,
) -> Result<(FailureUnit, FailureType, u8), (MavResult, String)> {
    if !injector {
        return Err((
            MavResult::MAV_RESULT_UNSUPPORTED,
            format!(
                "Failure injection: nothing in this graph injects failures (no {FAILURE_INJECTION_ENABLE})"
            ),
        ));
    }
    let p = request.params;
    let denied =
        |what: &str, v: f64| (MavResult::MAV_RESULT_DENIED, format!("Failure injection: {what} {v} unknown"));
    let unit =
        whole(p[0], u32::MAX).and_then(FailureUnit::from_mavlink).ok_or_else(|| denied("unit", p[0]))?;
    let failure =
        whole(p[1], u32::MAX).and_then(FailureType::from_mavlink).ok_or_else(|| denied("type", p[1]))?;
    let instance = whole(p[2], u8::MAX.into())
        .and_then(|i| u8::try_from(i).ok())
        .ok_or_else(|| denied("instance", p[2]))?;
    Ok((unit, failure, instance))
}

/// The ACK result of an injector's answer, and the STATUSTEXT that tells the ground station
/// what happened (the accepted failure, or why not).
pub fn answer(result: &FailureInjectionResult) -> (MavResult, MavMessage) {
    match &result.outcome {
        InjectionOutcome::Accepted(what) => (
            MavResult::MAV_RESULT_ACCEPTED,
            statustext(MavSeverity::MAV_SEVERITY_WARNING, &format!("Failure injected: {what}")),
        ),
        InjectionOutcome::Denied(why) => (
            MavResult::MAV_RESULT_DENIED,
            statustext(MavSeverity::MAV_SEVERITY_WARNING, &format!("Failure injection denied: {why}")),
        ),
        InjectionOutcome::Unsupported(why) => (
            MavResult::MAV_RESULT_UNSUPPORTED,
            statustext(MavSeverity::MAV_SEVERITY_WARNING, &format!("Failure injection unsupported: {why}")),
        ),
    }
}

#[cfg(test)]
mod tests {
    use mavlink::dialects::ardupilotmega::MavCmd;

    use super::*;
    use crate::services::Sender;

    fn req(p0: f64, p1: f64, p2: f64) -> CommandRequest {
        CommandRequest {
            command: MavCmd::MAV_CMD_INJECT_FAILURE,
            params: [p0, p1, p2, 0.0, 0.0, 0.0, 0.0],
            frame: None,
            sender: Sender { system_id: 255, component_id: 190 },
        }
    }

    #[test]
    fn mavsdk_s_gps_off_reads_as_the_gps_unit_off_on_every_instance() {
        assert_eq!(request(&req(4.0, 1.0, 0.0), true), Ok((FailureUnit::SensorGps, FailureType::Off, 0)));
        assert_eq!(request(&req(101.0, 0.0, 3.0), true), Ok((FailureUnit::SystemMotor, FailureType::Ok, 3)));
    }

    #[test]
    fn without_an_injector_every_request_is_unsupported() {
        let (result, reason) = request(&req(4.0, 1.0, 0.0), false).unwrap_err();
        assert_eq!(result, MavResult::MAV_RESULT_UNSUPPORTED);
        assert!(reason.contains(FAILURE_INJECTION_ENABLE), "{reason}");
    }

    #[test]
    fn numbers_that_name_no_unit_type_or_instance_are_denied_and_named() {
        for (p, what) in [
            ((9.0, 1.0, 0.0), "unit"),
            ((f64::NAN, 1.0, 0.0), "unit"),
            ((4.0, 8.0, 0.0), "type"),
            ((4.0, 1.5, 0.0), "type"),
            ((4.0, 1.0, -1.0), "instance"),
            ((4.0, 1.0, 256.0), "instance"),
            ((4.0, 1.0, f64::INFINITY), "instance"),
        ] {
            let (result, reason) = request(&req(p.0, p.1, p.2), true).unwrap_err();
            assert_eq!(result, MavResult::MAV_RESULT_DENIED, "{p:?}");
            assert!(reason.contains(what), "{p:?}: {reason}");
        }
    }
}
