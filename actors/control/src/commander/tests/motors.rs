//! The motor check: a stopped motor declared, flown on or landed, and bad telemetry ignored.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    ActuatorOutputs, Command, EscTelemetry, FailsafeAction, FailsafeCause, FlightMode,
};

use super::fixtures::{at, cmd, full_battery, hovering, nav};
use crate::commander::Commander;

/// The loop's commands and the ESCs' answer every 2.5 ms from `from_us` for `seconds`, each
/// motor commanded 0.5 and producing it, except `lost` producing `lost_thrust`; returns the
/// time reached.
fn motors_run(
    c: &mut Commander,
    from_us: u64,
    seconds: f64,
    count: u8,
    lost: usize,
    lost_thrust: f64,
) -> u64 {
    let mut t = from_us;
    while t < from_us + (seconds * 1e6) as u64 {
        t += 2500;
        let mut motors = [0.0; kestrel_proto::messages::MAX_MOTORS];
        motors[..usize::from(count)].fill(0.5);
        c.on_actuators(&ActuatorOutputs { time: Time(t), armed: true, motors });
        let mut thrust = motors;
        thrust[lost] = lost_thrust;
        c.on_esc_telemetry(&EscTelemetry { time: Time(t), count, thrust, speed_rad_s: [0.0; 8] });
        c.on_nav(&nav(Time(t), -5.0, true));
        c.update(Time(t));
    }
    t
}

#[test]
fn a_quad_motor_that_stops_is_declared_after_fd_act_mot_tout_and_lands() {
    let mut c = hovering();
    let t = motors_run(&mut c, 2000, 1.0, 4, 1, 0.5);
    assert_eq!(c.failed_motor(), None, "healthy telemetry");
    // Motor 2 produces nothing: declared once the shortfall has lasted FD_ACT_MOT_TOUT (0.1 s).
    let t = motors_run(&mut c, t, 0.095, 4, 1, 0.0);
    assert_eq!(c.failed_motor(), None, "declared before FD_ACT_MOT_TOUT");
    let t = motors_run(&mut c, t, 0.01, 4, 1, 0.0);
    assert_eq!(c.failed_motor(), Some(1));
    let sp = c.update(Time(t));
    assert_eq!(sp.failed_motor, Some(1), "the loop is told to allocate around it");
    let status = c.status(Time(t));
    assert_eq!(status.failed_motor, Some(1));
    assert_eq!(status.last_refusal.as_deref(), Some("Motor 2 failure: cannot hold yaw"));
    let f = status.failsafe.expect("a failsafe");
    assert_eq!((f.cause, f.action), (FailsafeCause::MotorFailure, FailsafeAction::Land));
    assert_eq!(c.mode(), FlightMode::Land);
    // Latched: the motor coming back does not undo the landing.
    let t = motors_run(&mut c, t, 0.5, 4, 1, 0.5);
    assert_eq!(c.failed_motor(), Some(1));
    assert_eq!(c.status(Time(t)).failsafe.map(|f| f.cause), Some(FailsafeCause::MotorFailure));
}

#[test]
fn a_hexa_motor_that_stops_is_reported_and_the_flight_goes_on() {
    let mut c = hovering();
    let t = motors_run(&mut c, 2000, 0.5, 6, 0, 0.0);
    assert_eq!(c.failed_motor(), Some(0));
    let status = c.status(Time(t));
    assert_eq!(status.failed_motor, Some(0));
    assert_eq!(status.last_refusal.as_deref(), Some("Motor 1 failure: flying on the others"));
    assert_eq!(status.failsafe, None, "five motors hold every axis: no failsafe");
    assert_eq!(c.mode(), FlightMode::PosHold);
    assert_eq!(c.update(Time(t)).failed_motor, Some(0));
}

#[test]
fn bad_or_stale_telemetry_is_never_judged_and_a_new_flight_starts_healthy() {
    let mut c = hovering();
    // NaN thrust is refused, not taken for a stopped motor.
    let t = motors_run(&mut c, 2000, 0.5, 4, 2, f64::NAN);
    assert_eq!(c.failed_motor(), None);
    // Telemetry with commands older than COMMAND_STALE_S: nothing to compare it with.
    let mut t = t;
    let stale = ActuatorOutputs { time: Time(t), armed: true, motors: [0.5; 8] };
    c.on_actuators(&stale);
    for _ in 0..200 {
        t += 2500;
        c.on_esc_telemetry(&EscTelemetry {
            time: Time(t + 30_000),
            count: 4,
            thrust: [0.0; 8],
            speed_rad_s: [0.0; 8],
        });
    }
    assert_eq!(c.failed_motor(), None);
    // A failure, then a landing and a new arming: the detector starts afresh.
    let t = motors_run(&mut c, t + 30_000, 0.5, 4, 3, 0.0);
    assert_eq!(c.failed_motor(), Some(3));
    cmd(&mut c, Command::Disarm { force: true }).expect("disarm");
    c.on_nav(&nav(Time(t), 0.0, true));
    c.on_battery(&full_battery(Time(t)));
    c.update(Time(t));
    at(&mut c, t, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    at(&mut c, t, Command::Arm).expect("arm");
    assert_eq!(c.failed_motor(), None);
}
