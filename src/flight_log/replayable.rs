//! The message types a log can be replayed as: a Kestrel log's topics are told by the schema
//! name each was recorded under, a ULog's by PX4's topic names (`super::px4`). The `log_replay`
//! actor publishes each kind on one output port.
//!
//! These are the messages a vehicle *measures* — the sensors' (`ImuSample`, `GpsFix`,
//! `BaroSample`, `MagSample`) and the battery's (`BatteryStatus`) — i.e. what the simulator or
//! the hardware drivers publish. Anything the graph computes from them (`NavState`, setpoints)
//! is what a replay exists to recompute, so it is not replayed.

use kestrel_proto::messages::{BaroSample, BatteryStatus, GpsFix, ImuSample, MagSample};
use kestrel_proto::{Message, Time};

use crate::recorder::{LogReader, RecorderError};

/// A replayable message type, with the output port it goes out on (named as the simulator's
/// and the drivers' outputs are, so a replay drops into a graph in their place).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    Imu,
    Gps,
    Baro,
    Mag,
    Battery,
}

impl Kind {
    /// Every kind, in port order.
    pub const ALL: [Kind; 5] = [Kind::Imu, Kind::Gps, Kind::Baro, Kind::Mag, Kind::Battery];

    /// The kind whose schema name (as recorded) is `type_name`.
    pub fn of_type(type_name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.type_name() == type_name)
    }

    /// The message type's schema name, e.g. `kestrel.ImuSample`.
    pub fn type_name(self) -> &'static str {
        match self {
            Kind::Imu => ImuSample::TYPE_NAME,
            Kind::Gps => GpsFix::TYPE_NAME,
            Kind::Baro => BaroSample::TYPE_NAME,
            Kind::Mag => MagSample::TYPE_NAME,
            Kind::Battery => BatteryStatus::TYPE_NAME,
        }
    }

    /// The output port messages of this kind are published on.
    pub fn port(self) -> &'static str {
        match self {
            Kind::Imu => "imu",
            Kind::Gps => "gps",
            Kind::Baro => "baro",
            Kind::Mag => "mag",
            Kind::Battery => "battery",
        }
    }

    /// Every message on `topic`, decoded as this kind, with its log time.
    pub fn read(self, log: &LogReader, topic: &str) -> Result<Vec<(Time, Replayed)>, RecorderError> {
        match self {
            Kind::Imu => read_as(log, topic, Replayed::Imu),
            Kind::Gps => read_as(log, topic, Replayed::Gps),
            Kind::Baro => read_as(log, topic, Replayed::Baro),
            Kind::Mag => read_as(log, topic, Replayed::Mag),
            Kind::Battery => read_as(log, topic, Replayed::Battery),
        }
    }
}

/// One recorded message, ready to publish.
#[derive(Clone, Debug, PartialEq)]
pub enum Replayed {
    Imu(ImuSample),
    Gps(GpsFix),
    Baro(BaroSample),
    Mag(MagSample),
    Battery(BatteryStatus),
}

fn read_as<T: Message>(
    log: &LogReader,
    topic: &str,
    wrap: fn(T) -> Replayed,
) -> Result<Vec<(Time, Replayed)>, RecorderError> {
    Ok(log.read::<T>(topic)?.into_iter().map(|r| (r.log_time, wrap(r.message))).collect())
}
