//! One calibration at a time, as the ground station drives it: the pure state machine
//! between the link's requests, the raw board-frame samples of the sensor source and the fits of
//! this module's siblings. It says how the vehicle must be handled ([`Motion`]), what to tell the
//! operator (the STATUSTEXT, MAG_CAL_* and ACCELCAL_VEHICLE_POS lines ArduPilot sends, so
//! MAVProxy's `accelcal`, `magcal` and `calibrate level` read them), and hands a good result back
//! as parameters; a refused fit changes nothing. The shell in `calibration_actor.rs` does the I/O.
//!
//! The ESC range calibration drives the motors, so it is held to more: it starts only disarmed,
//! landed and with ESC telemetry flowing (the speed is its feedback), tells the operator to take
//! the propellers off (PX4's "remove propellers"), and stops — pulses released to the disarmed
//! pulse — on cancel, an arm request, a timeout, or telemetry that goes quiet. PWM ESCs that
//! report no speed get PX4's procedure instead (`esc_calibration.cpp`): started only with the
//! battery disconnected (≤ 3 V), the maximum pulse until the battery is connected (within 20 s),
//! held 5 s more while the ESCs learn it, then released to the disarmed pulse, their minimum.
//! That part of the session is in `esc.rs`.

mod esc;

use kestrel_proto::Time;
use kestrel_proto::calibration::{CalibrationParams, SensorCalibration};
use kestrel_proto::messages::{
    ACCELCAL_FAILED, ACCELCAL_SUCCESS, CalibrationRequest, CalibrationStep, CalibrationUpdate, ImuSample,
    LandedState, MagCalState, MagReport, MagSample, Motion, Severity,
};
use std::time::Duration;

use nalgebra::Vector3;

use super::coverage::{Coverage, REGIONS};
use super::{
    AccelSettings, EscRamp, EscSample, EscSettings, GyroSettings, LevelSettings, MagFit, MagSettings,
    OrientationSamples, VehicleOrientation, calibrate_accel, calibrate_gyro, calibrate_level, calibrate_mag,
};
use esc::EscFeedback;

/// How a session samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SessionSettings {
    pub mag: MagSettings,
    pub accel: AccelSettings,
    pub gyro: GyroSettings,
    pub level: LevelSettings,
    /// IMU samples per still capture (gyro, level, each accelerometer orientation).
    pub still_samples: usize,
    /// Samples are dropped this long after the vehicle was (re)placed (s).
    pub settle_s: f64,
    /// Compass samples after which a fully covered sphere is fitted.
    pub mag_samples: usize,
    /// Compass collection ends (and is fitted, or refused) after this long (s).
    pub mag_timeout_s: f64,
    /// A session waiting this long for the ground station fails (s).
    pub idle_timeout_s: f64,
    /// MAG_CAL_PROGRESS period (s).
    pub progress_period_s: f64,
    pub esc: EscSettings,
    pub esc_ramp: EscRamp,
    /// ESC telemetry older than this stops (or refuses) the ESC calibration (s).
    pub esc_telemetry_timeout_s: f64,
    /// The ESC calibration fails this long after its ramp should have ended (s).
    pub esc_margin_s: f64,
    /// Without speed feedback (PWM ESCs, PX4's procedure): the pulse the ESCs learn as full
    /// (µs), how long to wait for the battery and to hold that pulse after it (s), and the
    /// voltage above which the battery counts as connected (V).
    pub esc_max_us: f64,
    pub esc_battery_wait_s: f64,
    pub esc_max_hold_s: f64,
    pub esc_battery_connected_v: f64,
}

impl SessionSettings {
    /// Defaults around the expected field strength (gauss).
    pub fn new(expected_field_gauss: f64) -> SessionSettings {
        SessionSettings {
            mag: MagSettings::new(expected_field_gauss),
            accel: AccelSettings::default(),
            gyro: GyroSettings::default(),
            level: LevelSettings::default(),
            still_samples: 400,
            settle_s: 0.5,
            mag_samples: 1500,
            mag_timeout_s: 40.0,
            idle_timeout_s: 120.0,
            progress_period_s: 0.5,
            esc: EscSettings {
                // The simulator's ESCs hold a speed of √throttle (thrust linear in command), so
                // speed flattens near full: 98 % of top speed is 4 % of the range short of full,
                // 99.8 % is 0.4 %. A measured speed is steady here (no load, no noise in the
                // simulator); a noisy ESC's telemetry would need the 98 % default.
                full_fraction: 0.998,
                ..EscSettings::default()
            },
            esc_ramp: EscRamp::default(),
            esc_telemetry_timeout_s: 0.3,
            esc_margin_s: 10.0,
            esc_max_us: 2000.0,
            esc_battery_wait_s: 20.0,
            esc_max_hold_s: 5.0,
            esc_battery_connected_v: 3.0,
        }
    }
}

#[derive(Debug)]
enum State {
    Idle,
    /// Gyro or level: one still capture.
    Still {
        step: CalibrationStep,
        samples: Vec<ImuSample>,
    },
    /// Six orientations; `next` indexes [`VehicleOrientation::ALL`]; `placed` once the ground
    /// station said the vehicle stands there.
    Accel {
        next: usize,
        placed: bool,
        samples: Vec<ImuSample>,
        captures: Vec<Vec<ImuSample>>,
    },
    Mag {
        autosave: bool,
        start_at: Time,
        samples: Vec<MagSample>,
        ends_at: Time,
    },
    /// A good compass fit waiting for DO_ACCEPT_MAG_CAL.
    MagDone {
        params: Vec<(String, f64)>,
    },
    /// The ESC ramp at `step`, held since `since`; `ramps[i]` the samples of output `i`.
    Esc {
        step: usize,
        since: Time,
        ramps: Vec<Vec<EscSample>>,
    },
    /// PWM ESCs without feedback: the maximum pulse since `since`, the battery connected at
    /// `connected` (then held [`SessionSettings::esc_max_hold_s`]).
    EscMaxMin {
        since: Time,
        connected: Option<Time>,
    },
}

/// The calibration session.
#[derive(Debug)]
pub struct Session {
    settings: SessionSettings,
    state: State,
    /// The values the sensor path uses now (from its owner's declaration).
    current: CalibrationParams,
    armed: bool,
    landed: bool,
    esc_feedback: Option<EscFeedback>,
    /// The newest battery voltage (V), if a battery monitor reports one.
    battery_v: Option<f64>,
    motion: Motion,
    /// No raw sample counts before this (the vehicle is still settling).
    settle_until: Option<Time>,
    /// The session fails at this time unless something happens first.
    deadline: Time,
    next_progress: Time,
    out: Vec<CalibrationUpdate>,
}

impl Session {
    pub fn new(settings: SessionSettings) -> Session {
        Session {
            settings,
            state: State::Idle,
            current: CalibrationParams::default(),
            armed: false,
            landed: true,
            esc_feedback: None,
            battery_v: None,
            motion: Motion::Idle,
            settle_until: None,
            deadline: Time::ZERO,
            next_progress: Time::ZERO,
            out: Vec::new(),
        }
    }

    /// How the vehicle must be handled now.
    pub fn motion(&self) -> Motion {
        self.motion
    }

    /// The step running, if any.
    pub fn running(&self) -> Option<CalibrationStep> {
        match &self.state {
            State::Idle => None,
            State::Still { step, .. } => Some(*step),
            State::Accel { .. } => Some(CalibrationStep::Accel),
            State::Mag { .. } | State::MagDone { .. } => Some(CalibrationStep::Mag),
            State::Esc { .. } | State::EscMaxMin { .. } => Some(CalibrationStep::Esc),
        }
    }

    /// The battery monitor's voltage (V): PWM ESCs are calibrated by connecting it.
    pub fn on_battery(&mut self, voltage_v: f64) {
        self.battery_v = Some(voltage_v);
    }

    /// The calibration values in use, as their owner declared them.
    pub fn set_current(&mut self, current: CalibrationParams) {
        self.current = current;
    }

    pub fn current(&self) -> &CalibrationParams {
        &self.current
    }

    /// Whether the vehicle is armed (no calibration starts then; an ESC calibration stops) and
    /// on the ground (an ESC calibration starts only there).
    pub fn set_vehicle(&mut self, armed: bool, landed: LandedState) {
        self.armed = armed;
        self.landed = landed == LandedState::OnGround;
        if armed {
            self.stop_esc("vehicle armed");
        }
    }

    /// Someone asked to arm: an ESC calibration stops at once (the commander refuses the arming
    /// while any calibration runs).
    pub fn on_arm_request(&mut self) {
        self.stop_esc("arming requested");
    }

    /// Steps of `required` without a result in the values in use.
    pub fn missing(&self, required: &[CalibrationStep]) -> Vec<CalibrationStep> {
        required.iter().copied().filter(|&s| !calibrated(&self.current, s)).collect()
    }

    /// What to send since the last call.
    pub fn take_updates(&mut self) -> Vec<CalibrationUpdate> {
        std::mem::take(&mut self.out)
    }

    fn text(&mut self, severity: Severity, text: impl Into<String>) {
        self.out.push(CalibrationUpdate::Text { severity, text: text.into() });
    }

    fn set_motion(&mut self, motion: Motion) {
        self.motion = motion;
        self.settle_until = None;
    }

    fn finish(&mut self) {
        self.state = State::Idle;
        self.set_motion(Motion::Idle);
    }

    /// Request `id` at `now`; answered (taken or refused with a reason) in the updates.
    pub fn on_request(&mut self, id: u32, request: CalibrationRequest, now: Time) {
        let refusal = self.request(request, now).err();
        if let Some(reason) = &refusal {
            self.text(Severity::Warning, reason.clone());
        }
        // The answer goes first: it is the COMMAND_ACK of what the other updates report.
        self.out.insert(0, CalibrationUpdate::Answer { id, refusal });
    }

    fn request(&mut self, request: CalibrationRequest, now: Time) -> Result<(), String> {
        let timeout = |s: &Session| now + Duration::from_secs_f64(s.settings.idle_timeout_s);
        match request {
            CalibrationRequest::Start { step, autosave, delay_s } => {
                if self.armed {
                    return Err(format!("{} calibration refused: vehicle armed", step.name()));
                }
                if let Some(running) = self.running() {
                    return Err(format!(
                        "{} calibration refused: {} calibration running",
                        step.name(),
                        running.name()
                    ));
                }
                if !(delay_s.is_finite() && (0.0..=60.0).contains(&delay_s)) {
                    return Err(format!("{} calibration refused: delay {delay_s} s", step.name()));
                }
                self.deadline = timeout(self);
                match step {
                    CalibrationStep::Gyro | CalibrationStep::Level => {
                        self.state =
                            State::Still { step, samples: Vec::with_capacity(self.settings.still_samples) };
                        self.set_motion(Motion::Level);
                        self.text(
                            Severity::Info,
                            format!("Calibrating {}: hold it still and level", step.name()),
                        );
                    }
                    CalibrationStep::Accel => {
                        self.state = State::Accel {
                            next: 0,
                            placed: false,
                            samples: Vec::new(),
                            captures: Vec::new(),
                        };
                        self.set_motion(Motion::Level);
                        self.ask_position(0);
                    }
                    CalibrationStep::Esc => return self.start_esc(now),
                    CalibrationStep::Mag => {
                        let start_at = now + Duration::from_secs_f64(delay_s);
                        let ends_at = start_at + Duration::from_secs_f64(self.settings.mag_timeout_s);
                        self.state = State::Mag { autosave, start_at, samples: Vec::new(), ends_at };
                        self.set_motion(Motion::Tumble);
                        self.next_progress = now;
                        self.text(Severity::Info, "Compass calibration: turn the vehicle every way");
                    }
                }
                Ok(())
            }
            CalibrationRequest::AccelPosition { position } => {
                let State::Accel { next, placed, .. } = &mut self.state else {
                    return Err("accelerometer calibration is not running".to_owned());
                };
                let expected = VehicleOrientation::ALL[*next];
                if *placed {
                    return Err(format!("already sampling the vehicle {expected}"));
                }
                if position != expected.accelcal_vehicle_pos() {
                    return Err(format!(
                        "position {position} is not the one asked for ({}, {expected})",
                        expected.accelcal_vehicle_pos()
                    ));
                }
                *placed = true;
                self.deadline = timeout(self);
                self.set_motion(Motion::Place { position });
                Ok(())
            }
            CalibrationRequest::MagAccept => {
                let State::MagDone { params } = &mut self.state else {
                    return Err("no compass calibration to accept".to_owned());
                };
                let params = std::mem::take(params);
                self.out.push(CalibrationUpdate::Results { params });
                self.text(Severity::Info, "Compass calibration accepted and saved");
                self.finish();
                Ok(())
            }
            CalibrationRequest::MagCancel => {
                if self.running() == Some(CalibrationStep::Mag) {
                    self.text(Severity::Info, "Compass calibration cancelled");
                    self.finish();
                }
                Ok(())
            }
            CalibrationRequest::Cancel => {
                match self.running() {
                    Some(step) => {
                        if matches!(self.state, State::Accel { .. }) {
                            self.out.push(CalibrationUpdate::AccelPosition { position: ACCELCAL_FAILED });
                        }
                        self.text(Severity::Info, format!("{} calibration cancelled", step.name()));
                        self.finish();
                    }
                    None => self.text(Severity::Info, "No calibration running"),
                }
                Ok(())
            }
        }
    }

    fn ask_position(&mut self, next: usize) {
        let orientation = VehicleOrientation::ALL[next];
        self.text(Severity::Info, format!("Place vehicle {orientation} and press any key."));
        self.out.push(CalibrationUpdate::AccelPosition { position: orientation.accelcal_vehicle_pos() });
    }

    /// Whether a raw sample stamped `time` counts (the vehicle has settled).
    fn settled(&mut self, time: Time) -> bool {
        let settle = Duration::from_secs_f64(self.settings.settle_s);
        let until = *self.settle_until.get_or_insert(time + settle);
        time >= until
    }

    /// A raw board-frame IMU sample.
    pub fn on_imu(&mut self, sample: &ImuSample) {
        let wanted = self.settings.still_samples;
        let collecting = match &self.state {
            State::Still { .. } => true,
            State::Accel { placed, .. } => *placed,
            _ => false,
        };
        if !collecting || !self.settled(sample.time) {
            return;
        }
        match &mut self.state {
            State::Still { step, samples } => {
                samples.push(sample.clone());
                if samples.len() >= wanted {
                    let (step, samples) = (*step, std::mem::take(samples));
                    self.finish();
                    self.fit_still(step, &samples);
                }
            }
            State::Accel { next, placed, samples, captures } => {
                samples.push(sample.clone());
                if samples.len() < wanted {
                    return;
                }
                captures.push(std::mem::take(samples));
                *placed = false;
                *next += 1;
                let next = *next;
                if next < VehicleOrientation::ALL.len() {
                    self.set_motion(Motion::Level);
                    self.ask_position(next);
                } else {
                    let captures = std::mem::take(captures);
                    self.finish();
                    self.fit_accel(&captures);
                }
            }
            _ => {}
        }
    }

    /// A raw board-frame compass sample.
    pub fn on_mag(&mut self, sample: &MagSample) {
        let State::Mag { start_at, .. } = &self.state else { return };
        if sample.time < *start_at || !self.settled(sample.time) {
            return;
        }
        let (wanted, field) = (self.settings.mag_samples, self.settings.mag.expected_field_gauss);
        let State::Mag { samples, .. } = &mut self.state else { return };
        samples.push(sample.clone());
        if samples.len() >= wanted && coverage(samples, field).covered(1) == REGIONS {
            self.end_mag();
        }
    }

    /// Timeouts and compass progress at `now`.
    pub fn on_tick(&mut self, now: Time) {
        if let State::Mag { samples, ends_at, .. } = &self.state {
            if now >= *ends_at {
                self.end_mag();
                return;
            }
            if now >= self.next_progress {
                let c = coverage(samples, self.settings.mag.expected_field_gauss);
                let share = (c.covered(1) as f64 / REGIONS as f64)
                    .min(samples.len() as f64 / self.settings.mag_samples as f64);
                let mask = u64::from(c.mask(1));
                self.out.push(CalibrationUpdate::MagProgress {
                    completion_pct: (share * 100.0).round().clamp(0.0, 100.0) as u8,
                    completion_mask: std::array::from_fn(|i| {
                        mask.checked_shr(8 * i as u32).unwrap_or(0) as u8
                    }),
                    attempt: 1,
                });
                self.next_progress = now + Duration::from_secs_f64(self.settings.progress_period_s);
            }
            return;
        }
        if let State::EscMaxMin { .. } = self.state {
            self.step_esc_max_min(now);
        }
        if let State::Esc { .. } = self.state {
            let stale = Duration::from_secs_f64(self.settings.esc_telemetry_timeout_s);
            if self.esc_feedback.is_none_or(|f| now.saturating_since(f.time) > stale) {
                self.stop_esc("ESC telemetry stopped");
                return;
            }
        }
        if self.running().is_some() && now >= self.deadline {
            let step = self.running().map_or("", CalibrationStep::name);
            if matches!(self.state, State::Accel { .. }) {
                self.out.push(CalibrationUpdate::AccelPosition { position: ACCELCAL_FAILED });
            }
            self.text(Severity::Critical, format!("Calibration FAILED: {step} timed out"));
            self.finish();
        }
    }

    fn with_current(&self, change: impl FnOnce(&mut SensorCalibration)) -> Option<CalibrationParams> {
        let mut c = self.current.calibration().ok()?;
        change(&mut c);
        Some(CalibrationParams::from_calibration(&c))
    }

    fn fit_still(&mut self, step: CalibrationStep, samples: &[ImuSample]) {
        let result = match step {
            CalibrationStep::Gyro => calibrate_gyro(samples, &self.settings.gyro)
                .map(|f| self.with_current(|c| c.gyro = f.calibration).map(|p| p.values("INS_GYROFFS")))
                .map_err(|e| e.to_string()),
            _ => {
                let accel = self.current.calibration().map(|c| c.accel).unwrap_or_default();
                calibrate_level(samples, &accel, &self.settings.level)
                    .map(|f| self.with_current(|c| c.level = f.level).map(|p| p.values("AHRS_TRIM")))
                    .map_err(|e| e.to_string())
            }
        };
        match result {
            Ok(Some(params)) => {
                self.text(Severity::Info, format!("{} calibration successful", step.name()));
                self.out.push(CalibrationUpdate::Results { params });
            }
            Ok(None) => self.text(Severity::Critical, "Calibration FAILED: the values in use are invalid"),
            Err(e) => self.text(Severity::Critical, format!("{} calibration FAILED: {e}", step.name())),
        }
    }

    fn fit_accel(&mut self, captures: &[Vec<ImuSample>]) {
        let given: Vec<OrientationSamples<'_>> = VehicleOrientation::ALL
            .iter()
            .zip(captures)
            .map(|(&orientation, samples)| OrientationSamples { orientation, samples })
            .collect();
        let params = calibrate_accel(&given, &self.settings.accel).map_err(|e| e.to_string()).and_then(|f| {
            self.with_current(|c| c.accel = f.calibration)
                .map(|p| p.values("INS_ACC"))
                .ok_or_else(|| "the values in use are invalid".to_owned())
        });
        match params {
            Ok(params) => {
                self.out.push(CalibrationUpdate::Results { params });
                self.out.push(CalibrationUpdate::AccelPosition { position: ACCELCAL_SUCCESS });
                self.text(Severity::Info, "Calibration successful");
            }
            Err(e) => {
                self.out.push(CalibrationUpdate::AccelPosition { position: ACCELCAL_FAILED });
                self.text(Severity::Critical, format!("Calibration FAILED: {e}"));
            }
        }
    }

    fn end_mag(&mut self) {
        let State::Mag { autosave, samples, .. } = std::mem::replace(&mut self.state, State::Idle) else {
            return;
        };
        self.set_motion(Motion::Idle);
        let fit = calibrate_mag(&samples, &self.settings.mag).map_err(|e| e.to_string()).and_then(|f| {
            self.with_current(|c| c.mag = f.calibration.clone())
                .map(|p| (f, p))
                .ok_or_else(|| "the values in use are invalid".to_owned())
        });
        match fit {
            Ok((fit, params)) => {
                self.out.push(CalibrationUpdate::MagReport(report(&fit, &params, autosave)));
                let values = params.values("COMPASS_");
                if autosave {
                    self.out.push(CalibrationUpdate::Results { params: values });
                    self.text(Severity::Info, "Compass calibration successful and saved");
                } else {
                    self.text(
                        Severity::Info,
                        "Compass calibration successful: accept it (DO_ACCEPT_MAG_CAL)",
                    );
                    self.state = State::MagDone { params: values };
                }
            }
            Err(reason) => {
                self.out.push(CalibrationUpdate::MagReport(MagReport {
                    state: MagCalState::Failed,
                    fitness_mgauss: 0.0,
                    offsets_mgauss: [0.0; 3],
                    diagonal: [1.0; 3],
                    off_diagonal: [0.0; 3],
                    autosaved: false,
                    reason: reason.clone(),
                }));
                self.text(Severity::Critical, format!("Compass calibration FAILED: {reason}"));
            }
        }
    }
}

fn report(fit: &MagFit, params: &CalibrationParams, autosaved: bool) -> MagReport {
    MagReport {
        state: MagCalState::Success,
        fitness_mgauss: fit.residual_gauss * 1000.0,
        offsets_mgauss: params.compass_ofs_mgauss,
        diagonal: params.compass_dia,
        off_diagonal: params.compass_odi,
        autosaved,
        reason: String::new(),
    }
}

/// Directions seen around the readings' centre, counting only readings at least half the
/// expected field from it, so sensor noise about one orientation covers nothing (progress and
/// when to stop; the fit counts its own).
fn coverage(samples: &[MagSample], expected_field_gauss: f64) -> Coverage {
    let n = samples.len().max(1) as f64;
    let centre = samples.iter().fold(Vector3::zeros(), |a, s| a + Vector3::from(s.field_gauss)) / n;
    Coverage::of(
        samples
            .iter()
            .map(|s| Vector3::from(s.field_gauss) - centre)
            .filter(|d| d.norm() >= 0.5 * expected_field_gauss),
    )
}

/// Whether the values in use hold a result of `step`.
fn calibrated(current: &CalibrationParams, step: CalibrationStep) -> bool {
    match step {
        CalibrationStep::Gyro => current.differs_from_default("INS_GYROFFS"),
        CalibrationStep::Accel => current.differs_from_default("INS_ACC"),
        CalibrationStep::Level => current.differs_from_default("AHRS_TRIM"),
        CalibrationStep::Mag => current.differs_from_default("COMPASS_OFS"),
        // Not `required`-able (the actor refuses it): its result lives with the motor outputs.
        CalibrationStep::Esc => true,
    }
}
