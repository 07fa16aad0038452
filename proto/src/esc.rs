//! ESC pulses, in one place for every output that drives ESCs (the Navio2 PWM motor actor, the
//! simulator's actuator path):
//!
//! * [`EscRanges`] — each output's pulse for motor command 0 and 1, the live parameters
//!   `SERVOn_MIN` / `SERVOn_MAX` ([`ESC_RANGE_PARAMS`], ArduPilot's names and sense: µs at zero
//!   and full output), which an ESC range calibration sets so equal commands give equal thrust;
//! * [`DirectPulses`] — the direct-pulse path ([`EscPulses`]): every value checked exactly
//!   (finite, inside [`SAFE_PULSE_MIN_US`]..=[`SAFE_PULSE_MAX_US`], ArduPilot's
//!   `MOTOR_TEST_PWM_MAX` 2200 µs), obeyed only while disarmed, and dropped
//!   [`DIRECT_PULSE_TIMEOUT`] after the last message, so a calibration that dies leaves the
//!   ESCs at the disarmed pulse.

use std::time::Duration;

use crate::messages::{EscPulses, MAX_MOTORS};
use crate::param_def::{ParamDef, WhileArmed};
use crate::time::Time;

/// Lowest pulse any output is ever asked for directly or by a range (µs).
pub const SAFE_PULSE_MIN_US: f64 = 800.0;
/// Highest pulse (µs): ArduPilot's motor test limit (`MOTOR_TEST_PWM_MAX`).
pub const SAFE_PULSE_MAX_US: f64 = 2200.0;
/// Narrowest range an output may map its commands onto (µs): less is a typo or a broken fit.
pub const MIN_RANGE_US: f64 = 100.0;
/// Direct pulses older than this are dropped for the disarmed pulse.
pub const DIRECT_PULSE_TIMEOUT: Duration = Duration::from_millis(100);

/// Why a range or a direct pulse is refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InvalidPulse {
    #[error(
        "output {output}: pulse {pulse_us:?} µs is not finite or outside {SAFE_PULSE_MIN_US}..={SAFE_PULSE_MAX_US} µs"
    )]
    OutOfRange { output: usize, pulse_us: f64 },
    #[error("output {output}: range {min_us}..{max_us} µs is narrower than {MIN_RANGE_US} µs or reversed")]
    Narrow { output: usize, min_us: f64, max_us: f64 },
    #[error("direct pulses stamped {stamped} arrived at {now}: older than {DIRECT_PULSE_TIMEOUT:?}")]
    Stale { stamped: Time, now: Time },
}

fn safe(output: usize, pulse_us: f64) -> Result<f64, InvalidPulse> {
    if pulse_us.is_finite() && (SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US).contains(&pulse_us) {
        Ok(pulse_us)
    } else {
        Err(InvalidPulse::OutOfRange { output, pulse_us })
    }
}

/// One output's pulses at motor command 0 and 1 (µs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputRange {
    pub min_us: f64,
    pub max_us: f64,
}

/// Every output's range, in the frame's motor order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EscRanges {
    pub outputs: [OutputRange; MAX_MOTORS],
}

impl EscRanges {
    /// Every output on `min_us..max_us` (the nominal 1000..2000 µs of PWM ESCs, or a driver's
    /// configured pulses).
    pub fn uniform(min_us: f64, max_us: f64) -> EscRanges {
        EscRanges { outputs: [OutputRange { min_us, max_us }; MAX_MOTORS] }
    }

    /// Checks every output: both ends finite and safe, at least [`MIN_RANGE_US`] apart.
    pub fn validate(&self) -> Result<(), InvalidPulse> {
        for (output, r) in self.outputs.iter().enumerate() {
            safe(output, r.min_us)?;
            safe(output, r.max_us)?;
            if r.max_us - r.min_us < MIN_RANGE_US {
                return Err(InvalidPulse::Narrow { output, min_us: r.min_us, max_us: r.max_us });
            }
        }
        Ok(())
    }

    /// The pulse for `command` on `output` (µs): 0..1 onto `min_us..max_us`, clamped, NaN as 0.
    /// An output index past [`MAX_MOTORS`] uses the last output's range.
    pub fn pulse_us(&self, output: usize, command: f64) -> f64 {
        let r = self.outputs[output.min(MAX_MOTORS - 1)];
        let c = if command.is_nan() { 0.0 } else { command.clamp(0.0, 1.0) };
        r.min_us + c * (r.max_us - r.min_us)
    }
}

impl Default for EscRanges {
    fn default() -> EscRanges {
        EscRanges::uniform(1000.0, 2000.0)
    }
}

macro_rules! esc_param {
    ($name:literal, $i:literal, min_us, $desc:expr) => {
        esc_param!(@ $name, $desc, |r: &EscRanges| r.outputs[$i].min_us, |r: &mut EscRanges, v| r.outputs[$i].min_us = v)
    };
    ($name:literal, $i:literal, max_us, $desc:expr) => {
        esc_param!(@ $name, $desc, |r: &EscRanges| r.outputs[$i].max_us, |r: &mut EscRanges, v| r.outputs[$i].max_us = v)
    };
    (@ $name:literal, $desc:expr, $get:expr, $set:expr) => {
        ParamDef {
            name: $name,
            unit: "us",
            min: SAFE_PULSE_MIN_US,
            max: SAFE_PULSE_MAX_US,
            description: $desc,
            // A narrowed range stops or races that motor (SERVO1_MIN 800 then SERVO1_MAX 900
            // leaves motor 1 near stopped): set on the ground only.
            while_armed: WhileArmed::Locked,
            get: $get,
            set: $set,
        }
    };
}

const AT_0: &str = "ESC pulse at motor command 0 (the ESC range calibration's start)";
const AT_1: &str = "ESC pulse at motor command 1 (the ESC range calibration's full speed)";

/// `SERVOn_MIN`, `SERVOn_MAX` for outputs 1..=8, in that order: the owner of `n` outputs
/// declares and applies the first `2 * n` ([`esc_range_params`]).
pub static ESC_RANGE_PARAMS: [ParamDef<EscRanges>; 2 * MAX_MOTORS] = [
    esc_param!("SERVO1_MIN", 0, min_us, AT_0),
    esc_param!("SERVO1_MAX", 0, max_us, AT_1),
    esc_param!("SERVO2_MIN", 1, min_us, AT_0),
    esc_param!("SERVO2_MAX", 1, max_us, AT_1),
    esc_param!("SERVO3_MIN", 2, min_us, AT_0),
    esc_param!("SERVO3_MAX", 2, max_us, AT_1),
    esc_param!("SERVO4_MIN", 3, min_us, AT_0),
    esc_param!("SERVO4_MAX", 3, max_us, AT_1),
    esc_param!("SERVO5_MIN", 4, min_us, AT_0),
    esc_param!("SERVO5_MAX", 4, max_us, AT_1),
    esc_param!("SERVO6_MIN", 5, min_us, AT_0),
    esc_param!("SERVO6_MAX", 5, max_us, AT_1),
    esc_param!("SERVO7_MIN", 6, min_us, AT_0),
    esc_param!("SERVO7_MAX", 6, max_us, AT_1),
    esc_param!("SERVO8_MIN", 7, min_us, AT_0),
    esc_param!("SERVO8_MAX", 7, max_us, AT_1),
];

/// The range parameters of the first `outputs` outputs.
pub fn esc_range_params(outputs: usize) -> &'static [ParamDef<EscRanges>] {
    &ESC_RANGE_PARAMS[..2 * outputs.min(MAX_MOTORS)]
}

/// The names of output `output`'s (0-based) range parameters.
pub fn esc_range_names(output: usize) -> (&'static str, &'static str) {
    let i = 2 * output.min(MAX_MOTORS - 1);
    (ESC_RANGE_PARAMS[i].name, ESC_RANGE_PARAMS[i + 1].name)
}

/// The direct-pulse path's state in a consumer: the newest accepted [`EscPulses`] and when it
/// arrived.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DirectPulses {
    latest: Option<(Time, [f64; MAX_MOTORS])>,
}

impl DirectPulses {
    /// Takes `message`, arriving at `now`. A release, or any refusal (a value out of range, a
    /// message already stale), drops the pulses held: the outputs go to the disarmed pulse.
    pub fn on_message(&mut self, message: &EscPulses, now: Time) -> Result<(), InvalidPulse> {
        self.latest = None;
        if !message.control {
            return Ok(());
        }
        if now.saturating_since(message.time) > DIRECT_PULSE_TIMEOUT {
            return Err(InvalidPulse::Stale { stamped: message.time, now });
        }
        for (output, &p) in message.pulses_us.iter().enumerate() {
            safe(output, p)?;
        }
        self.latest = Some((now, message.pulses_us));
        Ok(())
    }

    /// The pulses to drive at `now` (µs), if any: none while `armed` (the mixer's commands
    /// rule), once released, or [`DIRECT_PULSE_TIMEOUT`] after the last message.
    pub fn pulses_us(&self, now: Time, armed: bool) -> Option<&[f64; MAX_MOTORS]> {
        let (at, pulses) = self.latest.as_ref()?;
        (!armed && now.saturating_since(*at) <= DIRECT_PULSE_TIMEOUT).then_some(pulses)
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::param_def::apply;

    fn pulses(time_us: u64, control: bool, pulse_us: f64) -> EscPulses {
        EscPulses { time: Time::from_micros(time_us), control, pulses_us: [pulse_us; MAX_MOTORS] }
    }

    #[test]
    fn direct_pulses_are_checked_exactly_obeyed_disarmed_only_and_time_out() {
        let mut gate = DirectPulses::default();
        let t = Time::from_micros;
        assert_eq!(gate.on_message(&pulses(1_000_000, true, 1500.0), t(1_000_000)), Ok(()));
        assert_eq!(gate.pulses_us(t(1_100_000), false), Some(&[1500.0; MAX_MOTORS]));
        assert_eq!(gate.pulses_us(t(1_100_001), false), None, "stale after 0.1 s");
        assert_eq!(gate.pulses_us(t(1_050_000), true), None, "armed: the mixer rules");
        for bad in [f64::NAN, f64::INFINITY, -1500.0, 799.9, 2200.1, 0.0] {
            gate.on_message(&pulses(1_000_000, true, 1500.0), t(1_000_000)).expect("good");
            let mut message = pulses(1_000_000, true, 1500.0);
            message.pulses_us[3] = bad;
            assert!(
                matches!(
                    gate.on_message(&message, t(1_000_000)),
                    Err(InvalidPulse::OutOfRange { output: 3, .. })
                ),
                "{bad}"
            );
            assert_eq!(gate.pulses_us(t(1_000_000), false), None, "{bad} dropped what was held");
        }
        assert!(gate.on_message(&pulses(800_000, true, 1500.0), t(1_000_000)).is_err(), "arrived stale");
        gate.on_message(&pulses(1_000_000, true, 2200.0), t(1_000_000)).expect("the limit itself");
        gate.on_message(&pulses(1_010_000, false, f64::NAN), t(1_010_000)).expect("a release");
        assert_eq!(gate.pulses_us(t(1_010_000), false), None, "released at once");
    }

    #[test]
    fn ranges_are_servo_parameters_checked_as_a_whole() {
        let names: Vec<&str> = esc_range_params(2).iter().map(|d| d.name).collect();
        assert_eq!(names, ["SERVO1_MIN", "SERVO1_MAX", "SERVO2_MIN", "SERVO2_MAX"]);
        assert_eq!(esc_range_names(7), ("SERVO8_MIN", "SERVO8_MAX"));
        let mut ranges = EscRanges::default();
        let change = apply(esc_range_params(4), &mut ranges, "SERVO3_MIN", 1080.0, EscRanges::validate);
        assert!(change.is_ok(), "{change:?}");
        assert_eq!(ranges.outputs[2].min_us, 1080.0);
        assert!(apply(esc_range_params(4), &mut ranges, "SERVO3_MAX", 1150.0, EscRanges::validate).is_err());
        assert!(apply(esc_range_params(4), &mut ranges, "SERVO3_MAX", 2300.0, EscRanges::validate).is_err());
        assert_eq!(ranges.outputs[2].max_us, 2000.0, "refused: kept");
        assert_eq!(ranges.pulse_us(2, 0.5), 1540.0);
        assert_eq!(ranges.pulse_us(2, f64::NAN), 1080.0);
        assert_eq!(ranges.pulse_us(2, 7.0), 2000.0);
    }

    proptest! {
        /// Whatever the command, a valid range's pulse lies inside it.
        #[test]
        fn a_pulse_stays_inside_its_range(min in 800.0..2000.0f64, width in 100.0..1000.0f64, c in proptest::num::f64::ANY) {
            let max = (min + width).min(SAFE_PULSE_MAX_US);
            prop_assume!(max - min >= MIN_RANGE_US);
            let ranges = EscRanges::uniform(min, max);
            prop_assert!(ranges.validate().is_ok());
            let p = ranges.pulse_us(0, c);
            prop_assert!((min..=max).contains(&p), "{p}");
        }
    }
}
