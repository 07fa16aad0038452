//! Fault injection: what a world file's `[[faults]]` array breaks, and when.
//!
//! A [`Fault`] is one entry: it starts at `at_s` seconds of simulated time (the graph clock,
//! zero at the start of the run) and lasts `for_s` seconds, or to the end of the run when
//! `for_s` is omitted. A [`FaultSchedule`] answers which faults are active at a time
//! ([`FaultSchedule::active_at`]), sums them into the [`FaultEffects`] each model applies to its
//! own output (the GPS in `sensors/gps.rs`, the motors in `motors.rs`, ...), and reports each
//! start and end once ([`FaultSchedule::poll`]) for the log and the `sim_fault` topic. Later the
//! live simulator parameters and MAV_CMD_INJECT_FAILURE add entries to the same schedule
//! ([`FaultSchedule::push`]).
//!
//! Time is integer microseconds like the rest of the simulator: a fault is active on every tick
//! `t` with `start ≤ t < end`, `start = round(at_s·10⁶) µs`. A tick's physics (motors, wind) and
//! its sensor samples both see the faults active at the tick's time.
//!
//! Overlapping faults combine as the physics would: offsets and biases add, factors multiply,
//! switches (off, stuck, stop) hold while any is active; a later `wind` replaces an earlier one
//! (the latest start wins; on a tie, the later entry).

use std::fmt;

use kestrel_proto::Time;
use kestrel_proto::messages::{MAX_MOTORS, SimFault, SimFaultPhase};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::battery::BatteryFaults;
use crate::error::InvalidParam;
use crate::motors::MotorFaults;
use crate::sensors::baro::BaroFaults;
use crate::sensors::gps::GpsFaults;
use crate::sensors::imu::ImuFaults;
use crate::sensors::mag::MagFaults;
use crate::wind::WindFault;

/// One `[[faults]]` entry: a [`FaultKind`] from `at_s` for `for_s`.
///
/// In the world file the kind is the `kind` key and its values sit beside it:
/// ```toml
/// [[faults]]
/// at_s = 20.0
/// for_s = 5.0
/// kind = "gps_jump"
/// ned_m = [50.0, 0.0, 0.0]
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawFault", into = "RawFault")]
pub struct Fault {
    /// Start (s of simulated time, ≥ 0).
    pub at_s: f64,
    /// Duration (s, > 0); `None`: to the end of the run.
    pub for_s: Option<f64>,
    pub kind: FaultKind,
}

/// What breaks. Frames and units as everywhere in the simulator: NED earth frame around home,
/// FRD body frame, SI units except the magnetometer's gauss.
#[derive(Clone, Debug, PartialEq)]
pub enum FaultKind {
    /// `gps_off`: the receiver loses every satellite. As a u-blox does on loss of signal, it
    /// keeps sending a solution at its rate but flags it as no fix (`fixType` 0, `gnssFixOK`
    /// clear, no satellites): the fix carries [`GpsFixType::NoFix`](kestrel_proto::messages::GpsFixType),
    /// 0 satellites, the last good position, zero velocity and accuracies of 4 294 967 m (the
    /// all-ones `hAcc` a u-blox reports without a fix).
    GpsOff,
    /// `gps_jump ned_m = [n, e, d]`: the reported position is offset by `ned_m` (m, NED), as a
    /// multipath glitch or a spoofer would; velocity is unchanged.
    GpsJump { ned_m: [f64; 3] },
    /// `gps_noise factor`: the position and velocity noise 1σ are multiplied by `factor` (≥ 0).
    /// The reported accuracies are not: the receiver does not know (the harder case for the
    /// estimator, as ArduPilot's `SIM_GPS_NOISE`).
    GpsNoise { factor: f64 },
    /// `mag_anomaly gauss = [x, y, z]`: a field (gauss, body FRD) added to the magnetometer's
    /// reading, as a magnetised load or a steel structure nearby.
    MagAnomaly { gauss: [f64; 3] },
    /// `mag_stuck`: the magnetometer repeats its last reading before the fault, with fresh time
    /// stamps (a hung I²C device whose driver keeps reading the same register).
    MagStuck,
    /// `baro_drift m_s`: the pressure altitude error grows at `m_s` (m/s, positive = reads
    /// higher) from the fault's start: `m_s·(t − at_s)` metres after `t − at_s` seconds (the
    /// reported pressure consistent with it); it is gone when the fault ends.
    BaroDrift { m_s: f64 },
    /// `baro_stuck`: the barometer repeats its last reading before the fault, with fresh time
    /// stamps.
    BaroStuck,
    /// `gyro_bias rad_s = [x, y, z]`: a step (rad/s, body FRD) added to the gyro's output.
    GyroBias { rad_s: [f64; 3] },
    /// `accel_bias m_s2 = [x, y, z]`: a step (m/s², body FRD) added to the accelerometer's output.
    AccelBias { m_s2: [f64; 3] },
    /// `accel_clip`: the accelerometer saturates at its full-scale range (`[sensors.imu]
    /// accel_full_scale_g`, ±16 g by default): each axis's specific force is clamped to ±range
    /// and flagged in `accel_clipped`. Outside the fault the simulated IMU never clips.
    AccelClip,
    /// `imu_stop`: no IMU samples are published (the simulator keeps stepping on its own timer,
    /// so the lockstep clock runs on and the estimator sees the stream stop).
    ImuStop,
    /// `motor_lost motor`: motor `motor` (1-based, mixer order) gives no thrust and no drag
    /// torque (a propeller gone); it still turns, at no power.
    MotorLost { motor: u8 },
    /// `motor_weak motor thrust`: motor `motor`'s thrust and drag torque (and so the power it
    /// absorbs) are scaled by `thrust` (0..1) at the same speed, as a chipped propeller.
    MotorWeak { motor: u8, thrust: f64 },
    /// `battery_sag volts`: the pack's terminal voltage is lowered by `volts` (V, ≥ 0; never
    /// below 0), as a failing cell or a corroded connector would; the current and the charge
    /// drawn stay the healthy pack's, so the fault shows the voltage failsafe alone.
    BatterySag { volts: f64 },
    /// `wind ned_m_s = [n, e, d], gust_m_s`: the world's steady wind is replaced by `ned_m_s`
    /// (m/s, NED, the direction the air moves *towards*) and its gust 1σ by `gust_m_s` (m/s,
    /// ≥ 0, default 0) for the duration; the gusts keep the world's correlation time.
    Wind { ned_m_s: [f64; 3], gust_m_s: f64 },
    /// `camera_stop`: the simulated stereo camera publishes no frames (captures are skipped).
    CameraStop,
    /// `camera_black`: the camera publishes frames on time whose pixels are all 0 (a lens cap).
    CameraBlack,
    /// `camera_frozen`: the camera publishes the pixels of its last frame before the fault
    /// again and again, with fresh stamps and sequence numbers (a driver stuck on one buffer).
    CameraFrozen,
    /// `actor_panic actor`: the named actor of the graph panics. The runtime injects it (it
    /// reads the sim actor's world file at start-up, refuses a name that is not in the graph,
    /// and while the fault is active every incarnation of the actor panics on the first message
    /// it would handle: a `for_s` shorter than the restart backoff is one panic); the simulator
    /// only reports its start and end.
    ActorPanic { actor: String },
    /// `link_lost`: the ground station's radio link is down: the simulated ground station
    /// (`sim_gcs`, in the link crate) sends nothing while it is active, so the vehicle stops
    /// hearing its heartbeats; the simulator only reports its start and end.
    LinkLost,
}

/// Every kind's `kind` spelling, in the order of the world file documentation.
pub const KINDS: [&str; 20] = [
    "gps_off",
    "gps_jump",
    "gps_noise",
    "mag_anomaly",
    "mag_stuck",
    "baro_drift",
    "baro_stuck",
    "gyro_bias",
    "accel_bias",
    "accel_clip",
    "imu_stop",
    "motor_lost",
    "motor_weak",
    "battery_sag",
    "wind",
    "camera_stop",
    "camera_black",
    "camera_frozen",
    "actor_panic",
    "link_lost",
];

impl FaultKind {
    /// The `kind` spelling.
    pub fn name(&self) -> &'static str {
        match self {
            FaultKind::GpsOff => "gps_off",
            FaultKind::GpsJump { .. } => "gps_jump",
            FaultKind::GpsNoise { .. } => "gps_noise",
            FaultKind::MagAnomaly { .. } => "mag_anomaly",
            FaultKind::MagStuck => "mag_stuck",
            FaultKind::BaroDrift { .. } => "baro_drift",
            FaultKind::BaroStuck => "baro_stuck",
            FaultKind::GyroBias { .. } => "gyro_bias",
            FaultKind::AccelBias { .. } => "accel_bias",
            FaultKind::AccelClip => "accel_clip",
            FaultKind::ImuStop => "imu_stop",
            FaultKind::MotorLost { .. } => "motor_lost",
            FaultKind::MotorWeak { .. } => "motor_weak",
            FaultKind::BatterySag { .. } => "battery_sag",
            FaultKind::Wind { .. } => "wind",
            FaultKind::CameraStop => "camera_stop",
            FaultKind::CameraBlack => "camera_black",
            FaultKind::CameraFrozen => "camera_frozen",
            FaultKind::ActorPanic { .. } => "actor_panic",
            FaultKind::LinkLost => "link_lost",
        }
    }

    /// The 1-based motor the fault acts on, if it acts on one.
    pub fn motor(&self) -> Option<u8> {
        match self {
            FaultKind::MotorLost { motor } | FaultKind::MotorWeak { motor, .. } => Some(*motor),
            _ => None,
        }
    }

    /// Checks every value; the error names the field (`thrust`, `ned_m`, ...).
    pub fn validate(&self) -> Result<(), InvalidParam> {
        let finite3 = |field: &str, v: &[f64; 3]| match v.iter().find(|x| !x.is_finite()) {
            None => Ok(()),
            Some(x) => Err(InvalidParam::new(field, format!("must be finite, got {x}"))),
        };
        let at_least_zero = |field: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(InvalidParam::new(field, format!("must be a finite number ≥ 0, got {v}")))
            }
        };
        match self {
            FaultKind::GpsJump { ned_m } => finite3("ned_m", ned_m),
            FaultKind::GpsNoise { factor } => at_least_zero("factor", *factor),
            FaultKind::MagAnomaly { gauss } => finite3("gauss", gauss),
            FaultKind::BaroDrift { m_s } if !m_s.is_finite() => {
                Err(InvalidParam::new("m_s", format!("must be finite, got {m_s}")))
            }
            FaultKind::GyroBias { rad_s } => finite3("rad_s", rad_s),
            FaultKind::AccelBias { m_s2 } => finite3("m_s2", m_s2),
            FaultKind::MotorLost { motor } | FaultKind::MotorWeak { motor, .. }
                if !(1..=MAX_MOTORS).contains(&usize::from(*motor)) =>
            {
                Err(InvalidParam::new("motor", format!("must be within 1..={MAX_MOTORS}, got {motor}")))
            }
            FaultKind::MotorWeak { thrust, .. } if !(thrust.is_finite() && (0.0..=1.0).contains(thrust)) => {
                Err(InvalidParam::new("thrust", format!("must be within 0..=1, got {thrust}")))
            }
            FaultKind::BatterySag { volts } => at_least_zero("volts", *volts),
            FaultKind::Wind { ned_m_s, gust_m_s } => {
                finite3("ned_m_s", ned_m_s)?;
                at_least_zero("gust_m_s", *gust_m_s)
            }
            FaultKind::ActorPanic { actor } if actor.trim().is_empty() => {
                Err(InvalidParam::new("actor", "must name an actor of the graph"))
            }
            _ => Ok(()),
        }
    }
}

/// The values as the world file spells them, e.g. `motor = 1, thrust = 0.7`.
impl fmt::Display for FaultKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v3 = |v: &[f64; 3]| format!("[{}, {}, {}]", v[0], v[1], v[2]);
        match self {
            FaultKind::GpsJump { ned_m } => write!(f, "ned_m = {}", v3(ned_m)),
            FaultKind::GpsNoise { factor } => write!(f, "factor = {factor}"),
            FaultKind::MagAnomaly { gauss } => write!(f, "gauss = {}", v3(gauss)),
            FaultKind::BaroDrift { m_s } => write!(f, "m_s = {m_s}"),
            FaultKind::GyroBias { rad_s } => write!(f, "rad_s = {}", v3(rad_s)),
            FaultKind::AccelBias { m_s2 } => write!(f, "m_s2 = {}", v3(m_s2)),
            FaultKind::MotorLost { motor } => write!(f, "motor = {motor}"),
            FaultKind::MotorWeak { motor, thrust } => write!(f, "motor = {motor}, thrust = {thrust}"),
            FaultKind::BatterySag { volts } => write!(f, "volts = {volts}"),
            FaultKind::Wind { ned_m_s, gust_m_s } => {
                write!(f, "ned_m_s = {}, gust_m_s = {gust_m_s}", v3(ned_m_s))
            }
            FaultKind::ActorPanic { actor } => write!(f, "actor = \"{actor}\""),
            _ => Ok(()),
        }
    }
}

impl Fault {
    /// Checks the times and the kind's values; the error names the field.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        if !(self.at_s.is_finite() && self.at_s >= 0.0) {
            return Err(InvalidParam::new("at_s", format!("must be a finite time ≥ 0 s, got {}", self.at_s)));
        }
        if let Some(for_s) = self.for_s
            && !(for_s.is_finite() && for_s > 0.0)
        {
            return Err(InvalidParam::new(
                "for_s",
                format!("must be a finite duration > 0 s (omit it for the rest of the run), got {for_s}"),
            ));
        }
        self.kind.validate()
    }

    /// The first tick the fault is active on.
    pub fn start(&self) -> Time {
        Time(micros(self.at_s))
    }

    /// The first tick it is no longer active on; `None`: never. A positive `for_s` lasts at
    /// least a microsecond.
    pub fn end(&self) -> Option<Time> {
        self.for_s.map(|for_s| Time(micros(self.at_s).saturating_add(micros(for_s).max(1))))
    }

    /// Whether it is active at `time`: `start ≤ time < end`.
    pub fn active_at(&self, time: Time) -> bool {
        self.start() <= time && self.end().is_none_or(|end| time < end)
    }
}

/// Seconds to whole microseconds, saturating (validated values are finite and ≥ 0).
fn micros(s: f64) -> u64 {
    (s * 1e6).round() as u64
}

/// The flat table a `[[faults]]` entry is read from: every kind's values are optional here, and
/// [`Fault::try_from`] refuses those a kind does not have, so a typo is an error, not a default.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFault {
    at_s: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    for_s: Option<f64>,
    kind: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    ned_m: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    factor: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gauss: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    m_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rad_s: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    m_s2: Option<[f64; 3]>,
    /// Signed, so that 0 and −1 are refused as motor numbers rather than as integers.
    #[serde(skip_serializing_if = "Option::is_none")]
    motor: Option<i64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    thrust: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    volts: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ned_m_s: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gust_m_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    actor: Option<String>,
}

impl RawFault {
    /// The names of the values present, for refusing those the kind lacks.
    fn present(&self) -> Vec<&'static str> {
        let mut present = Vec::new();
        let mut note = |name: &'static str, is: bool| {
            if is {
                present.push(name);
            }
        };
        note("ned_m", self.ned_m.is_some());
        note("factor", self.factor.is_some());
        note("gauss", self.gauss.is_some());
        note("m_s", self.m_s.is_some());
        note("rad_s", self.rad_s.is_some());
        note("m_s2", self.m_s2.is_some());
        note("motor", self.motor.is_some());
        note("thrust", self.thrust.is_some());
        note("volts", self.volts.is_some());
        note("ned_m_s", self.ned_m_s.is_some());
        note("gust_m_s", self.gust_m_s.is_some());
        note("actor", self.actor.is_some());
        present
    }
}

impl TryFrom<RawFault> for Fault {
    type Error = InvalidParam;

    fn try_from(raw: RawFault) -> Result<Fault, InvalidParam> {
        fn need<T: Clone>(kind: &str, field: &str, value: &Option<T>) -> Result<T, InvalidParam> {
            value.clone().ok_or_else(|| InvalidParam::new(field, format!("is required by kind `{kind}`")))
        }
        let k = raw.kind.as_str();
        let (kind, takes): (FaultKind, &[&str]) = match k {
            "gps_off" => (FaultKind::GpsOff, &[]),
            "gps_jump" => (FaultKind::GpsJump { ned_m: need(k, "ned_m", &raw.ned_m)? }, &["ned_m"]),
            "gps_noise" => (FaultKind::GpsNoise { factor: need(k, "factor", &raw.factor)? }, &["factor"]),
            "mag_anomaly" => (FaultKind::MagAnomaly { gauss: need(k, "gauss", &raw.gauss)? }, &["gauss"]),
            "mag_stuck" => (FaultKind::MagStuck, &[]),
            "baro_drift" => (FaultKind::BaroDrift { m_s: need(k, "m_s", &raw.m_s)? }, &["m_s"]),
            "baro_stuck" => (FaultKind::BaroStuck, &[]),
            "gyro_bias" => (FaultKind::GyroBias { rad_s: need(k, "rad_s", &raw.rad_s)? }, &["rad_s"]),
            "accel_bias" => (FaultKind::AccelBias { m_s2: need(k, "m_s2", &raw.m_s2)? }, &["m_s2"]),
            "accel_clip" => (FaultKind::AccelClip, &[]),
            "imu_stop" => (FaultKind::ImuStop, &[]),
            "motor_lost" => {
                (FaultKind::MotorLost { motor: motor_number(need(k, "motor", &raw.motor)?)? }, &["motor"])
            }
            "motor_weak" => (
                FaultKind::MotorWeak {
                    motor: motor_number(need(k, "motor", &raw.motor)?)?,
                    thrust: need(k, "thrust", &raw.thrust)?,
                },
                &["motor", "thrust"],
            ),
            "battery_sag" => (FaultKind::BatterySag { volts: need(k, "volts", &raw.volts)? }, &["volts"]),
            "wind" => (
                FaultKind::Wind {
                    ned_m_s: need(k, "ned_m_s", &raw.ned_m_s)?,
                    gust_m_s: raw.gust_m_s.unwrap_or(0.0),
                },
                &["ned_m_s", "gust_m_s"],
            ),
            "camera_stop" => (FaultKind::CameraStop, &[]),
            "camera_black" => (FaultKind::CameraBlack, &[]),
            "camera_frozen" => (FaultKind::CameraFrozen, &[]),
            "actor_panic" => (FaultKind::ActorPanic { actor: need(k, "actor", &raw.actor)? }, &["actor"]),
            "link_lost" => (FaultKind::LinkLost, &[]),
            other => {
                let known = KINDS.join(", ");
                return Err(InvalidParam::new(
                    "kind",
                    format!("`{other}` is not a fault kind (one of {known})"),
                ));
            }
        };
        if let Some(foreign) = raw.present().into_iter().find(|field| !takes.contains(field)) {
            return Err(InvalidParam::new(foreign, format!("is not a value of kind `{k}`")));
        }
        let fault = Fault { at_s: raw.at_s, for_s: raw.for_s, kind };
        fault.validate()?;
        Ok(fault)
    }
}

/// A motor number from the file: 1..=MAX_MOTORS (the frame's own count is checked when the
/// simulator starts, where the vehicle is known).
fn motor_number(motor: i64) -> Result<u8, InvalidParam> {
    u8::try_from(motor)
        .ok()
        .filter(|m| (1..=MAX_MOTORS).contains(&usize::from(*m)))
        .ok_or_else(|| InvalidParam::new("motor", format!("must be within 1..={MAX_MOTORS}, got {motor}")))
}

impl From<Fault> for RawFault {
    fn from(fault: Fault) -> RawFault {
        let mut raw = RawFault {
            at_s: fault.at_s,
            for_s: fault.for_s,
            kind: fault.kind.name().to_owned(),
            ..RawFault::default()
        };
        match fault.kind {
            FaultKind::GpsJump { ned_m } => raw.ned_m = Some(ned_m),
            FaultKind::GpsNoise { factor } => raw.factor = Some(factor),
            FaultKind::MagAnomaly { gauss } => raw.gauss = Some(gauss),
            FaultKind::BaroDrift { m_s } => raw.m_s = Some(m_s),
            FaultKind::GyroBias { rad_s } => raw.rad_s = Some(rad_s),
            FaultKind::AccelBias { m_s2 } => raw.m_s2 = Some(m_s2),
            FaultKind::MotorLost { motor } => raw.motor = Some(i64::from(motor)),
            FaultKind::MotorWeak { motor, thrust } => {
                raw.motor = Some(i64::from(motor));
                raw.thrust = Some(thrust);
            }
            FaultKind::BatterySag { volts } => raw.volts = Some(volts),
            FaultKind::Wind { ned_m_s, gust_m_s } => {
                raw.ned_m_s = Some(ned_m_s);
                raw.gust_m_s = Some(gust_m_s);
            }
            FaultKind::ActorPanic { actor } => raw.actor = Some(actor),
            FaultKind::GpsOff
            | FaultKind::MagStuck
            | FaultKind::BaroStuck
            | FaultKind::AccelClip
            | FaultKind::ImuStop
            | FaultKind::CameraStop
            | FaultKind::CameraBlack
            | FaultKind::CameraFrozen
            | FaultKind::LinkLost => {}
        }
        raw
    }
}

/// Where a scheduled fault is in its life, for [`FaultSchedule::poll`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Pending,
    Active,
    Ended,
}

/// The faults of a run, in the order they were added (the world file's order first).
#[derive(Clone, Debug, Default)]
pub struct FaultSchedule {
    faults: Vec<Fault>,
    phases: Vec<Phase>,
}

impl FaultSchedule {
    /// A schedule of `faults` (already validated), none started yet.
    pub fn new(faults: &[Fault]) -> FaultSchedule {
        FaultSchedule { faults: faults.to_vec(), phases: vec![Phase::Pending; faults.len()] }
    }

    /// Adds a fault (a live parameter or a MAVLink command); its index is the next one.
    pub fn push(&mut self, fault: Fault) {
        self.faults.push(fault);
        self.phases.push(Phase::Pending);
    }

    /// Ends fault `index` from the first tick after `time` on (never later than it was to end).
    /// One added and ended between two ticks takes no effect; its start and end are still
    /// reported, by the same poll.
    pub fn end_after(&mut self, index: usize, time: Time) {
        let Some(fault) = self.faults.get_mut(index) else { return };
        let end_s = (time.0 + 1) as f64 * 1e-6;
        let for_s = (end_s - fault.at_s).max(1e-6);
        fault.for_s = Some(fault.for_s.map_or(for_s, |old| old.min(for_s)));
    }

    /// Every fault, with its index.
    pub fn faults(&self) -> &[Fault] {
        &self.faults
    }

    /// The faults active at `time` (`start ≤ time < end`), with their indices, in order.
    pub fn active_at(&self, time: Time) -> impl Iterator<Item = (usize, &Fault)> {
        self.faults.iter().enumerate().filter(move |(_, f)| f.active_at(time))
    }

    /// Every start and end at or before `now` not reported yet, stamped `now` (the tick they
    /// take effect on), in index order, a start before its end. A fault whose whole window
    /// falls between two polls is reported started and ended by the same poll.
    pub fn poll(&mut self, now: Time) -> Vec<FaultEvent> {
        let mut events = Vec::new();
        for (index, (fault, phase)) in self.faults.iter().zip(self.phases.iter_mut()).enumerate() {
            if *phase == Phase::Pending && fault.start() <= now {
                *phase = Phase::Active;
                events.push(FaultEvent { time: now, index, phase: SimFaultPhase::Started });
            }
            if *phase == Phase::Active && fault.end().is_some_and(|end| end <= now) {
                *phase = Phase::Ended;
                events.push(FaultEvent { time: now, index, phase: SimFaultPhase::Ended });
            }
        }
        events
    }

    /// What the faults active at `time` do, summed over all of them.
    pub fn effects_at(&self, time: Time) -> FaultEffects {
        let mut effects = FaultEffects::default();
        let mut wind_start = None;
        for (_, fault) in self.active_at(time) {
            let since_s = time.0.saturating_sub(fault.start().0) as f64 * 1e-6;
            match &fault.kind {
                FaultKind::GpsOff => effects.gps.off = true,
                FaultKind::GpsJump { ned_m } => effects.gps.offset_ned_m += Vector3::from(*ned_m),
                FaultKind::GpsNoise { factor } => effects.gps.noise_factor *= factor,
                FaultKind::MagAnomaly { gauss } => effects.mag.added_frd_gauss += Vector3::from(*gauss),
                FaultKind::MagStuck => effects.mag.stuck = true,
                FaultKind::BaroDrift { m_s } => effects.baro.altitude_error_m += m_s * since_s,
                FaultKind::BaroStuck => effects.baro.stuck = true,
                FaultKind::GyroBias { rad_s } => effects.imu.gyro_bias_rad_s += Vector3::from(*rad_s),
                FaultKind::AccelBias { m_s2 } => effects.imu.accel_bias_m_s2 += Vector3::from(*m_s2),
                FaultKind::AccelClip => effects.imu.clip = true,
                FaultKind::ImuStop => effects.imu.stopped = true,
                FaultKind::MotorLost { motor } => effects.motors.thrust_scale[usize::from(*motor) - 1] = 0.0,
                FaultKind::MotorWeak { motor, thrust } => {
                    effects.motors.thrust_scale[usize::from(*motor) - 1] *= thrust
                }
                FaultKind::BatterySag { volts } => effects.battery.sag_v += volts,
                FaultKind::Wind { ned_m_s, gust_m_s } => {
                    // `active_at` yields in index order, so `>=` lets a later entry win a tie.
                    if wind_start.is_none_or(|start| fault.start() >= start) {
                        wind_start = Some(fault.start());
                        effects.wind = Some(WindFault { steady_ned_m_s: *ned_m_s, gust_std_m_s: *gust_m_s });
                    }
                }
                FaultKind::CameraStop => effects.camera.stop = true,
                FaultKind::CameraBlack => effects.camera.black = true,
                FaultKind::CameraFrozen => effects.camera.frozen = true,
                FaultKind::ActorPanic { .. } | FaultKind::LinkLost => {}
            }
        }
        effects
    }

    /// The `sim_fault` message of `event`.
    pub fn message(&self, event: &FaultEvent) -> SimFault {
        let fault = &self.faults[event.index];
        SimFault {
            time: event.time,
            index: u32::try_from(event.index).unwrap_or(u32::MAX),
            phase: event.phase,
            kind: fault.kind.name().to_owned(),
            values: fault.kind.to_string(),
            at_s: fault.at_s,
            for_s: fault.for_s,
        }
    }
}

/// A fault starting or ending: entry `index` of the schedule, at `time`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultEvent {
    pub time: Time,
    pub index: usize,
    pub phase: SimFaultPhase,
}

/// What the active faults do to each model, in the model's own terms. Each part is defined, and
/// applied, next to the model it changes.
#[derive(Clone, Debug, PartialEq)]
pub struct FaultEffects {
    pub gps: GpsFaults,
    pub mag: MagFaults,
    pub baro: BaroFaults,
    pub imu: ImuFaults,
    pub motors: MotorFaults,
    pub battery: BatteryFaults,
    /// The wind that replaces the world's, if any.
    pub wind: Option<WindFault>,
    pub camera: CameraFaults,
}

impl Default for FaultEffects {
    /// No fault: every offset 0, every factor 1, every switch off.
    fn default() -> FaultEffects {
        FaultEffects {
            gps: GpsFaults::default(),
            mag: MagFaults::default(),
            baro: BaroFaults::default(),
            imu: ImuFaults::default(),
            motors: MotorFaults::default(),
            battery: BatteryFaults::default(),
            wind: None,
            camera: CameraFaults::default(),
        }
    }
}

/// The stereo camera's faults (applied in `camera_actor.rs`): when several are active, stopped
/// wins over black, black over frozen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CameraFaults {
    pub stop: bool,
    pub black: bool,
    pub frozen: bool,
}

/// Reads every `[[faults]]` entry of a world file's `text` on its own, so that a bad one is
/// reported with its line (1-based) and its field (`faults[i].thrust`). A file TOML cannot parse
/// at all passes here, for the ordinary parse to report.
pub(crate) fn check_entries(text: &str) -> Result<(), (usize, InvalidParam)> {
    #[derive(Deserialize)]
    struct Entries {
        #[serde(default)]
        faults: Vec<toml::Spanned<toml::Table>>,
    }
    let Ok(entries) = toml::from_str::<Entries>(text) else { return Ok(()) };
    for (i, entry) in entries.faults.iter().enumerate() {
        let line = text[..entry.span().start].matches('\n').count() + 1;
        let within = |e: InvalidParam| (line, e.within(&format!("faults[{i}]")));
        let raw = RawFault::deserialize(toml::Value::Table(entry.get_ref().clone()))
            .map_err(|e| (line, InvalidParam::new(format!("faults[{i}]"), e.message().trim().to_owned())))?;
        Fault::try_from(raw).map_err(within)?;
    }
    Ok(())
}

/// The 1-based line of each `[[faults]]` header in a world file's `text`, in order; empty when
/// the text is not TOML.
pub fn entry_lines(text: &str) -> Vec<usize> {
    #[derive(Deserialize)]
    struct Entries {
        #[serde(default)]
        faults: Vec<toml::Spanned<toml::Table>>,
    }
    toml::from_str::<Entries>(text)
        .map(|e| e.faults.iter().map(|f| text[..f.span().start].matches('\n').count() + 1).collect())
        .unwrap_or_default()
}

/// Checks a world's faults against the vehicle that flies in it (motor numbers within the
/// frame); the field is `faults[i].motor`.
pub(crate) fn check_for_vehicle(faults: &[Fault], motor_count: usize) -> Result<(), InvalidParam> {
    for (i, fault) in faults.iter().enumerate() {
        let within = |e: InvalidParam| e.within(&format!("faults[{i}]"));
        if let Some(motor) = fault.kind.motor()
            && usize::from(motor) > motor_count
        {
            return Err(within(InvalidParam::new(
                "motor",
                format!("is {motor}, but the vehicle's frame has motors 1..={motor_count}"),
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// The faults of a world file's text (only `[[faults]]` entries), or the first error.
    fn parse(text: &str) -> Result<Vec<Fault>, (usize, InvalidParam)> {
        check_entries(text)?;
        #[derive(Deserialize)]
        struct Only {
            faults: Vec<Fault>,
        }
        Ok(toml::from_str::<Only>(text).expect("checked entries parse").faults)
    }

    fn one(entry: &str) -> Result<Fault, InvalidParam> {
        parse(&format!("[[faults]]\n{entry}\n")).map(|mut f| f.remove(0)).map_err(|(_, e)| e)
    }

    #[test]
    fn every_kind_parses_with_its_values() {
        let cases: [(&str, FaultKind); 20] = [
            ("kind = \"gps_off\"", FaultKind::GpsOff),
            (
                "kind = \"gps_jump\"\nned_m = [50.0, -2.0, 1.0]",
                FaultKind::GpsJump { ned_m: [50.0, -2.0, 1.0] },
            ),
            ("kind = \"gps_noise\"\nfactor = 4.0", FaultKind::GpsNoise { factor: 4.0 }),
            (
                "kind = \"mag_anomaly\"\ngauss = [0.3, 0.0, -0.1]",
                FaultKind::MagAnomaly { gauss: [0.3, 0.0, -0.1] },
            ),
            ("kind = \"mag_stuck\"", FaultKind::MagStuck),
            ("kind = \"baro_drift\"\nm_s = -1.0", FaultKind::BaroDrift { m_s: -1.0 }),
            ("kind = \"baro_stuck\"", FaultKind::BaroStuck),
            (
                "kind = \"gyro_bias\"\nrad_s = [0.087, 0.0, 0.0]",
                FaultKind::GyroBias { rad_s: [0.087, 0.0, 0.0] },
            ),
            ("kind = \"accel_bias\"\nm_s2 = [0.0, 0.5, 0.0]", FaultKind::AccelBias { m_s2: [0.0, 0.5, 0.0] }),
            ("kind = \"accel_clip\"", FaultKind::AccelClip),
            ("kind = \"imu_stop\"", FaultKind::ImuStop),
            ("kind = \"motor_lost\"\nmotor = 1", FaultKind::MotorLost { motor: 1 }),
            (
                "kind = \"motor_weak\"\nmotor = 2\nthrust = 0.7",
                FaultKind::MotorWeak { motor: 2, thrust: 0.7 },
            ),
            ("kind = \"battery_sag\"\nvolts = 1.5", FaultKind::BatterySag { volts: 1.5 }),
            (
                "kind = \"wind\"\nned_m_s = [12.0, 0.0, 0.0]\ngust_m_s = 4.0",
                FaultKind::Wind { ned_m_s: [12.0, 0.0, 0.0], gust_m_s: 4.0 },
            ),
            ("kind = \"camera_stop\"", FaultKind::CameraStop),
            ("kind = \"camera_black\"", FaultKind::CameraBlack),
            ("kind = \"camera_frozen\"", FaultKind::CameraFrozen),
            (
                "kind = \"actor_panic\"\nactor = \"estimator\"",
                FaultKind::ActorPanic { actor: "estimator".into() },
            ),
            ("kind = \"link_lost\"", FaultKind::LinkLost),
        ];
        for (values, kind) in cases {
            let fault = one(&format!("at_s = 12.5\nfor_s = 3.0\n{values}"))
                .unwrap_or_else(|e| panic!("{values}: {e}"));
            assert_eq!(fault, Fault { at_s: 12.5, for_s: Some(3.0), kind: kind.clone() }, "{values}");
            assert!(KINDS.contains(&kind.name()));
            // Written back, it reads the same.
            let text = toml::to_string(&std::collections::BTreeMap::from([("faults", vec![fault.clone()])]))
                .expect("serialises");
            assert_eq!(parse(&text).expect("round trip"), [fault], "{text}");
        }
        let gentle = one("at_s = 0\nkind = \"wind\"\nned_m_s = [3.0, 0.0, 0.0]").expect("gusts optional");
        assert_eq!(gentle.kind, FaultKind::Wind { ned_m_s: [3.0, 0.0, 0.0], gust_m_s: 0.0 });
        assert_eq!(gentle.for_s, None, "omitted: to the end");
    }

    #[test]
    fn bad_values_are_refused_naming_the_field() {
        let cases = [
            ("at_s = -1.0\nkind = \"gps_off\"", "at_s"),
            ("at_s = nan\nkind = \"gps_off\"", "at_s"),
            ("at_s = inf\nkind = \"gps_off\"", "at_s"),
            ("at_s = 1.0\nfor_s = -5.0\nkind = \"gps_off\"", "for_s"),
            ("at_s = 1.0\nfor_s = 0.0\nkind = \"gps_off\"", "for_s"),
            ("at_s = 1.0\nfor_s = inf\nkind = \"gps_off\"", "for_s"),
            ("at_s = 1.0\nkind = \"gps_jump\"\nned_m = [nan, 0.0, 0.0]", "ned_m"),
            ("at_s = 1.0\nkind = \"gps_jump\"", "ned_m"),
            ("at_s = 1.0\nkind = \"gps_noise\"\nfactor = -2.0", "factor"),
            ("at_s = 1.0\nkind = \"gps_noise\"\nfactor = inf", "factor"),
            ("at_s = 1.0\nkind = \"mag_anomaly\"\ngauss = [0.0, -inf, 0.0]", "gauss"),
            ("at_s = 1.0\nkind = \"baro_drift\"\nm_s = nan", "m_s"),
            ("at_s = 1.0\nkind = \"gyro_bias\"\nrad_s = [0.0, 0.0, nan]", "rad_s"),
            ("at_s = 1.0\nkind = \"accel_bias\"\nm_s2 = [inf, 0.0, 0.0]", "m_s2"),
            ("at_s = 1.0\nkind = \"motor_lost\"\nmotor = 0", "motor"),
            ("at_s = 1.0\nkind = \"motor_lost\"\nmotor = -1", "motor"),
            ("at_s = 1.0\nkind = \"motor_lost\"\nmotor = 9", "motor"),
            ("at_s = 1.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = 1.5", "thrust"),
            ("at_s = 1.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = -0.1", "thrust"),
            ("at_s = 1.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = nan", "thrust"),
            ("at_s = 1.0\nkind = \"motor_weak\"\nmotor = 1", "thrust"),
            ("at_s = 1.0\nkind = \"battery_sag\"\nvolts = -1.0", "volts"),
            ("at_s = 1.0\nkind = \"wind\"\nned_m_s = [nan, 0.0, 0.0]", "ned_m_s"),
            ("at_s = 1.0\nkind = \"wind\"\nned_m_s = [1.0, 0.0, 0.0]\ngust_m_s = -1.0", "gust_m_s"),
            ("at_s = 1.0\nkind = \"actor_panic\"\nactor = \" \"", "actor"),
            // A value of another kind, and a kind that does not exist.
            ("at_s = 1.0\nkind = \"gps_off\"\nfactor = 2.0", "factor"),
            ("at_s = 1.0\nkind = \"gps_of\"", "kind"),
        ];
        for (entry, field) in cases {
            let err = one(entry).expect_err(entry);
            assert_eq!(err.field, format!("faults[0].{field}"), "{entry}: {err}");
        }
        // Keys no kind has, and missing times, are TOML-level errors naming the entry.
        for entry in ["at_s = 1.0\nkind = \"gps_off\"\nduration_s = 2.0", "kind = \"gps_off\""] {
            let err = one(entry).expect_err(entry);
            assert_eq!(err.field, "faults[0]", "{entry}: {err}");
        }
    }

    #[test]
    fn a_bad_entry_is_located_by_its_line() {
        let text = "[home]\nlat_deg = 6.8\n\n[[faults]]\nat_s = 1.0\nkind = \"gps_off\"\n\n\
                    [[faults]]\nat_s = 2.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = 1.5\n";
        let (line, err) = parse(text).expect_err("thrust > 1");
        assert_eq!((line, err.field.as_str()), (8, "faults[1].thrust"), "{err}");
        assert_eq!(entry_lines(text), [4, 8]);
    }

    #[test]
    fn motors_outside_the_frame_are_refused_at_start() {
        let weak =
            |motor| Fault { at_s: 1.0, for_s: None, kind: FaultKind::MotorWeak { motor, thrust: 0.5 } };
        assert_eq!(check_for_vehicle(&[weak(4)], 4), Ok(()));
        assert_eq!(check_for_vehicle(&[weak(6)], 6), Ok(()));
        let err = check_for_vehicle(&[weak(1), weak(5)], 4).expect_err("quad has no motor 5");
        assert_eq!(err.field, "faults[1].motor");
        let panic =
            Fault { at_s: 1.0, for_s: None, kind: FaultKind::ActorPanic { actor: "estimator".into() } };
        assert_eq!(check_for_vehicle(&[panic], 4), Ok(()), "the runtime's to check");
    }

    fn at(s: f64) -> Time {
        Time::from_secs_f64(s)
    }

    fn fault(at_s: f64, for_s: Option<f64>, kind: FaultKind) -> Fault {
        Fault { at_s, for_s, kind }
    }

    #[test]
    fn a_fault_is_active_from_its_start_until_its_end_or_for_ever() {
        let schedule = FaultSchedule::new(&[
            fault(10.0, Some(5.0), FaultKind::GpsOff),
            fault(12.0, None, FaultKind::MagStuck),
        ]);
        let active = |s| schedule.active_at(at(s)).map(|(i, _)| i).collect::<Vec<_>>();
        assert_eq!(active(9.999_999), [] as [usize; 0]);
        assert_eq!(active(10.0), [0]);
        assert_eq!(active(12.0), [0, 1]);
        assert_eq!(active(14.999_999), [0, 1]);
        assert_eq!(active(15.0), [1], "the end is exclusive");
        assert_eq!(active(1e6), [1], "no for_s: to the end of the run");
    }

    #[test]
    fn overlapping_faults_add_multiply_or_replace() {
        let schedule = FaultSchedule::new(&[
            fault(0.0, None, FaultKind::GpsJump { ned_m: [1.0, 2.0, 3.0] }),
            fault(5.0, Some(10.0), FaultKind::GpsJump { ned_m: [10.0, 0.0, 0.0] }),
            fault(0.0, None, FaultKind::GpsNoise { factor: 2.0 }),
            fault(5.0, None, FaultKind::GpsNoise { factor: 3.0 }),
            fault(0.0, None, FaultKind::MotorWeak { motor: 2, thrust: 0.5 }),
            fault(5.0, None, FaultKind::MotorWeak { motor: 2, thrust: 0.5 }),
            fault(0.0, None, FaultKind::Wind { ned_m_s: [1.0, 0.0, 0.0], gust_m_s: 0.0 }),
            fault(5.0, Some(1.0), FaultKind::Wind { ned_m_s: [9.0, 0.0, 0.0], gust_m_s: 2.0 }),
            fault(2.0, Some(8.0), FaultKind::BaroDrift { m_s: 1.0 }),
            fault(4.0, Some(6.0), FaultKind::BaroDrift { m_s: -0.5 }),
        ]);
        let before = schedule.effects_at(at(1.0));
        assert_eq!(before.gps.offset_ned_m, Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(before.gps.noise_factor, 2.0);
        assert_eq!(before.motors.thrust_scale[..3], [1.0, 0.5, 1.0]);
        assert_eq!(before.wind.as_ref().map(|w| w.steady_ned_m_s), Some([1.0, 0.0, 0.0]));
        let during = schedule.effects_at(at(5.5));
        assert_eq!(during.gps.offset_ned_m, Vector3::new(11.0, 2.0, 3.0));
        assert_eq!(during.gps.noise_factor, 6.0);
        assert_eq!(during.motors.thrust_scale[1], 0.25);
        assert_eq!(during.wind, Some(WindFault { steady_ned_m_s: [9.0, 0.0, 0.0], gust_std_m_s: 2.0 }));
        // 3.5 s at +1 m/s and 1.5 s at −0.5 m/s.
        assert!(
            (during.baro.altitude_error_m - (3.5 - 0.75)).abs() < 1e-9,
            "{}",
            during.baro.altitude_error_m
        );
        let after = schedule.effects_at(at(6.0));
        assert_eq!(
            after.wind.as_ref().map(|w| w.steady_ned_m_s),
            Some([1.0, 0.0, 0.0]),
            "back to the earlier"
        );
        assert_eq!(schedule.effects_at(at(10.0)).baro.altitude_error_m, 0.0, "drift gone at its end");
        assert_eq!(FaultSchedule::default().effects_at(at(3.0)), FaultEffects::default());
    }

    #[test]
    fn each_start_and_end_is_reported_once() {
        let mut schedule = FaultSchedule::new(&[
            fault(1.0, Some(2.0), FaultKind::ImuStop),
            fault(0.0, None, FaultKind::CameraBlack),
            fault(1.5, Some(0.0001), FaultKind::BaroStuck),
        ]);
        let started = |i, s| FaultEvent { time: at(s), index: i, phase: SimFaultPhase::Started };
        let ended = |i, s| FaultEvent { time: at(s), index: i, phase: SimFaultPhase::Ended };
        assert_eq!(schedule.poll(at(0.0)), [started(1, 0.0)]);
        assert_eq!(schedule.poll(at(0.5)), []);
        assert_eq!(schedule.poll(at(1.0)), [started(0, 1.0)]);
        assert_eq!(schedule.poll(at(2.0)), [started(2, 2.0), ended(2, 2.0)], "a short one between polls");
        assert_eq!(schedule.poll(at(1e4)), [ended(0, 1e4)]);
        assert_eq!(schedule.poll(at(2e4)), []);
        let message = schedule.message(&ended(0, 1e4));
        assert_eq!(
            (message.kind.as_str(), message.values.as_str(), message.for_s),
            ("imu_stop", "", Some(2.0))
        );
    }

    fn any_kind() -> impl Strategy<Value = FaultKind> {
        prop_oneof![
            Just(FaultKind::GpsOff),
            (-100.0..100.0f64).prop_map(|n| FaultKind::GpsJump { ned_m: [n, 0.0, 0.0] }),
            (0.0..10.0f64).prop_map(|factor| FaultKind::GpsNoise { factor }),
            (1u8..=4, 0.0..=1.0f64).prop_map(|(motor, thrust)| FaultKind::MotorWeak { motor, thrust }),
            Just(FaultKind::ImuStop),
        ]
    }

    fn any_fault() -> impl Strategy<Value = Fault> {
        (0u32..40_000, prop::option::of(1u32..20_000), any_kind()).prop_map(|(at_ms, for_ms, kind)| Fault {
            at_s: f64::from(at_ms) * 1e-3,
            for_s: for_ms.map(|ms| f64::from(ms) * 1e-3),
            kind,
        })
    }

    proptest! {
        /// Polled at increasing times, every fault is reported started once its start has come
        /// and ended once its end has, never twice and never ended before started; and between
        /// polls it is active exactly when started and not ended.
        #[test]
        fn polling_agrees_with_the_windows(
            faults in prop::collection::vec(any_fault(), 0..8),
            mut polls in prop::collection::vec(0u64..70_000_000, 1..40),
        ) {
            polls.sort_unstable();
            let mut schedule = FaultSchedule::new(&faults);
            let mut started = vec![0u32; faults.len()];
            let mut ended = vec![0u32; faults.len()];
            let mut last = Time::ZERO;
            for &t in &polls {
                let now = Time(t);
                let events = schedule.poll(now);
                for e in &events {
                    prop_assert_eq!(e.time, now);
                    match e.phase {
                        SimFaultPhase::Started => {
                            prop_assert!(faults[e.index].start() <= now);
                            started[e.index] += 1;
                        }
                        SimFaultPhase::Ended => {
                            prop_assert!(faults[e.index].end().is_some_and(|end| end <= now));
                            prop_assert_eq!(started[e.index], 1);
                            ended[e.index] += 1;
                        }
                    }
                }
                for (i, f) in faults.iter().enumerate() {
                    prop_assert!(started[i] <= 1 && ended[i] <= 1);
                    prop_assert_eq!(started[i] == 1, f.start() <= now);
                    prop_assert_eq!(ended[i] == 1, f.end().is_some_and(|end| end <= now));
                    let active = schedule.active_at(now).any(|(j, _)| j == i);
                    prop_assert_eq!(active, started[i] == 1 && ended[i] == 0);
                    prop_assert_eq!(active, f.start() <= now && f.end().is_none_or(|end| now < end));
                }
                last = now;
            }
            prop_assert!(schedule.poll(last).is_empty(), "nothing twice");
        }

        /// The effects depend only on the faults active at the time: none active is no effect,
        /// and a motor's scale is the product of its active `motor_weak` thrusts.
        #[test]
        fn effects_are_those_of_the_active_faults(
            faults in prop::collection::vec(any_fault(), 0..8),
            t in 0u64..70_000_000,
        ) {
            let schedule = FaultSchedule::new(&faults);
            let now = Time(t);
            let effects = schedule.effects_at(now);
            let active: Vec<&Fault> = faults.iter().filter(|f| f.active_at(now)).collect();
            if active.is_empty() {
                prop_assert_eq!(&effects, &FaultEffects::default());
            }
            for motor in 1..=4u8 {
                let expected: f64 = active
                    .iter()
                    .filter_map(|f| match f.kind {
                        FaultKind::MotorWeak { motor: m, thrust } if m == motor => Some(thrust),
                        _ => None,
                    })
                    .product();
                prop_assert!((effects.motors.thrust_scale[usize::from(motor) - 1] - expected).abs() < 1e-12);
            }
            prop_assert_eq!(effects.imu.stopped, active.iter().any(|f| f.kind == FaultKind::ImuStop));
            prop_assert_eq!(effects.gps.off, active.iter().any(|f| f.kind == FaultKind::GpsOff));
        }
    }
}
