//! The ESC range calibration's part of the session: it drives the motors, so it starts only
//! disarmed and landed, ramps the outputs while ESC telemetry shows their speed (or runs PX4's
//! max-then-min for PWM ESCs that report nothing), and stops to the disarmed pulse on cancel, an
//! arm request, a timeout or telemetry that goes quiet.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::esc::esc_range_names;
use kestrel_proto::messages::{
    CalibrationStep, CalibrationUpdate, EscTelemetry, MAX_MOTORS, Motion, Severity,
};

use super::{Session, State};
use crate::calibration::{EscSample, calibrate_esc};

/// The newest ESC telemetry: when, and how many motors it reports.
#[derive(Clone, Copy, Debug)]
pub(super) struct EscFeedback {
    pub(super) time: Time,
    pub(super) count: usize,
}

impl Session {
    /// The pulse every output is to be driven at now (µs), while the ESC calibration runs.
    pub fn esc_pulses_us(&self) -> Option<[f64; MAX_MOTORS]> {
        match &self.state {
            State::Esc { step, .. } => {
                self.settings.esc_ramp.pulse_us(*step).map(|p| [f64::from(p); MAX_MOTORS])
            }
            State::EscMaxMin { .. } => Some([self.settings.esc_max_us; MAX_MOTORS]),
            _ => None,
        }
    }

    /// Stops a running ESC calibration (`why` tells the operator): the motors go to the
    /// disarmed pulse.
    pub(super) fn stop_esc(&mut self, why: &str) {
        if self.running() == Some(CalibrationStep::Esc) {
            self.text(
                Severity::Critical,
                format!("ESC calibration stopped: {why}; motors at the disarmed pulse"),
            );
            self.finish();
        }
    }

    /// Starts the ESC ramp, if the vehicle may turn its motors and their speed can be seen.
    pub(super) fn start_esc(&mut self, now: Time) -> Result<(), String> {
        if !self.landed {
            return Err("ESC calibration refused: vehicle not landed".to_owned());
        }
        let stale = Duration::from_secs_f64(self.settings.esc_telemetry_timeout_s);
        let Some(feedback) =
            self.esc_feedback.filter(|f| now.saturating_since(f.time) <= stale && f.count > 0)
        else {
            return self.start_esc_max_min(now);
        };
        let ramp = self.settings.esc_ramp;
        self.deadline = now + Duration::from_secs_f64(ramp.duration_s() + self.settings.esc_margin_s);
        self.state =
            State::Esc { step: 0, since: now, ramps: vec![Vec::with_capacity(ramp.steps()); feedback.count] };
        self.set_motion(Motion::PropsOff);
        self.text(
            Severity::Critical,
            "ESC calibration: REMOVE THE PROPELLERS. Motors will spin up to full speed",
        );
        self.text(
            Severity::Info,
            format!(
                "ESC calibration: ramping {} outputs {}..{} us over {:.0} s",
                feedback.count,
                ramp.from_us(),
                ramp.to_us(),
                ramp.duration_s()
            ),
        );
        Ok(())
    }

    /// PX4's calibration of PWM ESCs, which report nothing: needs a battery monitor, and the
    /// battery disconnected (the ESCs must power up seeing the maximum pulse).
    fn start_esc_max_min(&mut self, now: Time) -> Result<(), String> {
        let connected_v = self.settings.esc_battery_connected_v;
        match self.battery_v {
            None => Err("ESC calibration refused: no ESC telemetry (motor speed) for the ramp, \
                 and no battery voltage for the PWM ESCs' max-then-min"
                .to_owned()),
            Some(v) if !(v.is_finite() && v <= connected_v) => Err(format!(
                "ESC calibration refused: no ESC telemetry (motor speed) for the ramp; for PWM ESCs disconnect the battery ({v:.1} V) and try again"
            )),
            Some(_) => {
                let s = &self.settings;
                self.deadline =
                    now + Duration::from_secs_f64(s.esc_battery_wait_s + s.esc_max_hold_s + s.esc_margin_s);
                self.state = State::EscMaxMin { since: now, connected: None };
                self.set_motion(Motion::PropsOff);
                self.text(
                    Severity::Critical,
                    "ESC calibration: REMOVE THE PROPELLERS. Connect the battery now",
                );
                self.text(
                    Severity::Info,
                    format!(
                        "ESC calibration: no ESC telemetry, PWM max-then-min: {:.0} us until the battery is connected",
                        self.settings.esc_max_us
                    ),
                );
                Ok(())
            }
        }
    }

    /// The PWM procedure at `now`: wait for the battery, hold the maximum, then release.
    pub(super) fn step_esc_max_min(&mut self, now: Time) {
        let (wait_s, hold_s, connected_v) = (
            self.settings.esc_battery_wait_s,
            self.settings.esc_max_hold_s,
            self.settings.esc_battery_connected_v,
        );
        let battery_on = self.battery_v.is_some_and(|v| v > connected_v);
        let State::EscMaxMin { since, connected } = self.state else { return };
        match connected {
            None if battery_on => {
                self.state = State::EscMaxMin { since, connected: Some(now) };
                self.text(Severity::Info, "ESC calibration: battery connected, holding the maximum pulse");
            }
            None if now.saturating_since(since).as_secs_f64() > wait_s => {
                self.text(Severity::Critical, "ESC calibration FAILED: timeout waiting for the battery");
                self.finish();
            }
            Some(at) if now.saturating_since(at).as_secs_f64() >= hold_s => {
                self.finish();
                self.text(
                    Severity::Info,
                    "ESC calibration done: the ESCs learnt the maximum and now the disarmed pulse as minimum",
                );
            }
            _ => {}
        }
    }

    /// ESC telemetry: the ramp's feedback.
    pub fn on_esc(&mut self, telemetry: &EscTelemetry) {
        let count = usize::from(telemetry.count).min(MAX_MOTORS);
        self.esc_feedback = Some(EscFeedback { time: telemetry.time, count });
        let dwell = Duration::from_secs_f64(self.settings.esc_ramp.dwell_s());
        let ramp = self.settings.esc_ramp;
        let State::Esc { step, since, ramps } = &mut self.state else { return };
        if telemetry.time < *since + dwell {
            return;
        }
        let Some(pulse_us) = ramp.pulse_us(*step) else { return };
        for (i, samples) in ramps.iter_mut().enumerate() {
            let speed_rad_s = if i < count { telemetry.speed_rad_s[i] } else { f64::NAN };
            samples.push(EscSample { pulse_us, speed_rad_s });
        }
        *step += 1;
        *since = telemetry.time;
        if *step >= ramp.steps() {
            let ramps = std::mem::take(ramps);
            self.finish();
            self.fit_esc(&ramps);
        }
    }

    fn fit_esc(&mut self, ramps: &[Vec<EscSample>]) {
        match calibrate_esc(ramps, &self.settings.esc) {
            Ok(ranges) => {
                let mut params = Vec::with_capacity(2 * ranges.len());
                let mut summary = Vec::with_capacity(ranges.len());
                for (i, r) in ranges.iter().enumerate() {
                    let (min, max) = esc_range_names(i);
                    params.push((min.to_owned(), f64::from(r.start_us)));
                    params.push((max.to_owned(), f64::from(r.full_us)));
                    summary.push(format!("{} {}..{}", i + 1, r.start_us, r.full_us));
                }
                self.out.push(CalibrationUpdate::Results { params });
                self.text(Severity::Info, format!("ESC calibration successful (us): {}", summary.join(", ")));
            }
            Err(e) => self.text(Severity::Critical, format!("ESC calibration FAILED: {e}")),
        }
    }
}
