//! The GPS actor: a u-blox (or any NMEA) receiver on a UART, configured at start-up and read
//! by a tokio task that publishes each fix on `gps` stamped with its time of validity, with a
//! `health` report every second.
//!
//! A line that fails or closes (a cable shaken loose, a receiver browning out) is not the
//! actor's end: the reader says so, counts it as an error in `health`, tries the device again
//! every [`REOPEN_PERIOD`] and, once it opens, sets the receiver up again from its power-up
//! rate, as at start (a receiver that kept its rate ignores the slow bytes and takes the rest).
//! Failing instead would leave the supervisor's restart limit to decide whether GPS ever comes
//! back; ArduPilot's and PX4's GPS drivers likewise keep probing for their receiver.
//!
//! On Navio2 the on-board u-blox M8N sits on SPI (`/dev/spidev0.0`), which this actor does not
//! drive; it reads a receiver on the UART header (`/dev/ttyAMA0`) or USB (`/dev/ttyACM0`).

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use kestrel_proto::messages::GpsFix;
use kestrel_proto::{Actor, ActorError, Clock, Context, Publisher, Setup, Time};
use serde::Deserialize;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_util::sync::CancellationToken;

use crate::gps::{Configuration, GpsDecoder, GpsStats};
use crate::health::Counters;
use crate::nmea::NmeaFixOptions;
use crate::reader_task::ReaderTask;
use crate::serial::{self, LineSettings, SerialTransport};
use crate::ubx::DynamicModel;

/// Time for a receiver to finish sending at the old rate and switch to the new one after
/// CFG-PRT (u-blox: the change applies once the port's transmit buffer is empty).
const BAUD_SWITCH_WAIT: Duration = Duration::from_millis(150);

/// Period of the health report.
const HEALTH_PERIOD: Duration = Duration::from_secs(1);
/// Interval between attempts to open a receiver's device again after its line was lost.
pub const REOPEN_PERIOD: Duration = Duration::from_secs(1);

/// Opens the receiver's device again at its power-up rate.
type Reopen = Box<dyn Fn() -> std::io::Result<Box<dyn SerialTransport>> + Send + Sync>;

/// `[actors.gps.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GpsActorParams {
    /// UART device node.
    pub device: PathBuf,
    /// Line rate the receiver is switched to and read at (bit/s).
    pub baud: u32,
    /// Line rate the receiver talks at power-up (u-blox M8 factory setting: 9600 bit/s).
    pub initial_baud: u32,
    /// Send the UBX set-up sequence (u-blox receivers). Off for receivers that only speak
    /// NMEA: they are then read at `baud`, which must be their own rate.
    pub configure: bool,
    /// Navigation solutions per second (Hz).
    pub rate_hz: f64,
    /// The receiver's navigation filter model (PX4's default: airborne < 2 g).
    pub dynamic_model: DynamicModel,
    /// Delay from a NAV-PVT epoch to its earliest possible arrival (s), subtracted on top of
    /// the observed transport delay; see [`crate::ubx::ValidityClock`].
    pub ubx_latency_s: f64,
    /// How NMEA-only fixes fill in accuracy and lag.
    pub nmea: NmeaFixOptions,
}

impl Default for GpsActorParams {
    fn default() -> GpsActorParams {
        GpsActorParams {
            device: PathBuf::from("/dev/ttyAMA0"),
            baud: 115_200,
            initial_baud: 9600,
            configure: true,
            rate_hz: 5.0,
            dynamic_model: DynamicModel::Airborne2g,
            ubx_latency_s: 0.05,
            nmea: NmeaFixOptions::default(),
        }
    }
}

/// What the GPS actor handles.
#[derive(Debug)]
pub enum GpsInput {
    /// Timer `health_report`, every second; a port name of its own, apart from the `health` output.
    Health(Time),
}

/// What the reader task needs, handed over in [`Actor::start`].
struct Reader {
    port: Option<Box<dyn SerialTransport>>,
    /// How to open the device again after the line was lost (`None`: a port given to
    /// [`GpsActor::with_port`], whose loss ends the reader).
    reopen: Option<Reopen>,
    configuration: Option<Configuration>,
    initial_baud: u32,
    baud: u32,
    decoder: GpsDecoder,
    stats: Arc<Mutex<GpsStats>>,
    /// Times the line was lost.
    losses: Arc<AtomicU64>,
    out: Publisher<GpsFix>,
}

impl Reader {
    async fn run(mut self, clock: Arc<dyn Clock>, stop: CancellationToken) -> Result<(), String> {
        loop {
            let port = match self.port.take() {
                Some(port) => port,
                None => match &self.reopen {
                    Some(reopen) => match reopen_when_back(reopen, &stop).await {
                        Some(port) => port,
                        None => return Ok(()),
                    },
                    None => return Ok(()),
                },
            };
            match self.session(port, &clock, &stop).await {
                Ok(()) => return Ok(()),
                Err(e) if self.reopen.is_some() => {
                    let losses = self.losses.fetch_add(1, Ordering::Relaxed) + 1;
                    tracing::warn!(
                        losses,
                        "{e}: opening the receiver again every {} s",
                        REOPEN_PERIOD.as_secs()
                    );
                }
                Err(e) => return Err(e),
            }
        }
    }

    /// Sets the receiver up on `port` and reads it until the line fails (`Err`) or the graph
    /// stops (`Ok`).
    async fn session(
        &mut self,
        mut port: Box<dyn SerialTransport>,
        clock: &Arc<dyn Clock>,
        stop: &CancellationToken,
    ) -> Result<(), String> {
        let failed = |what: &str, e: std::io::Error| format!("GPS {what}: {e}");
        if let Some(c) = &self.configuration {
            port.write_all(&c.switch_baud).await.map_err(|e| failed("write", e))?;
            port.flush().await.map_err(|e| failed("write", e))?;
            if self.initial_baud != self.baud {
                tokio::time::sleep(BAUD_SWITCH_WAIT).await;
                port.set_baud_rate(self.baud).map_err(|e| failed("baud rate change", e))?;
            }
            port.write_all(&c.settings.concat()).await.map_err(|e| failed("write", e))?;
            port.flush().await.map_err(|e| failed("write", e))?;
        }
        let mut buf = [0u8; 1024];
        loop {
            let n = tokio::select! {
                _ = stop.cancelled() => return Ok(()),
                read = port.read(&mut buf) => read.map_err(|e| failed("read", e))?,
            };
            if n == 0 {
                return Err("GPS serial port closed".into());
            }
            for fix in self.decoder.push(&buf[..n], clock.now()) {
                self.out.publish(fix);
            }
            *self.stats.lock().unwrap_or_else(|e| e.into_inner()) = self.decoder.stats();
        }
    }
}

/// Tries the device every [`REOPEN_PERIOD`] until it opens (or the graph stops: `None`).
async fn reopen_when_back(reopen: &Reopen, stop: &CancellationToken) -> Option<Box<dyn SerialTransport>> {
    loop {
        tokio::select! {
            _ = stop.cancelled() => return None,
            _ = tokio::time::sleep(REOPEN_PERIOD) => {}
        }
        if let Ok(port) = reopen() {
            tracing::info!("GPS receiver line open again: setting it up");
            return Some(port);
        }
    }
}

/// The GPS actor. Outputs: `gps`, `health`.
pub struct GpsActor {
    reader: Option<Reader>,
    stats: Arc<Mutex<GpsStats>>,
    losses: Arc<AtomicU64>,
    task: ReaderTask,
}

impl GpsActor {
    /// Builds the actor on an already opened port (any [`SerialTransport`]); `device` names
    /// it in health reports.
    pub fn with_port(
        port: Box<dyn SerialTransport>,
        device: &str,
        params: &GpsActorParams,
        setup: &mut impl Setup<GpsInput>,
    ) -> Result<GpsActor, ActorError> {
        let configuration = params
            .configure
            .then(|| Configuration::new(params.baud, params.rate_hz, params.dynamic_model))
            .transpose()
            .map_err(|e| ActorError::Params(e.to_string()))?;
        let ubx_latency = kestrel_proto::timing::seconds("ubx_latency_s", params.ubx_latency_s, 0.0, 10.0)?;
        kestrel_proto::timing::seconds("nmea.lag_s", params.nmea.lag_s, 0.0, 10.0)?;
        let stats = Arc::new(Mutex::new(GpsStats::default()));
        let losses = Arc::new(AtomicU64::new(0));
        setup.timer("health_report", HEALTH_PERIOD, GpsInput::Health);
        let reader = Reader {
            port: Some(port),
            reopen: None,
            configuration,
            initial_baud: params.initial_baud,
            baud: params.baud,
            decoder: GpsDecoder::new(ubx_latency, params.nmea.clone()),
            stats: Arc::clone(&stats),
            losses: Arc::clone(&losses),
            out: setup.output("gps"),
        };
        Ok(GpsActor {
            reader: Some(reader),
            stats,
            losses,
            task: ReaderTask::new("GPS", device, setup.output("health")),
        })
    }
}

impl Actor for GpsActor {
    type Params = GpsActorParams;
    type Input = GpsInput;

    fn build(params: &GpsActorParams, setup: &mut impl Setup<GpsInput>) -> Result<GpsActor, ActorError> {
        let first_baud = if params.configure { params.initial_baud } else { params.baud };
        let what = format!("GPS receiver at {first_baud} baud");
        setup.claim_device(&params.device)?;
        let port = serial::open(&params.device, LineSettings::n81(first_baud), &what)
            .map_err(|e| ActorError::Failed(e.to_string()))?;
        let mut actor =
            GpsActor::with_port(Box::new(port), &params.device.display().to_string(), params, setup)?;
        let device = params.device.clone();
        if let Some(reader) = actor.reader.as_mut() {
            reader.reopen = Some(Box::new(move || {
                serial::open(&device, LineSettings::n81(first_baud), &what)
                    .map(|port| Box::new(port) as Box<dyn SerialTransport>)
                    .map_err(|e| std::io::Error::other(e.to_string()))
            }));
        }
        Ok(actor)
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let reader =
            self.reader.take().ok_or_else(|| ActorError::Failed("GPS reader already started".into()))?;
        self.task.start(ctx, reader.run(Arc::clone(ctx.clock()), ctx.shutdown().clone()));
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: GpsInput) -> Result<(), ActorError> {
        let GpsInput::Health(now) = input;
        let stats = *self.stats.lock().unwrap_or_else(|e| e.into_inner());
        let errors = stats.errors() + self.losses.load(Ordering::Relaxed);
        let totals = Counters { published: stats.fixes, errors, clipped: 0 };
        self.task.tick(now, totals).await
    }

    async fn stop(&mut self, _ctx: &Context) {
        self.task.stop();
    }
}
