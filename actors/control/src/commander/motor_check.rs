//! The commander's motor check: the latest motor commands paired with the ESC telemetry that
//! follows them, fed to the [`MotorFailureDetector`] (PX4's FailureDetector runs in its
//! commander on `actuator_motors` and `esc_status` the same way).
//!
//! Commands are taken only while armed and recent (a command older than
//! [`COMMAND_STALE_S`] no longer says what the motors should do); the detector's time step is
//! the telemetry's own stamps. Without telemetry (Navio2 PWM) nothing is ever judged.

use kestrel_proto::Time;
use kestrel_proto::messages::{ActuatorOutputs, EscTelemetry};

use crate::motor_failure::{MAX_MOTORS, MotorFailureDetector, MotorFailureError, MotorFailureParams};

/// Commands older than this at a telemetry sample are not compared with it (s): ten loop
/// periods at 400 Hz, well inside `FD_ACT_MOT_TOUT`.
pub const COMMAND_STALE_S: f64 = 0.025;

/// Fewest motors that can hold roll, pitch, yaw and thrust: one per axis.
const MOTORS_FOR_FOUR_AXES: u8 = 4;

/// What the check knows.
#[derive(Clone, Debug)]
pub struct MotorCheck {
    detector: MotorFailureDetector,
    commands: Option<ActuatorOutputs>,
    last_telemetry: Option<Time>,
    /// Motors the telemetry reports (the frame's).
    motor_count: Option<u8>,
    /// Telemetry samples refused (non-finite, a count that does not fit), for the logs.
    pub refused: u64,
}

impl MotorCheck {
    pub fn new(params: MotorFailureParams) -> Result<MotorCheck, MotorFailureError> {
        Ok(MotorCheck {
            detector: MotorFailureDetector::new(params)?,
            commands: None,
            last_telemetry: None,
            motor_count: None,
            refused: 0,
        })
    }

    /// New parameters (validated with the commander's); timers and a failure are kept.
    pub fn set_params(&mut self, params: MotorFailureParams) -> Result<(), MotorFailureError> {
        self.detector.set_params(params)
    }

    /// A new flight: nothing has failed yet.
    pub fn reset(&mut self) {
        self.detector.reset();
        self.last_telemetry = None;
    }

    pub fn on_actuators(&mut self, outputs: &ActuatorOutputs) {
        self.commands = Some(outputs.clone());
    }

    /// Judges one telemetry sample; returns the motor (0-based) declared failed by it, only
    /// on the sample that declared it.
    pub fn on_telemetry(&mut self, esc: &EscTelemetry) -> Option<usize> {
        let before = self.detector.failed();
        let n = usize::from(esc.count);
        let last = self.last_telemetry.replace(esc.time);
        let command = self
            .commands
            .as_ref()
            .filter(|c| c.armed && esc.time.saturating_since(c.time).as_secs_f64() <= COMMAND_STALE_S);
        let (Some(last), Some(command)) = (last, command) else { return None };
        if n > MAX_MOTORS {
            self.refused += 1;
            tracing::warn!(count = n, "ESC telemetry: more motors than the detector tracks; refused");
            return None;
        }
        let mut commands = [0.0_f32; MAX_MOTORS];
        let mut produced = [0.0_f32; MAX_MOTORS];
        for i in 0..n {
            commands[i] = command.motors[i] as f32;
            produced[i] = esc.thrust[i] as f32;
        }
        let dt = esc.time.saturating_since(last).as_secs_f32();
        if dt <= 0.0 {
            return None;
        }
        match self.detector.update(&commands[..n], &produced[..n], dt) {
            Ok(failed) => {
                self.motor_count = Some(esc.count);
                failed.filter(|_| before.is_none())
            }
            Err(e) => {
                self.refused += 1;
                tracing::warn!(error = %e, "ESC telemetry refused by the motor-failure detector");
                None
            }
        }
    }

    /// The motor declared failed this flight (0-based), if any.
    pub fn failed(&self) -> Option<usize> {
        self.detector.failed()
    }

    /// Whether the motors left after the failure can still hold every axis (four or more:
    /// a hexa or an octo), so the flight may go on; false with no failure.
    pub fn others_hold_all_axes(&self) -> bool {
        self.failed().is_some() && self.motor_count.is_some_and(|n| n > MOTORS_FOR_FOUR_AXES)
    }
}
