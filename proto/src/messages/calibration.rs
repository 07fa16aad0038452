//! A sensor calibration driven from the ground station, between the link, the
//! calibration actor that owns the session, the sensor source that feeds it raw samples and moves
//! the vehicle (the simulator; a person on hardware), and the commander's pre-arm check.
//!
//! * link ─`CalibrationCommand`─► calibration (each answered by a `CalibrationEvent::Answer`, the
//!   command's one COMMAND_ACK);
//! * calibration ─`CalibrationMotion`─► sensor source ─`imu_raw`, `mag_raw`─► calibration (raw
//!   board-frame samples flow only while a motion is asked for);
//! * calibration ─`CalibrationEvent`─► link (STATUSTEXT, MAG_CAL_PROGRESS / MAG_CAL_REPORT,
//!   COMMAND_LONG(ACCELCAL_VEHICLE_POS), and the results, which the link sets as parameters);
//! * calibration ─`CalibrationStatus`─► commander (which required steps are missing).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// One calibration a ground station can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CalibrationStep {
    /// Gyro offsets at rest (PREFLIGHT_CALIBRATION param1 = 1).
    Gyro,
    /// Six-orientation accelerometer offsets and scales (param5 = 1).
    Accel,
    /// Board level trim (param5 = 2).
    Level,
    /// Compass hard and soft iron (DO_START_MAG_CAL); "compass" in config files.
    #[serde(rename = "compass")]
    Mag,
    /// Each ESC's pulse range from a ramp with speed feedback (param7 = 1), props off; its
    /// result is the motor outputs' `SERVOn_MIN`/`SERVOn_MAX`, so it cannot be `required`.
    Esc,
}

impl CalibrationStep {
    pub const ALL: [CalibrationStep; 5] = [
        CalibrationStep::Gyro,
        CalibrationStep::Accel,
        CalibrationStep::Level,
        CalibrationStep::Mag,
        CalibrationStep::Esc,
    ];

    /// The pre-arm refusal while this step is required and missing, in ArduPilot's words where
    /// ArduPilot has the check ("3D Accel calibration needed", "Compass not calibrated").
    pub fn prearm_text(self) -> &'static str {
        match self {
            CalibrationStep::Gyro => "PreArm: Gyro calibration needed",
            CalibrationStep::Accel => "PreArm: 3D Accel calibration needed",
            CalibrationStep::Level => "PreArm: Level calibration needed",
            CalibrationStep::Mag => "PreArm: Compass not calibrated",
            CalibrationStep::Esc => "PreArm: ESC calibration needed",
        }
    }

    /// The name used in config files and STATUSTEXT.
    pub fn name(self) -> &'static str {
        match self {
            CalibrationStep::Gyro => "gyro",
            CalibrationStep::Accel => "accel",
            CalibrationStep::Level => "level",
            CalibrationStep::Mag => "compass",
            CalibrationStep::Esc => "ESC",
        }
    }
}

/// What the ground station asked for.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CalibrationRequest {
    /// Start a calibration. For the compass: `autosave` keeps a good fit without
    /// DO_ACCEPT_MAG_CAL, `delay_s` waits before sampling (DO_START_MAG_CAL param3, param4).
    Start { step: CalibrationStep, autosave: bool, delay_s: f64 },
    /// The vehicle stands in the orientation it asked for (COMMAND_LONG ACCELCAL_VEHICLE_POS
    /// from the ground station; `position` is ACCELCAL_VEHICLE_POS 1..=6).
    AccelPosition { position: u32 },
    /// DO_ACCEPT_MAG_CAL: keep the compass fit reported.
    MagAccept,
    /// DO_CANCEL_MAG_CAL: stop the compass calibration and keep the old values.
    MagCancel,
    /// PREFLIGHT_CALIBRATION with every parameter 0 (ArduPilot's cancel): stop whatever
    /// calibration runs, keep the old values, motors to the disarmed pulse.
    Cancel,
}

/// A [`CalibrationRequest`] the link numbered: the answer with the same `id` becomes its
/// COMMAND_ACK.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CalibrationCommand {
    pub time: Time,
    pub id: u32,
    pub request: CalibrationRequest,
}
crate::impl_message!(CalibrationCommand);

/// How the vehicle must be handled for the running calibration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// No calibration: the sensor source publishes no raw samples.
    #[default]
    Idle,
    /// Standing still and level on its legs (gyro, level).
    Level,
    /// Turned slowly through every orientation (compass).
    Tumble,
    /// Set down still in ACCELCAL_VEHICLE_POS `position` (1 level .. 6 upside down).
    Place { position: u32 },
    /// Standing on its legs with the propellers taken off (ESC range calibration): the motors
    /// turn and push nothing. No raw samples are needed.
    PropsOff,
}

impl Motion {
    /// Whether the sensor source publishes raw samples for this motion.
    pub fn wants_raw_samples(self) -> bool {
        !matches!(self, Motion::Idle | Motion::PropsOff)
    }
}

/// The motion the calibration asks for now.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CalibrationMotion {
    pub time: Time,
    pub motion: Motion,
}
crate::impl_message!(CalibrationMotion);

/// How much a text matters (MAV_SEVERITY's INFO, WARNING, CRITICAL).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    Info,
    Warning,
    Critical,
}

/// Where a compass calibration is (MAG_CAL_STATUS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MagCalState {
    WaitingToStart,
    Collecting,
    Success,
    Failed,
}

/// A compass fit as MAG_CAL_REPORT carries it, in ArduPilot's parameter form (offsets added to
/// the reading, then the symmetric correction matrix applied).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MagReport {
    pub state: MagCalState,
    /// RMS residual (milligauss).
    pub fitness_mgauss: f64,
    pub offsets_mgauss: [f64; 3],
    pub diagonal: [f64; 3],
    /// xy, xz, yz.
    pub off_diagonal: [f64; 3],
    /// Saved without waiting for DO_ACCEPT_MAG_CAL.
    pub autosaved: bool,
    /// Why it failed (empty on success).
    pub reason: String,
}

/// What the calibration tells the ground station and the link.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CalibrationUpdate {
    /// The answer to command `id`: `None` taken, otherwise why not.
    Answer { id: u32, refusal: Option<String> },
    /// A line for the operator (STATUSTEXT).
    Text { severity: Severity, text: String },
    /// Ask the ground station to place the vehicle in ACCELCAL_VEHICLE_POS `position`, or tell
    /// it the six-position calibration ended (ACCELCAL_VEHICLE_POS_SUCCESS / _FAILED).
    AccelPosition { position: u32 },
    /// MAG_CAL_PROGRESS: `completion_pct` and the directions seen (bit per region).
    MagProgress { completion_pct: u8, completion_mask: [u8; 10], attempt: u8 },
    /// MAG_CAL_REPORT.
    MagReport(MagReport),
    /// Parameters to set and persist (the link sets them as a PARAM_SET would).
    Results { params: Vec<(String, f64)> },
}

/// One [`CalibrationUpdate`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CalibrationEvent {
    pub time: Time,
    pub update: CalibrationUpdate,
}
crate::impl_message!(CalibrationEvent);

/// What the commander's pre-arm check needs: required steps without a result, and a running
/// session (no arming while the vehicle is being turned over).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct CalibrationStatus {
    pub time: Time,
    pub missing: Vec<CalibrationStep>,
    pub running: Option<CalibrationStep>,
}
crate::impl_message!(CalibrationStatus);

/// ACCELCAL_VEHICLE_POS_SUCCESS / _FAILED (ArduPilot's dialect).
pub const ACCELCAL_SUCCESS: u32 = 16_777_215;
pub const ACCELCAL_FAILED: u32 = 16_777_216;
