//! The RCIO actor: Navio2's RC input and power module, read from the `rcio` driver's sysfs
//! files by timers — sticks on `manual_control` (50 Hz), the battery on `battery` (10 Hz) —
//! with a `health` report every second.
//!
//! The reads are short sysfs reads, done inline in the handler. A failed read is counted and
//! skipped; only a run of them (the co-processor gone) fails the
//! actor. While the driver says the receiver is not connected, or a mapped channel reads 0 µs
//! (no pulses), no sticks are published and the commander's RC-loss timeout acts.

use std::path::PathBuf;
use std::time::Duration;

use kestrel_proto::messages::{BatteryStatus, ManualControl, SensorHealth};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::health::{Counters, HealthWindow};
use crate::rcio::{BatteryMonitor, PowerModule, RcioError, RcioSysfs};
use crate::sbus::StickMap;

/// Consecutive failed polls after which the actor fails (one second of RC polls).
const MAX_CONSECUTIVE_ERRORS: u32 = 50;

/// `[actors.rcio.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RcioActorParams {
    /// The driver's sysfs directory (a temporary directory in tests).
    pub root: PathBuf,
    /// RC input polls per second (Hz).
    pub rc_rate_hz: f64,
    /// Which channel is which stick, in pulse widths (µs).
    pub sticks: StickMap,
    /// Battery polls per second (Hz).
    pub battery_rate_hz: f64,
    pub power_module: PowerModule,
}

impl Default for RcioActorParams {
    fn default() -> RcioActorParams {
        RcioActorParams {
            root: PathBuf::from("/sys/kernel/rcio"),
            rc_rate_hz: 50.0,
            sticks: StickMap::pulse_width_us(),
            battery_rate_hz: 10.0,
            power_module: PowerModule::default(),
        }
    }
}

/// What the RCIO actor handles.
#[derive(Debug)]
pub enum RcioInput {
    /// Timer `rc`.
    Rc(Time),
    /// Timer `battery_poll` (`battery` is the output).
    Battery(Time),
    /// Timer `health_report`, every second; a port name of its own, apart from the `health` output.
    Health(Time),
}

/// The RCIO actor. Outputs: `manual_control`, `battery`, `health`.
pub struct RcioActor {
    rcio: RcioSysfs,
    sticks: StickMap,
    channels: usize,
    module: PowerModule,
    monitor: BatteryMonitor,
    counters: Counters,
    consecutive_errors: u32,
    window: Option<HealthWindow>,
    manual_out: Publisher<ManualControl>,
    battery_out: Publisher<BatteryStatus>,
    health_out: Publisher<SensorHealth>,
}

fn period(name: &str, hz: f64) -> Result<Duration, ActorError> {
    kestrel_proto::timing::period_of_rate(name, hz, 0.0, 1000.0)
}

impl RcioActor {
    /// Reads the mapped RC channels; `None` while the receiver delivers nothing.
    fn read_sticks(&self, now: Time) -> Result<Option<ManualControl>, RcioError> {
        if self.rcio.rc_connected()? == Some(false) {
            return Ok(None);
        }
        let channels =
            (0..self.channels).map(|i| self.rcio.rc_channel_us(i)).collect::<Result<Vec<u16>, _>>()?;
        Ok((!channels.contains(&0)).then(|| self.sticks.sticks(&channels, now)))
    }

    fn read_battery(&mut self, now: Time) -> Result<BatteryStatus, RcioError> {
        let voltage = self.rcio.adc_mv(self.module.voltage_channel)?;
        let current = self.rcio.adc_mv(self.module.current_channel)?;
        Ok(self.monitor.update(voltage, current, now))
    }

    /// Counts a failed read; fails once they run on.
    fn failed(&mut self, e: RcioError) -> Result<(), ActorError> {
        self.counters.errors += 1;
        self.consecutive_errors += 1;
        tracing::warn!("RCIO read failed: {e}");
        if self.consecutive_errors >= MAX_CONSECUTIVE_ERRORS {
            return Err(ActorError::Failed(format!(
                "{} consecutive RCIO reads failed, last: {e}",
                self.consecutive_errors
            )));
        }
        Ok(())
    }
}

impl Actor for RcioActor {
    type Params = RcioActorParams;
    type Input = RcioInput;

    fn build(params: &RcioActorParams, setup: &mut impl Setup<RcioInput>) -> Result<RcioActor, ActorError> {
        let rc_period = period("rc_rate_hz", params.rc_rate_hz)?;
        let battery_period = period("battery_rate_hz", params.battery_rate_hz)?;
        let root = setup.config_dir().join(&params.root);
        setup.claim_device(&root)?;
        let rcio = RcioSysfs::new(&root);
        let channels = params.sticks.highest_channel();
        // Every file the actor will read must be there now: a missing driver or a wrong
        // channel is a start-up error naming the file, not a stream of failed polls.
        let check = || -> Result<(), RcioError> {
            for i in 0..channels {
                rcio.rc_channel_us(i)?;
            }
            rcio.adc_mv(params.power_module.voltage_channel)?;
            rcio.adc_mv(params.power_module.current_channel)?;
            Ok(())
        };
        check().map_err(|e| ActorError::Failed(format!("Navio2 RCIO: {e}")))?;
        setup.timer("rc", rc_period, RcioInput::Rc);
        setup.timer("battery_poll", battery_period, RcioInput::Battery);
        setup.timer("health_report", Duration::from_secs(1), RcioInput::Health);
        Ok(RcioActor {
            rcio,
            sticks: params.sticks.clone(),
            channels,
            module: params.power_module.clone(),
            monitor: BatteryMonitor::new(params.power_module.clone()),
            counters: Counters::default(),
            consecutive_errors: 0,
            window: None,
            manual_out: setup.output("manual_control"),
            battery_out: setup.output("battery"),
            health_out: setup.output("health"),
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let root = self.rcio.root().display().to_string();
        self.window = Some(HealthWindow::new(ctx.name(), &root, ctx.now()));
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: RcioInput) -> Result<(), ActorError> {
        match input {
            RcioInput::Rc(now) => match self.read_sticks(now) {
                Ok(sticks) => {
                    self.consecutive_errors = 0;
                    if let Some(sticks) = sticks {
                        self.counters.published += 1;
                        self.manual_out.publish(sticks);
                    }
                }
                Err(e) => self.failed(e)?,
            },
            RcioInput::Battery(now) => match self.read_battery(now) {
                Ok(battery) => {
                    self.consecutive_errors = 0;
                    self.battery_out.publish(battery);
                }
                Err(e) => self.failed(e)?,
            },
            RcioInput::Health(now) => {
                if let Some(window) = &mut self.window {
                    self.health_out.publish(window.report(now, self.counters));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::testing::{TestSetup, ready};

    use super::*;
    use crate::rcio::sysfs::tests::FakeRcio;

    fn navio2(name: &str) -> FakeRcio {
        let fake = FakeRcio::new(name);
        for (ch, us) in [1500, 1500, 1000, 1500, 1000, 1000, 1000, 1000].iter().enumerate() {
            fake.set(&format!("rcin/ch{ch}"), &format!("{us}\n"));
        }
        for (ch, mv) in [4950, 5020, 1100, 588, 0, 0].iter().enumerate() {
            fake.set(&format!("adc/ch{ch}"), &format!("{mv}\n"));
        }
        fake
    }

    #[test]
    fn publishes_sticks_and_battery_from_sysfs() {
        let fake = navio2("actor");
        let params = RcioActorParams { root: fake.root.clone(), ..RcioActorParams::default() };
        let mut setup = TestSetup::new("rcio", "/");
        let mut actor = RcioActor::build(&params, &mut setup).expect("build");
        assert_eq!(
            setup.timers(),
            [
                ("rc", Duration::from_millis(20)),
                ("battery_poll", Duration::from_millis(100)),
                ("health_report", Duration::from_secs(1))
            ]
        );
        let ctx = setup.context();
        ready(actor.start(&ctx)).expect("start");
        fake.set("rcin/ch0", "2000\n");
        fake.set("rcin/ch2", "1500\n");
        ready(actor.handle(&ctx, setup.tick("rc", Time::from_micros(20_000)))).expect("rc");
        let sticks: Vec<ManualControl> = setup.published("manual_control");
        assert_eq!((sticks[0].roll, sticks[0].pitch, sticks[0].throttle), (1.0, 0.0, 0.5));
        ready(actor.handle(&ctx, setup.tick("battery_poll", Time::from_micros(100_000)))).expect("battery");
        let battery: Vec<BatteryStatus> = setup.published("battery");
        assert!((battery[0].voltage_v - 12.43).abs() < 1e-9 && (battery[0].current_a - 9.996).abs() < 1e-9);

        // Receiver off: no sticks; a vanished file: counted, not fatal.
        fake.set("rcin/connected", "0\n");
        ready(actor.handle(&ctx, setup.tick("rc", Time::from_micros(40_000)))).expect("rc");
        fake.set("rcin/connected", "1\n");
        std::fs::remove_file(fake.root.join("rcin/ch3")).expect("remove");
        ready(actor.handle(&ctx, setup.tick("rc", Time::from_micros(60_000))))
            .expect("one failure is not fatal");
        assert_eq!(setup.count("manual_control"), 1);
        ready(actor.handle(&ctx, setup.tick("health_report", Time::from_micros(1_000_000)))).expect("health");
        let health: Vec<SensorHealth> = setup.published("health");
        assert_eq!((health[0].errors, health[0].rate_hz), (1, 1.0));
        assert_eq!(health[0].device, fake.root.display().to_string());
    }

    #[test]
    fn a_missing_driver_or_channel_names_the_file() {
        let params =
            RcioActorParams { root: "/sys/kernel/rcio-kestrel-none".into(), ..RcioActorParams::default() };
        let err = RcioActor::build(&params, &mut TestSetup::new("rcio", "/")).err().expect("no driver");
        assert!(err.to_string().contains("/sys/kernel/rcio-kestrel-none/rcin/ch0"), "{err}");
        let fake = navio2("missing");
        let mut params = RcioActorParams { root: fake.root.clone(), ..RcioActorParams::default() };
        params.power_module.current_channel = 7;
        let err = RcioActor::build(&params, &mut TestSetup::new("rcio", "/")).err().expect("no adc ch7");
        assert!(err.to_string().contains("adc/ch7"), "{err}");
    }
}
