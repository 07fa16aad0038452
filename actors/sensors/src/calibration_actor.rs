//! The calibration actor: owns the one calibration session of the vehicle (the pure
//! [`Session`]) and feeds it from its mailboxes. Inputs: `command` ([`CalibrationCommand`], from
//! the link), `imu_raw` and `mag_raw` (raw board-frame samples from the sensor source, which
//! sends them only while a [`CalibrationMotion`] other than idle is asked for), `vehicle_status`
//! (no calibration while armed), `param_decl` (the calibration values the sensor path's owner
//! flies with). Outputs: `event` ([`CalibrationEvent`], to the link), `motion`
//! ([`CalibrationMotion`], to the sensor source) and `status` ([`CalibrationStatus`], to the
//! commander's pre-arm check, published when it changes and every second). For the ESC range
//! calibration also `esc_telemetry` (the motors' speeds, its feedback) and `vehicle_command` (an
//! arm request stops it), `battery` (where PWM ESCs report nothing, PX4's max-then-min waits
//! for the battery to be connected), and the output `esc_pulses` ([`EscPulses`], to whatever
//! drives the motors: repeated every 20 ms while a calibration drives them, released when it
//! ends). The `tick` timer runs at 50 Hz so the pulses repeat even when nothing else arrives.
//!
//! It also runs MAV_CMD_DO_MOTOR_TEST ([`MotorTest`]) on the same pulses: started by the
//! commander's acceptance on `command_result` ([`CommandResult`]), spinning the outputs the
//! motor owner declares on `param_decl` (`SERVOn_MIN/MAX`), stopped by any other command on
//! `vehicle_command` (whose heartbeats keep it going), a calibration request, or arming.
//!
//! It lives apart from the sensor drivers so the simulator and the hardware share one session,
//! and apart from the link so MAVLink stays a transport of requests and results.

use std::time::Duration;

use kestrel_proto::calibration::{CALIBRATION_PARAMS, CalibrationParams};
use kestrel_proto::messages::{
    BatteryStatus, CalibrationCommand, CalibrationEvent, CalibrationMotion, CalibrationStatus,
    CalibrationStep, CalibrationUpdate, Command, CommandResult, EscPulses, EscTelemetry, ImuSample,
    MAX_MOTORS, MagSample, ParamDecl, Severity, VehicleCommand, VehicleStatus,
};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::calibration::{Session, SessionSettings};
use crate::motor_test::MotorTest;

/// `[actors.calibration.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CalibrationActorParams {
    /// Strength of the Earth's field where the vehicle flies (gauss), the compass fit's
    /// reference (the World Magnetic Model's total intensity at home; the simulator's world
    /// file). 0.05..=1.
    pub expected_field_gauss: f64,
    /// Steps without whose result arming is refused (ArduPilot's pre-arm "3D Accel calibration
    /// needed", "Compass not calibrated"): any of "gyro", "accel", "level", "compass".
    pub required: Vec<CalibrationStep>,
}

impl Default for CalibrationActorParams {
    fn default() -> CalibrationActorParams {
        CalibrationActorParams { expected_field_gauss: 0.5, required: Vec::new() }
    }
}

#[derive(Debug)]
pub enum CalibrationInput {
    Command(CalibrationCommand),
    Imu(ImuSample),
    Mag(MagSample),
    Status(Box<VehicleStatus>),
    Decl(ParamDecl),
    Esc(EscTelemetry),
    VehicleCommand(VehicleCommand),
    CommandResult(CommandResult),
    Battery(BatteryStatus),
    Tick(Time),
}

/// Direct pulses are repeated this often while the ramp holds one (well inside the consumers'
/// `DIRECT_PULSE_TIMEOUT`).
const PULSE_REPEAT: Duration = Duration::from_millis(20);

pub struct CalibrationActor {
    session: Session,
    motor_test: MotorTest,
    required: Vec<CalibrationStep>,
    event: Publisher<CalibrationEvent>,
    motion: Publisher<CalibrationMotion>,
    status: Publisher<CalibrationStatus>,
    esc_pulses: Publisher<EscPulses>,
    /// The pulses last sent and when; `None` once released.
    last_pulses: Option<(Time, [f64; MAX_MOTORS])>,
    last_motion: Option<kestrel_proto::messages::Motion>,
    last_status: Option<CalibrationStatus>,
    last_status_time: Time,
}

impl CalibrationActor {
    fn text(&self, now: Time, severity: Severity, text: String) {
        self.event
            .publish(CalibrationEvent { time: now, update: CalibrationUpdate::Text { severity, text } });
    }

    /// Stops a motor test under way, saying why.
    fn stop_motor_test(&mut self, now: Time, why: &str) {
        if self.motor_test.stop() {
            self.text(now, Severity::Info, format!("finished motor test: {why}"));
        }
    }

    fn publish(&mut self, now: Time) {
        for update in self.session.take_updates() {
            self.event.publish(CalibrationEvent { time: now, update });
        }
        let motion = self.session.motion();
        if self.last_motion != Some(motion) {
            self.motion.publish(CalibrationMotion { time: now, motion });
            self.last_motion = Some(motion);
        }
        if let Some(why) = self.motor_test.update(now) {
            self.text(now, Severity::Info, format!("finished motor test: {why}"));
        }
        let pulses = self.session.esc_pulses_us().or_else(|| self.motor_test.pulses_us(now));
        match (pulses, self.last_pulses) {
            (Some(pulses_us), last)
                if last.is_none_or(|(at, p)| p != pulses_us || now.saturating_since(at) >= PULSE_REPEAT) =>
            {
                self.esc_pulses.publish(EscPulses { time: now, control: true, pulses_us });
                self.last_pulses = Some((now, pulses_us));
            }
            (None, Some(_)) => {
                self.esc_pulses.publish(EscPulses {
                    time: now,
                    control: false,
                    pulses_us: [0.0; MAX_MOTORS],
                });
                self.last_pulses = None;
            }
            _ => {}
        }
        let status = CalibrationStatus {
            time: now,
            missing: self.session.missing(&self.required),
            running: self.session.running(),
        };
        let changed = self
            .last_status
            .as_ref()
            .is_none_or(|s| s.missing != status.missing || s.running != status.running);
        if changed || now.saturating_since(self.last_status_time) >= Duration::from_secs(1) {
            self.last_status_time = now;
            self.last_status = Some(status.clone());
            self.status.publish(status);
        }
    }
}

impl Actor for CalibrationActor {
    type Params = CalibrationActorParams;
    type Input = CalibrationInput;

    fn build(
        params: &CalibrationActorParams,
        setup: &mut impl Setup<CalibrationInput>,
    ) -> Result<Self, ActorError> {
        let field = params.expected_field_gauss;
        if !(field.is_finite() && (0.05..=1.0).contains(&field)) {
            return Err(ActorError::Params(format!("expected_field_gauss = {field} is outside 0.05..=1 G")));
        }
        if params.required.contains(&CalibrationStep::Esc) {
            return Err(ActorError::Params(
                "required: \"esc\" cannot be required (its result is the motor outputs' SERVOn_MIN/MAX)"
                    .into(),
            ));
        }
        setup.input("command", CalibrationInput::Command);
        setup.input("imu_raw", CalibrationInput::Imu);
        setup.input("mag_raw", CalibrationInput::Mag);
        setup.input("vehicle_status", |s| CalibrationInput::Status(Box::new(s)));
        setup.input("param_decl", CalibrationInput::Decl);
        setup.input("esc_telemetry", CalibrationInput::Esc);
        setup.input("vehicle_command", CalibrationInput::VehicleCommand);
        setup.input("command_result", CalibrationInput::CommandResult);
        setup.input("battery", CalibrationInput::Battery);
        setup.timer("tick", PULSE_REPEAT, CalibrationInput::Tick);
        Ok(CalibrationActor {
            session: Session::new(SessionSettings::new(field)),
            motor_test: MotorTest::default(),
            required: params.required.clone(),
            event: setup.output("event"),
            motion: setup.output("motion"),
            status: setup.output("status"),
            esc_pulses: setup.output("esc_pulses"),
            last_pulses: None,
            last_motion: None,
            last_status: None,
            last_status_time: Time::ZERO,
        })
    }

    async fn handle(&mut self, _ctx: &Context, input: CalibrationInput) -> Result<(), ActorError> {
        let now = match input {
            CalibrationInput::Command(c) => {
                self.stop_motor_test(c.time, "calibration requested");
                self.session.on_request(c.id, c.request, c.time);
                c.time
            }
            CalibrationInput::Imu(s) => {
                self.session.on_imu(&s);
                s.time
            }
            CalibrationInput::Mag(s) => {
                self.session.on_mag(&s);
                s.time
            }
            CalibrationInput::Status(s) => {
                if s.armed {
                    self.stop_motor_test(s.time, "armed");
                }
                self.session.set_vehicle(s.armed, s.landed);
                s.time
            }
            CalibrationInput::Decl(d) => {
                // The owner of the sensor path declares the calibration parameters it flies with.
                self.motor_test.on_decl(&d);
                if d.params.iter().any(|p| p.name == CALIBRATION_PARAMS[0].name) {
                    let current =
                        d.params.iter().fold(CalibrationParams::default(), |c, p| c.with(&p.name, p.value));
                    self.session.set_current(current);
                }
                d.time
            }
            CalibrationInput::Esc(t) => {
                self.session.on_esc(&t);
                t.time
            }
            CalibrationInput::VehicleCommand(c) => {
                if c.command == Command::Arm {
                    self.session.on_arm_request();
                }
                match c.command {
                    Command::Heartbeat { .. } => self.motor_test.on_heartbeat(c.time),
                    // A new test replaces this one once the commander takes it.
                    Command::MotorTest { .. } => {}
                    _ => self.stop_motor_test(c.time, "another command"),
                }
                c.time
            }
            CalibrationInput::CommandResult(r) => {
                if let (Command::MotorTest { first, count, throttle, duration_s }, None) =
                    (r.command, &r.refusal)
                {
                    match self.motor_test.start(first, count, throttle, duration_s, r.time) {
                        Ok(()) => self.text(r.time, Severity::Info, "starting motor test".into()),
                        Err(e) => self.text(r.time, Severity::Critical, e.to_string()),
                    }
                }
                r.time
            }
            CalibrationInput::Battery(b) => {
                self.session.on_battery(b.voltage_v);
                b.time
            }
            CalibrationInput::Tick(t) => {
                self.session.on_tick(t);
                t
            }
        };
        self.publish(now);
        Ok(())
    }
}
