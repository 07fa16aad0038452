//! The `log_replay` actor's output ports: one publisher per kind of sample being replayed.

use kestrel_proto::messages::{BaroSample, BatteryStatus, GpsFix, ImuSample, MagSample};
use kestrel_proto::{Message, Publisher, Setup};

use crate::flight_log::{Kind, Replayed};

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
