//! What a fault is: a [`FaultKind`] with its values, from a start for a duration, and the checks
//! of both (the error names the field). Read from the world file through [`super::entry`].

use std::fmt;

use kestrel_proto::Time;
use kestrel_proto::messages::MAX_MOTORS;
use serde::{Deserialize, Serialize};

use super::entry::RawFault;
use crate::error::InvalidParam;

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
    /// `camera_glare region = [x0, y0, x1, y1], intensity, lens`: veiling glare (the sun in or
    /// near the view, thesis §4.2.4) over the rectangle of columns `x0..x1` and rows `y0..y1`,
    /// given as shares of the image width and height (0..1, top-left origin): each pixel there
    /// becomes `p + intensity·(255 − p)` (intensity 0..1; 1 washes the region out to white). On
    /// `lens` `"left"`, `"right"` or `"both"` (default both).
    CameraGlare { region: [f64; 4], intensity: f64, lens: CameraLens },
    /// `camera_capped lens`: lens `"left"` or `"right"` sees black (every pixel 0, a lens cap)
    /// while the other still sees.
    CameraCapped { lens: CameraLens },
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

/// Which lens of the stereo camera a camera fault acts on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraLens {
    Left,
    Right,
    Both,
}

impl CameraLens {
    /// The world file's spelling.
    pub fn name(self) -> &'static str {
        match self {
            CameraLens::Left => "left",
            CameraLens::Right => "right",
            CameraLens::Both => "both",
        }
    }

    /// `"left"`, `"right"` or `"both"`; anything else is refused naming `lens`.
    pub fn parse(name: &str) -> Result<CameraLens, InvalidParam> {
        match name {
            "left" => Ok(CameraLens::Left),
            "right" => Ok(CameraLens::Right),
            "both" => Ok(CameraLens::Both),
            other => Err(InvalidParam::new(
                "lens",
                format!("must be \"left\", \"right\" or \"both\", got {other:?}"),
            )),
        }
    }

    /// Whether the fault acts on the left (`false`: right) image.
    pub fn covers(self, left: bool) -> bool {
        match self {
            CameraLens::Left => left,
            CameraLens::Right => !left,
            CameraLens::Both => true,
        }
    }
}

/// Every kind's `kind` spelling, in the order of the world file documentation.
pub const KINDS: [&str; 22] = [
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
    "camera_glare",
    "camera_capped",
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
            FaultKind::CameraGlare { .. } => "camera_glare",
            FaultKind::CameraCapped { .. } => "camera_capped",
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
            FaultKind::CameraGlare { region, intensity, .. } => {
                let [x0, y0, x1, y1] = *region;
                let share = |v: f64| v.is_finite() && (0.0..=1.0).contains(&v);
                if !(region.iter().all(|&v| share(v)) && x0 < x1 && y0 < y1) {
                    return Err(InvalidParam::new(
                        "region",
                        format!(
                            "must be [x0, y0, x1, y1] shares of the image in 0..=1 with x0 < x1 and y0 < y1, got {region:?}"
                        ),
                    ));
                }
                if !share(*intensity) {
                    return Err(InvalidParam::new(
                        "intensity",
                        format!("must be within 0..=1, got {intensity}"),
                    ));
                }
                Ok(())
            }
            FaultKind::CameraCapped { lens: CameraLens::Both } => Err(InvalidParam::new(
                "lens",
                "must be \"left\" or \"right\" (both lenses capped is camera_black)",
            )),
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
            FaultKind::CameraGlare { region, intensity, lens } => write!(
                f,
                "region = [{}, {}, {}, {}], intensity = {intensity}, lens = \"{}\"",
                region[0],
                region[1],
                region[2],
                region[3],
                lens.name()
            ),
            FaultKind::CameraCapped { lens } => write!(f, "lens = \"{}\"", lens.name()),
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
