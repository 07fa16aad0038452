//! A flight log, whichever kind: a PX4 ULog or a Kestrel MCAP log, read into one shape — the
//! sensor samples the vehicle measured (what an estimator runs on) and the estimate and ground
//! truth it logged beside them (what a replay is compared with). This is the one way in for
//! both users of recorded flights: the `log_replay` actor publishes a log's sensor topics into a
//! graph, and `kestrel replay` runs the EKF over them (`crate::replay`).
//!
//! The format is told by the file's first bytes, not its name. Every sample comes out as our own
//! message type, stamped as ours are — with the time it was *measured* — and paired with the log
//! time at which the vehicle received it, so a replay reproduces each sensor's lag.

mod error;
mod kestrel_log;
mod px4;
pub mod replayable;
mod ulog;

use std::path::{Path, PathBuf};

use kestrel_estimator::EkfParams;
use kestrel_proto::Time;
use kestrel_proto::geo::Geodetic;

pub use error::FlightLogError;
pub use replayable::{Kind, Replayed};
pub use ulog::UlogDamage;

use crate::recorder::LogReader;

/// The kinds of flight log there are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// PX4's ULog (`.ulg`).
    Ulog,
    /// Kestrel's own MCAP log (`kestrel run --record`).
    Mcap,
}

/// A flight log read into our messages.
pub struct FlightLog {
    path: PathBuf,
    format: Format,
    /// Every topic of the log with the type it holds, in the log's order.
    topics: Vec<LogTopic>,
    /// The topics that carry sensor samples, with their samples in log-time order.
    sensors: Vec<SensorTopic>,
    /// The log's own estimate: PX4 EKF2's, or the recorded `nav_state`.
    estimate: Option<Reference>,
    /// The simulator's ground truth, when a simulator wrote the log.
    truth: Option<Reference>,
    /// Estimator settings in force when the log was written.
    settings: LoggedSettings,
    /// Where the log stops being readable, when it does before its end.
    damage: Option<String>,
}

/// A topic of a log and the type it holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogTopic {
    pub name: String,
    /// The type's name as the log gives it: a schema name (`kestrel.ImuSample`) or, for a
    /// ULog, the topic's own name.
    pub type_name: String,
}

/// One topic's sensor samples.
#[derive(Clone, Debug)]
pub struct SensorTopic {
    pub name: String,
    pub kind: Kind,
    /// (log time the vehicle received it, the sample stamped with its measurement time).
    pub samples: Vec<(Time, Replayed)>,
}

/// A logged track of estimates (or truth) to compare a replay with.
#[derive(Clone, Debug)]
pub struct Reference {
    /// What it is, for people: `EKF2`, `the recorded nav_state`, `ground truth`.
    pub label: &'static str,
    pub samples: Vec<ReferenceSample>,
    /// Whether heights compare only up to a constant: EKF2 keeps its own height datum (its
    /// origin's altitude, reset on its own schedule), so its height is compared after removing
    /// the difference at the first instant both filters have one.
    pub align_height: bool,
}

/// One logged estimate (or truth) at the instant it describes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceSample {
    pub time: Time,
    /// Body-to-NED attitude `[w, x, y, z]`, when logged near this instant.
    pub attitude: Option<[f64; 4]>,
    pub position: Option<ReferencePosition>,
}

/// A logged position and which parts of it the logger held valid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferencePosition {
    pub place: Place,
    pub horizontal_valid: bool,
    pub vertical_valid: bool,
}

/// Where a logged position is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Place {
    /// North, east, down (m) from the logger's own origin, when it had one on WGS-84.
    Local { ned_m: [f64; 3], origin: Option<Geodetic> },
    /// A point on WGS-84 (the simulator's truth).
    Global(Geodetic),
}

/// Estimator settings a log records, which a replay must use to see the sensors as the vehicle
/// did: PX4 stamps GPS with its arrival and leaves the lag to `EKF2_GPS_DELAY`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoggedSettings {
    pub gps_lag_s: Option<f64>,
    pub baro_lag_s: Option<f64>,
    pub mag_lag_s: Option<f64>,
    pub mag_declination_deg: Option<f64>,
}

impl LoggedSettings {
    /// `params` with the logged settings in place of the caller's.
    pub fn apply(&self, mut params: EkfParams) -> EkfParams {
        let set = |target: &mut f64, value: Option<f64>| {
            if let Some(v) = value {
                *target = v;
            }
        };
        set(&mut params.gps_lag_s, self.gps_lag_s);
        set(&mut params.baro_lag_s, self.baro_lag_s);
        set(&mut params.mag_lag_s, self.mag_lag_s);
        set(&mut params.mag_declination_deg, self.mag_declination_deg);
        params
    }
}

impl FlightLog {
    /// Reads the log at `path`, whichever format its first bytes say it is.
    pub fn open(path: &Path) -> Result<FlightLog, FlightLogError> {
        let bytes =
            std::fs::read(path).map_err(|source| FlightLogError::Read { path: path.to_owned(), source })?;
        if bytes.starts_with(&ulog::MAGIC) {
            px4::read(path, &bytes)
        } else if bytes.starts_with(mcap::MAGIC) {
            kestrel_log::read(LogReader::from_bytes(path, bytes)?)
        } else {
            Err(FlightLogError::NotALog { path: path.to_owned(), bytes: bytes.len() as u64 })
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn format(&self) -> Format {
        self.format
    }

    /// Every topic of the log.
    pub fn topics(&self) -> &[LogTopic] {
        &self.topics
    }

    /// The sensor topics, in the log's order.
    pub fn sensors(&self) -> &[SensorTopic] {
        &self.sensors
    }

    /// The sensor topic `name`; a topic the log lacks is named with those it has, a topic that
    /// holds no sensor samples with the type it holds.
    pub fn sensor(&self, name: &str) -> Result<&SensorTopic, FlightLogError> {
        if let Some(topic) = self.sensors.iter().find(|t| t.name == name) {
            return Ok(topic);
        }
        let path = self.path.clone();
        match self.topics.iter().find(|t| t.name == name) {
            Some(topic) => Err(FlightLogError::NotReplayable {
                path,
                topic: name.to_owned(),
                found: topic.type_name.clone(),
                replayable: self.replayable_names(),
            }),
            None => Err(FlightLogError::UnknownTopic {
                path,
                topic: name.to_owned(),
                available: self.topics.iter().map(|t| t.name.clone()).collect(),
            }),
        }
    }

    /// The log's own estimate, and its ground truth.
    pub fn references(&self) -> (Option<&Reference>, Option<&Reference>) {
        (self.estimate.as_ref(), self.truth.as_ref())
    }

    pub fn settings(&self) -> LoggedSettings {
        self.settings
    }

    /// What was lost, when the log is damaged or cut short (everything before it was read).
    pub fn damage(&self) -> Option<&str> {
        self.damage.as_deref()
    }

    /// What a topic must hold to be replayed, in this format's words.
    fn replayable_names(&self) -> Vec<String> {
        match self.format {
            Format::Mcap => Kind::ALL.map(|k| k.type_name().to_owned()).to_vec(),
            Format::Ulog => px4::SENSOR_TOPICS.iter().map(|t| (*t).to_owned()).collect(),
        }
    }
}

/// The item of `items` (in time order) whose time is nearest `t_us`, if within `max_gap_us`.
pub fn nearest<T>(items: &[T], time: impl Fn(&T) -> Time, t_us: u64, max_gap_us: u64) -> Option<&T> {
    let gap = |k: usize| time(&items[k]).as_micros().abs_diff(t_us);
    let i = items.partition_point(|item| time(item).as_micros() < t_us);
    [i.checked_sub(1), (i < items.len()).then_some(i)]
        .into_iter()
        .flatten()
        .filter(|&k| gap(k) <= max_gap_us)
        .min_by_key(|&k| gap(k))
        .map(|k| &items[k])
}
