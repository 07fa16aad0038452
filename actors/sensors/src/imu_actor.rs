//! The IMU actor: an MPU-9250 on spidev, read at its 1 kHz output rate by a dedicated thread
//! (a tokio timer cannot hold 1 ms), averaged to `imu` at 400 Hz, with each new AK8963
//! measurement published on `mag` (100 Hz). A `health` timer checks the reader thread: if it
//! stopped on an error, the actor fails with that error and the supervisor restarts it;
//! otherwise it publishes the output rate, failed reads and clipped samples on `health`.
//! A clipped average carries its per-axis flags in the `ImuSample` itself (for the estimator)
//! and is also counted in the health report and logged.
//!
//! Like ArduPilot's `AP_InertialSensor` and `Compass`, the driver owns the board's calibration
//! (`param_decl`: [`CALIBRATION_PARAMS`], set from `param_set`) and publishes corrected samples;
//! while a calibration asks for a motion (`calibration_motion`) it also publishes the raw ones on
//! `imu_raw` and `mag_raw` for the `calibration` actor, as the simulator does. The calibration
//! is disarmed-only (`WhileArmed::Locked`): where `vehicle_status` is routed, a set while armed is
//! refused here as well as by the link.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use kestrel_proto::calibration::{CALIBRATION_PARAMS, CalibrationParams};
use kestrel_proto::messages::{
    CalibrationMotion, ImuSample, MagSample, ParamDecl, ParamSet, SensorHealth, VehicleStatus,
};
use kestrel_proto::param_def::{ParamChange, answer, apply_set, declare};
use kestrel_proto::{Actor, ActorError, Clock, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::bus::SpiBus;
use crate::health::{Counters, HealthWindow};
use crate::imu_decimator::ImuDecimator;
use crate::linux::LinuxSpi;
use crate::live_calibration::{CalibrationReader, LiveCalibration};
use crate::mpu9250::{Mpu9250, Mpu9250Config};

/// Consecutive failed reads after which the reader gives up.
const MAX_CONSECUTIVE_ERRORS: u32 = 50;

/// `[actors.imu.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuActorParams {
    /// spidev node (Navio2: `/dev/spidev0.1`).
    pub device: PathBuf,
    /// SPI mode (the MPU-9250 accepts 0 and 3).
    pub spi_mode: u8,
    /// SPI clock (Hz); register writes need ≤ 1 MHz.
    pub spi_speed_hz: u32,
    /// Rate of the averaged `imu` output (Hz).
    pub output_rate_hz: f64,
    pub mpu9250: Mpu9250Config,
}

impl Default for ImuActorParams {
    fn default() -> ImuActorParams {
        ImuActorParams {
            device: PathBuf::from("/dev/spidev0.1"),
            spi_mode: 0,
            spi_speed_hz: 1_000_000,
            output_rate_hz: 400.0,
            mpu9250: Mpu9250Config::default(),
        }
    }
}

/// What the IMU actor handles.
#[derive(Debug)]
pub enum ImuInput {
    /// Timer `health_report`, every second; a port name of its own, apart from the `health` output.
    Health(Time),
    /// A calibration parameter from the ground station (others' names are ignored).
    Param(ParamSet),
    /// How a running calibration wants the vehicle handled: anything but idle asks for raw samples.
    Motion(CalibrationMotion),
    /// The commander's status (port `vehicle_status`): whether the vehicle is armed.
    Status(Box<VehicleStatus>),
}

/// Counters the reader thread shares with the actor.
#[derive(Debug, Default)]
struct ReaderStats {
    reads: AtomicU64,
    /// Averaged samples published on `imu`.
    published: AtomicU64,
    errors: AtomicU64,
    clipped: AtomicU64,
}

type Imu = Mpu9250<Box<dyn SpiBus + Send>>;

/// The IMU actor. Outputs: `imu`, `mag` (corrected), `imu_raw`, `mag_raw` (while calibrating),
/// `param_decl`, `health`.
pub struct ImuActor {
    /// The configured chip until [`Actor::start`] hands it to the reader thread.
    imu: Option<Imu>,
    reader: Option<JoinHandle<Result<(), String>>>,
    stats: Arc<ReaderStats>,
    read_period: Duration,
    output_period: Duration,
    imu_out: Publisher<ImuSample>,
    mag_out: Publisher<MagSample>,
    raw: RawOutputs,
    param_decl: Publisher<ParamDecl>,
    /// The calibration as its parameters hold it, and as the reader applies it.
    calibration: CalibrationParams,
    live: Arc<LiveCalibration>,
    /// Our name in the config: the owner named in `param_decl`.
    name: String,
    /// The spidev node, for health reports.
    device: String,
    /// Opened in [`Actor::start`], on the running graph's clock.
    window: Option<HealthWindow>,
    health_out: Publisher<SensorHealth>,
    /// Whether the newest `vehicle_status` says armed (false where it is not routed).
    armed: bool,
}

impl ImuActor {
    /// Builds the actor on an already opened bus (tests and benches pass a fake).
    pub fn with_bus(
        bus: Box<dyn SpiBus + Send>,
        params: &ImuActorParams,
        setup: &mut impl Setup<ImuInput>,
    ) -> Result<ImuActor, ActorError> {
        let output_period = kestrel_proto::timing::period_of_rate(
            "output_rate_hz",
            params.output_rate_hz,
            0.0,
            f64::INFINITY,
        )?;
        let bus_path = bus.path().display().to_string();
        let imu = Mpu9250::new(bus, params.mpu9250.clone(), &mut std::thread::sleep)
            .map_err(|e| ActorError::Failed(e.to_string()))?;
        let read_period = Duration::from_micros(1000 * (1 + u64::from(params.mpu9250.sample_rate_divider)));
        setup.timer("health_report", Duration::from_secs(1), ImuInput::Health);
        setup.input("param_set", ImuInput::Param);
        setup.input("calibration_motion", ImuInput::Motion);
        setup.input("vehicle_status", |s| ImuInput::Status(Box::new(s)));
        Ok(ImuActor {
            imu: Some(imu),
            reader: None,
            stats: Arc::default(),
            read_period,
            output_period,
            imu_out: setup.output("imu"),
            mag_out: setup.output("mag"),
            raw: RawOutputs { imu: setup.output("imu_raw"), mag: setup.output("mag_raw") },
            param_decl: setup.output("param_decl"),
            calibration: CalibrationParams::default(),
            live: Arc::default(),
            name: setup.name().to_owned(),
            device: bus_path,
            window: None,
            health_out: setup.output("health"),
            armed: false,
        })
    }

    /// Applies a calibration parameter (checked as a whole calibration: a singular soft-iron
    /// matrix is refused) and hands the calibration to the reader; the link is told the values
    /// in use, applied or refused.
    fn on_param(&mut self, p: &ParamSet) {
        let outcome = apply_set(&CALIBRATION_PARAMS, &mut self.calibration, p, self.armed, |c| {
            c.calibration().map(|_| ())
        });
        if let Ok(ParamChange::Applied) = outcome
            && let Ok(calibration) = self.calibration.calibration()
        {
            self.live.set(calibration);
        }
        if answer(&self.name, p, outcome) {
            self.param_decl.publish(declare(
                &CALIBRATION_PARAMS,
                &self.calibration,
                &self.name,
                false,
                p.time,
            ));
        }
    }

    /// Ends the reader thread's run and returns its outcome (`Ok` if none was running).
    fn join_reader(&mut self) -> Result<(), ActorError> {
        match self.reader.take().map(JoinHandle::join) {
            None | Some(Ok(Ok(()))) => Ok(()),
            Some(Ok(Err(e))) => Err(ActorError::Failed(e)),
            Some(Err(_)) => Err(ActorError::Failed("the IMU reader thread panicked".into())),
        }
    }
}

/// The uncorrected samples, for a running calibration.
#[derive(Clone)]
struct RawOutputs {
    imu: Publisher<ImuSample>,
    mag: Publisher<MagSample>,
}

/// The reader loop: read, publish the magnetometer, average, publish the IMU, until shutdown.
struct Reader {
    imu: Imu,
    clock: Arc<dyn Clock>,
    decimator: ImuDecimator,
    stats: Arc<ReaderStats>,
    period: Duration,
    imu_out: Publisher<ImuSample>,
    mag_out: Publisher<MagSample>,
    raw: RawOutputs,
    calibration: CalibrationReader,
}

impl Reader {
    fn run(mut self, stop: impl Fn() -> bool) -> Result<(), String> {
        let mut next = Instant::now();
        let mut consecutive_errors = 0;
        while !stop() {
            let time = self.clock.now();
            match self.imu.read(time) {
                Ok(reading) => {
                    consecutive_errors = 0;
                    self.stats.reads.fetch_add(1, Ordering::Relaxed);
                    let raw_wanted = self.calibration.raw_wanted();
                    let calibration = self.calibration.current();
                    if let Some(field_gauss) = reading.mag_frd_gauss {
                        let raw = MagSample { time, field_gauss };
                        self.mag_out.publish(calibration.apply_mag(&raw));
                        if raw_wanted {
                            self.raw.mag.publish(raw);
                        }
                    }
                    if let Some(out) = self.decimator.push(&reading) {
                        if out.sample.is_clipped() {
                            self.stats.clipped.fetch_add(1, Ordering::Relaxed);
                        }
                        self.stats.published.fetch_add(1, Ordering::Relaxed);
                        self.imu_out.publish(calibration.apply_imu(&out.sample));
                        if raw_wanted {
                            self.raw.imu.publish(out.sample);
                        }
                    }
                }
                Err(e) => {
                    self.stats.errors.fetch_add(1, Ordering::Relaxed);
                    consecutive_errors += 1;
                    if consecutive_errors >= MAX_CONSECUTIVE_ERRORS {
                        return Err(format!("{consecutive_errors} consecutive IMU reads failed, last: {e}"));
                    }
                }
            }
            next += self.period;
            let now = Instant::now();
            match next.checked_duration_since(now) {
                Some(wait) => std::thread::sleep(wait),
                None => next = now,
            }
        }
        Ok(())
    }
}

impl Actor for ImuActor {
    type Params = ImuActorParams;
    type Input = ImuInput;

    fn build(params: &ImuActorParams, setup: &mut impl Setup<ImuInput>) -> Result<ImuActor, ActorError> {
        if let Some(bus) = kestrel_proto::bus::open_plugged_spi(&params.device) {
            return ImuActor::with_bus(bus, params, setup);
        }
        setup.claim_device(&params.device)?;
        let bus = LinuxSpi::open(&params.device, params.spi_mode, params.spi_speed_hz).map_err(|e| {
            ActorError::Io { what: format!("MPU-9250 IMU on {}", params.device.display()), source: e.source }
        })?;
        ImuActor::with_bus(Box::new(bus), params, setup)
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let imu = self.imu.take().ok_or_else(|| ActorError::Failed("IMU reader already started".into()))?;
        let reader = Reader {
            imu,
            clock: Arc::clone(ctx.clock()),
            decimator: ImuDecimator::new(self.output_period),
            stats: Arc::clone(&self.stats),
            period: self.read_period,
            imu_out: self.imu_out.clone(),
            mag_out: self.mag_out.clone(),
            raw: self.raw.clone(),
            calibration: self.live.reader(),
        };
        let shutdown = ctx.shutdown().clone();
        let handle = std::thread::Builder::new()
            .name(format!("{}-reader", ctx.name()))
            .spawn(move || reader.run(move || shutdown.is_cancelled()))
            .map_err(|source| ActorError::Io { what: "cannot start the IMU reader thread".into(), source })?;
        self.reader = Some(handle);
        self.window = Some(HealthWindow::new(ctx.name(), &self.device, ctx.now()));
        self.param_decl.publish(declare(&CALIBRATION_PARAMS, &self.calibration, &self.name, true, ctx.now()));
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: ImuInput) -> Result<(), ActorError> {
        let now = match input {
            ImuInput::Health(now) => now,
            ImuInput::Param(p) => {
                self.on_param(&p);
                return Ok(());
            }
            ImuInput::Motion(m) => {
                self.live.set_raw_wanted(m.motion.wants_raw_samples());
                return Ok(());
            }
            ImuInput::Status(s) => {
                self.armed = s.armed;
                return Ok(());
            }
        };
        if self.reader.as_ref().is_some_and(JoinHandle::is_finished) {
            self.join_reader()?;
            return Err(ActorError::Failed("the IMU reader stopped".into()));
        }
        let totals = Counters {
            published: self.stats.published.load(Ordering::Relaxed),
            errors: self.stats.errors.load(Ordering::Relaxed),
            clipped: self.stats.clipped.load(Ordering::Relaxed),
        };
        if let Some(window) = &mut self.window {
            let health = window.report(now, totals);
            if health.clipped > 0 {
                tracing::warn!("{} IMU samples clipped in the last second", health.clipped);
            }
            tracing::debug!(reads = self.stats.reads.load(Ordering::Relaxed), "IMU reader health");
            self.health_out.publish(health);
        }
        Ok(())
    }

    async fn stop(&mut self, _ctx: &Context) {
        if let Err(e) = self.join_reader() {
            tracing::error!("IMU reader: {e}");
        }
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::testing::{TestSetup, ready};

    use super::*;
    use crate::mpu9250::FakeMpu9250;
    use kestrel_proto::messages::{FlightMode, LandedState, Motion};
    use kestrel_proto::testing::vehicle_status;
    use kestrel_proto::units::GRAVITY_M_S2;

    /// Runs the reader on `fake` until it has published an IMU and a mag sample, then takes a
    /// health report and stops.
    fn run_until_published(fake: FakeMpu9250) -> TestSetup<ImuInput> {
        let mut setup = TestSetup::new("imu", ".");
        let mut actor =
            ImuActor::with_bus(Box::new(fake), &ImuActorParams::default(), &mut setup).expect("build");
        let ctx = setup.context();
        ready(actor.start(&ctx)).expect("start");
        // Advance the graph clock until the reader has averaged a sample (bounded for slow machines).
        for k in 1..=5_000u64 {
            setup.manual_clock().set(Time::from_micros(1000 * k));
            std::thread::sleep(Duration::from_millis(1));
            if setup.count("imu") > 0 && setup.count("mag") > 0 {
                break;
            }
        }
        let now = setup.manual_clock().now();
        ready(actor.handle(&ctx, setup.tick("health_report", now))).expect("reader healthy");
        ctx.shutdown().cancel();
        ready(actor.stop(&ctx));
        setup
    }

    #[test]
    fn the_reader_publishes_averaged_imu_mag_and_health_until_shutdown() {
        let mut fake = FakeMpu9250::new(0x71);
        fake.set_motion([0, 0, 2048], 0, [0, 0, 0]);
        fake.set_mag([100, 0, 0], false);
        let setup = run_until_published(fake);
        let imu: Vec<ImuSample> = setup.published("imu");
        assert!(!imu.is_empty());
        assert!((imu[0].accel_m_s2[2] + GRAVITY_M_S2).abs() < 1e-9, "{:?}", imu[0]);
        assert!(imu.iter().all(|s| !s.is_clipped()), "{:?}", imu[0]);
        assert!(setup.count("mag") > 0);
        let health: Vec<SensorHealth> = setup.published("health");
        assert_eq!(health.len(), 1);
        assert_eq!(
            (health[0].device.as_str(), health[0].errors, health[0].clipped),
            ("/dev/spidev-fake", 0, 0)
        );
        assert!(health[0].rate_hz > 0.0, "{:?}", health[0]);
    }

    #[test]
    fn the_ground_stations_calibration_corrects_the_samples_and_raw_ones_flow_while_calibrating() {
        let mut fake = FakeMpu9250::new(0x71);
        fake.set_motion([0, 0, 2048], 0, [0, 0, 0]);
        fake.set_mag([100, -50, 200], false);
        let mut setup = TestSetup::new("imu", ".");
        let mut actor =
            ImuActor::with_bus(Box::new(fake), &ImuActorParams::default(), &mut setup).expect("build");
        let ctx = setup.context();
        ready(actor.start(&ctx)).expect("start");
        let set = |name: &str, value| ParamSet { time: Time::ZERO, name: name.into(), value, restore: false };
        // COMPASS_OFS_X is added to the reading (mG); INS_ACCOFFS_Z subtracted (m/s²).
        ready(actor.handle(&ctx, ImuInput::Param(set("COMPASS_OFS_X", 120.0)))).expect("param");
        ready(actor.handle(&ctx, ImuInput::Param(set("INS_ACCOFFS_Z", 0.25)))).expect("param");
        ready(actor.handle(&ctx, ImuInput::Param(set("COMPASS_DIA_X", 0.0))))
            .expect("a refusal is no failure");
        ready(actor.handle(&ctx, ImuInput::Param(set("RTL_ALT_M", 25.0)))).expect("not ours");
        // Armed, a calibration change is refused, and disarmed again it is taken.
        for (armed, value) in [(true, 0.05), (false, 0.02)] {
            let status = vehicle_status(Time::ZERO, armed, FlightMode::PosHold, LandedState::InAir);
            ready(actor.handle(&ctx, setup.input("vehicle_status", status))).expect("status");
            ready(actor.handle(&ctx, ImuInput::Param(set("INS_GYROFFS_X", value)))).expect("param");
            let decls: Vec<ParamDecl> = setup.published("param_decl");
            let now = decls.last().unwrap().params.iter().find(|p| p.name == "INS_GYROFFS_X").unwrap().value;
            assert_eq!(now, if armed { 0.0 } else { 0.02 }, "armed {armed}");
        }
        let tumble = CalibrationMotion { time: Time::ZERO, motion: Motion::Tumble };
        ready(actor.handle(&ctx, ImuInput::Motion(tumble))).expect("motion");
        for k in 1..=5_000u64 {
            setup.manual_clock().set(Time::from_micros(1000 * k));
            std::thread::sleep(Duration::from_millis(1));
            if setup.count("imu_raw") > 0 && setup.count("mag_raw") > 0 {
                break;
            }
        }
        ctx.shutdown().cancel();
        ready(actor.stop(&ctx));

        let decls: Vec<ParamDecl> = setup.published("param_decl");
        assert_eq!(decls.len(), 6, "at start and after each of our five sets: {decls:?}");
        assert!(decls[0].start && decls[0].params.len() == CALIBRATION_PARAMS.len());
        let value = |name: &str| decls.last().unwrap().params.iter().find(|p| p.name == name).unwrap().value;
        assert_eq!((value("COMPASS_OFS_X"), value("INS_ACCOFFS_Z")), (120.0, 0.25));
        assert_eq!(value("COMPASS_DIA_X"), 1.0, "a singular soft-iron correction is refused");

        let (mag, mag_raw): (Vec<MagSample>, Vec<MagSample>) =
            (setup.published("mag"), setup.published("mag_raw"));
        let raw = mag_raw.last().expect("raw mag");
        let corrected = mag.iter().find(|m| m.time == raw.time).expect("the same sample, corrected");
        let shift: Vec<f64> = (0..3).map(|i| corrected.field_gauss[i] - raw.field_gauss[i]).collect();
        assert!(
            (shift[0] - 0.120).abs() < 1e-12 && shift[1].abs() < 1e-12 && shift[2].abs() < 1e-12,
            "{shift:?}"
        );
        let (imu, imu_raw): (Vec<ImuSample>, Vec<ImuSample>) =
            (setup.published("imu"), setup.published("imu_raw"));
        let raw = imu_raw.last().expect("raw imu");
        let corrected = imu.iter().find(|s| s.time == raw.time).expect("the same sample, corrected");
        assert!((raw.accel_m_s2[2] - corrected.accel_m_s2[2] - 0.25).abs() < 1e-12, "{raw:?} {corrected:?}");
    }

    #[test]
    fn no_raw_samples_without_a_calibration_running() {
        let mut fake = FakeMpu9250::new(0x71);
        fake.set_motion([0, 0, 2048], 0, [0, 0, 0]);
        fake.set_mag([100, 0, 0], false);
        let setup = run_until_published(fake);
        assert_eq!((setup.count("imu_raw"), setup.count("mag_raw")), (0, 0));
        assert!(setup.count("imu") > 0 && setup.count("mag") > 0);
    }

    #[test]
    fn clipped_samples_are_reported_in_health() {
        let mut fake = FakeMpu9250::new(0x71);
        fake.set_motion([0, 0, i16::MAX], 0, [i16::MIN, 0, 0]);
        fake.set_mag([100, 0, 0], false);
        let setup = run_until_published(fake);
        let health: Vec<SensorHealth> = setup.published("health");
        // Every average saw a clipped axis (the reader may publish more after the report).
        assert!(health[0].clipped >= 1, "{:?}", health[0]);
        assert!(health[0].clipped <= setup.count("imu") as u64, "{:?}", health[0]);
        // And each sample says so itself, on one gyro and one accelerometer axis.
        let imu: Vec<ImuSample> = setup.published("imu");
        for sample in &imu {
            let count = |axes: [bool; 3]| axes.iter().filter(|&&c| c).count();
            assert_eq!((count(sample.gyro_clipped), count(sample.accel_clipped)), (1, 1), "{sample:?}");
        }
    }

    #[test]
    fn a_missing_device_or_chip_is_an_error_naming_it() {
        let params =
            ImuActorParams { device: PathBuf::from("/dev/spidev-kestrel-none"), ..ImuActorParams::default() };
        let err = ImuActor::build(&params, &mut TestSetup::new("imu", ".")).err().expect("no device");
        assert!(err.to_string().contains("/dev/spidev-kestrel-none"), "{err}");
        let err = ImuActor::with_bus(
            Box::new(FakeMpu9250::absent()),
            &ImuActorParams::default(),
            &mut TestSetup::new("imu", "."),
        )
        .err()
        .expect("no chip");
        assert!(
            err.to_string().contains("/dev/spidev-fake") && err.to_string().contains("WHO_AM_I"),
            "{err}"
        );
    }
}
