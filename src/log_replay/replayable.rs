//! The message types a log can be replayed as, read from a log by the schema name each topic
//! was recorded under, and published on one output port per type.
//!
//! These are the messages a vehicle *measures* — the sensors' (`ImuSample`, `GpsFix`,
//! `BaroSample`, `MagSample`) and the battery's (`BatteryStatus`) — i.e. what the simulator or
//! the hardware drivers publish. Anything the graph computes from them (`NavState`, setpoints)
//! is what a replay exists to recompute, so it is not replayed.

use kestrel_proto::messages::{BaroSample, BatteryStatus, GpsFix, ImuSample, MagSample};
use kestrel_proto::{Message, Publisher, Setup, Time};

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

/// The replay's output ports: one publisher per kind being replayed.
pub struct Outputs {
    imu: Option<Publisher<ImuSample>>,
    gps: Option<Publisher<GpsFix>>,
    baro: Option<Publisher<BaroSample>>,
    mag: Option<Publisher<MagSample>>,
    battery: Option<Publisher<BatteryStatus>>,
}

impl Outputs {
    /// Declares an output port for each kind in `kinds`, and only those: routing a port whose
    /// type is not replayed is then a config error that lists the ports there are.
    pub fn declare<I>(kinds: &[Kind], setup: &mut impl Setup<I>) -> Outputs {
        let has = |k: Kind| kinds.contains(&k);
        Outputs {
            imu: has(Kind::Imu).then(|| setup.output(Kind::Imu.port())),
            gps: has(Kind::Gps).then(|| setup.output(Kind::Gps.port())),
            baro: has(Kind::Baro).then(|| setup.output(Kind::Baro.port())),
            mag: has(Kind::Mag).then(|| setup.output(Kind::Mag.port())),
            battery: has(Kind::Battery).then(|| setup.output(Kind::Battery.port())),
        }
    }

    /// Publishes `message` on its kind's port (declared for every kind the schedule holds).
    pub fn publish(&self, message: Replayed) {
        match message {
            Replayed::Imu(m) => publish(&self.imu, m),
            Replayed::Gps(m) => publish(&self.gps, m),
            Replayed::Baro(m) => publish(&self.baro, m),
            Replayed::Mag(m) => publish(&self.mag, m),
            Replayed::Battery(m) => publish(&self.battery, m),
        }
    }
}

fn publish<T: Message>(port: &Option<Publisher<T>>, message: T) {
    if let Some(port) = port {
        port.publish(message);
    }
}
