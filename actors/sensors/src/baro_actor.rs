//! The barometer actor: an MS5611 on an I2C adapter, sampled without blocking by a timer at
//! twice the output rate, publishing `baro`, with a `health` report every second.

use std::path::PathBuf;
use std::time::Duration;

use kestrel_proto::messages::{BaroSample, SensorHealth};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::bus::I2cBus;
use crate::health::{Counters, HealthWindow};
use crate::linux::LinuxI2c;
use crate::ms5611::{Ms5611, Ms5611Sampler, Oversampling};

/// `[actors.baro.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaroActorParams {
    /// I2C adapter (Navio2: `/dev/i2c-1`).
    pub device: PathBuf,
    /// 7-bit address (0x77 with CSB low, as on Navio2; 0x76 with CSB high).
    pub address: u8,
    /// Samples per second (Hz).
    pub rate_hz: f64,
    pub oversampling: Oversampling,
}

impl Default for BaroActorParams {
    fn default() -> BaroActorParams {
        BaroActorParams {
            device: PathBuf::from("/dev/i2c-1"),
            address: 0x77,
            rate_hz: 10.0,
            oversampling: Oversampling::Osr4096,
        }
    }
}

/// What the barometer actor handles.
#[derive(Debug)]
pub enum BaroInput {
    /// Timer `poll`, at twice `rate_hz`.
    Poll(Time),
    /// Timer `health_report`, every second; a port name of its own, apart from the `health` output.
    Health(Time),
}

/// The barometer actor. Output: `baro`.
pub struct BaroActor {
    baro: Ms5611<Box<dyn I2cBus + Send>>,
    sampler: Ms5611Sampler,
    out: Publisher<BaroSample>,
    published: u64,
    /// The I2C adapter, for health reports.
    device: String,
    /// Opened in [`Actor::start`], on the running graph's clock.
    window: Option<HealthWindow>,
    health_out: Publisher<SensorHealth>,
}

impl BaroActor {
    /// Builds the actor on an already opened bus (tests and benches pass a fake).
    pub fn with_bus(
        bus: Box<dyn I2cBus + Send>,
        params: &BaroActorParams,
        setup: &mut impl Setup<BaroInput>,
    ) -> Result<BaroActor, ActorError> {
        let poll = poll_period(params)?;
        let device = bus.path().display().to_string();
        let baro = Ms5611::new(bus, params.oversampling, &mut std::thread::sleep)
            .map_err(|e| ActorError::Failed(e.to_string()))?;
        setup.timer("poll", poll, BaroInput::Poll);
        setup.timer("health_report", Duration::from_secs(1), BaroInput::Health);
        Ok(BaroActor {
            baro,
            sampler: Ms5611Sampler::new(),
            out: setup.output("baro"),
            published: 0,
            device,
            window: None,
            health_out: setup.output("health"),
        })
    }
}

/// Half the sample period, which must leave a conversion time to each conversion.
fn poll_period(params: &BaroActorParams) -> Result<Duration, ActorError> {
    let conversion = params.oversampling.conversion_time();
    let max_hz = 0.5 / conversion.as_secs_f64();
    if !(params.rate_hz.is_finite() && params.rate_hz > 0.0 && params.rate_hz <= max_hz) {
        return Err(ActorError::Params(format!(
            "rate_hz must be in (0, {max_hz:.0}] at {:?}, got {}",
            params.oversampling, params.rate_hz
        )));
    }
    Ok(kestrel_proto::timing::period_of_rate("rate_hz", params.rate_hz, 0.0, max_hz)? / 2)
}

impl Actor for BaroActor {
    type Params = BaroActorParams;
    type Input = BaroInput;

    fn build(params: &BaroActorParams, setup: &mut impl Setup<BaroInput>) -> Result<BaroActor, ActorError> {
        poll_period(params)?;
        if let Some(bus) = kestrel_proto::bus::open_plugged_i2c(&params.device, params.address) {
            return BaroActor::with_bus(bus, params, setup);
        }
        setup.claim_device(&params.device)?;
        let bus = LinuxI2c::open(&params.device, params.address).map_err(|e| ActorError::Io {
            what: format!(
                "MS5611 barometer at I2C address {:#04x} on {}",
                params.address,
                params.device.display()
            ),
            source: e.source,
        })?;
        BaroActor::with_bus(Box::new(bus), params, setup)
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        self.window = Some(HealthWindow::new(ctx.name(), &self.device, ctx.now()));
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: BaroInput) -> Result<(), ActorError> {
        match input {
            BaroInput::Poll(time) => match self.sampler.tick(&mut self.baro, time) {
                Ok(Some(sample)) => {
                    self.published += 1;
                    self.out.publish(sample);
                }
                Ok(None) => {}
                Err(e) => return Err(ActorError::Failed(e.to_string())),
            },
            BaroInput::Health(now) => {
                let totals = Counters { published: self.published, errors: 0, clipped: 0 };
                if let Some(window) = &mut self.window {
                    self.health_out.publish(window.report(now, totals));
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
    use crate::ms5611::FakeMs5611;
    use crate::ms5611::prom::tests::datasheet_prom_words;

    #[test]
    fn publishes_compensated_samples_at_the_configured_rate() {
        let mut setup = TestSetup::new("baro", ".");
        let fake = FakeMs5611::new(datasheet_prom_words(), 9_085_466, 8_569_150);
        let mut actor =
            BaroActor::with_bus(Box::new(fake), &BaroActorParams::default(), &mut setup).expect("build");
        assert_eq!(
            setup.timers(),
            [("poll", Duration::from_millis(50)), ("health_report", Duration::from_secs(1))]
        );
        let ctx = setup.context();
        ready(actor.start(&ctx)).expect("start");
        for k in 0..5u64 {
            ready(actor.handle(&ctx, setup.tick("poll", Time::from_micros(50_000 * k)))).expect("tick");
        }
        let samples: Vec<BaroSample> = setup.published("baro");
        assert_eq!(samples.len(), 2);
        assert_eq!(samples[0].pressure_pa, 100_009.0);
        assert_eq!(samples[1].time, Time::from_micros(150_000 + 9_040));
        ready(actor.handle(&ctx, setup.tick("health_report", Time::from_micros(1_000_000)))).expect("health");
        let health: Vec<SensorHealth> = setup.published("health");
        assert_eq!((health[0].rate_hz, health[0].device.as_str()), (2.0, "/dev/i2c-fake"));
    }

    #[test]
    fn a_missing_device_is_an_error_naming_it() {
        let params =
            BaroActorParams { device: PathBuf::from("/dev/i2c-kestrel-none"), ..BaroActorParams::default() };
        let err = BaroActor::build(&params, &mut TestSetup::new("baro", ".")).err().expect("no device");
        assert!(err.to_string().contains("/dev/i2c-kestrel-none"), "{err}");
        let mut setup = TestSetup::new("baro", ".");
        let err =
            BaroActor::with_bus(Box::new(FakeMs5611::absent()), &BaroActorParams::default(), &mut setup)
                .err()
                .expect("absent chip");
        assert!(err.to_string().contains("/dev/i2c-fake"), "{err}");
    }

    #[test]
    fn an_impossible_rate_is_a_parameter_error() {
        let params = BaroActorParams { rate_hz: 100.0, ..BaroActorParams::default() };
        let err =
            BaroActor::with_bus(Box::new(FakeMs5611::absent()), &params, &mut TestSetup::new("baro", "."));
        assert!(matches!(err, Err(ActorError::Params(_))));
    }
}
