//! The SBUS actor: an RC receiver's SBUS output on a UART (100 000 baud, 8E2), read by a tokio
//! task that publishes the pilot's sticks on `manual_control` at the receiver's frame rate,
//! with a `health` report every second.
//!
//! SBUS is an inverted serial line. Linux UARTs do not invert in software, so the signal must
//! be inverted in hardware before the RX pin: Navio2 does it on board (its SBUS input goes to
//! the RCIO co-processor, read by [`crate::rcio_actor`] instead), other boards need an
//! inverter or a receiver with an uninverted output.
//!
//! While the receiver reports failsafe its channels are presets, not the pilot's hands, so no
//! sticks are published; the commander's RC-loss timeout then acts on the silence.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use kestrel_proto::messages::ManualControl;
use kestrel_proto::{Actor, ActorError, Clock, Context, Publisher, Setup, Time};
use serde::Deserialize;
use tokio::io::AsyncReadExt;
use tokio_util::sync::CancellationToken;

use crate::health::Counters;
use crate::reader_task::ReaderTask;
use crate::sbus::{SbusParser, StickMap};
use crate::serial::{self, LineSettings, SerialTransport};

/// Period of the health report.
const HEALTH_PERIOD: Duration = Duration::from_secs(1);

/// `[actors.rc.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SbusActorParams {
    /// UART device node, behind a hardware inverter.
    pub device: PathBuf,
    /// Which channel is which stick, with each channel's calibrated range.
    pub sticks: StickMap,
}

impl Default for SbusActorParams {
    fn default() -> SbusActorParams {
        SbusActorParams { device: PathBuf::from("/dev/ttyAMA0"), sticks: StickMap::default() }
    }
}

/// What the SBUS actor handles.
#[derive(Debug)]
pub enum SbusInput {
    /// Timer `health_report`, every second; a port name of its own, apart from the `health` output.
    Health(Time),
}

/// What the reader has seen, for health reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SbusStats {
    /// Frames decoded.
    pub frames: u64,
    /// Header bytes not followed by a valid frame.
    pub rejected: u64,
    /// Frames flagged "frame lost" by the receiver.
    pub frames_lost: u64,
    /// Frames in failsafe.
    pub failsafe: u64,
}

/// The reader task's state, handed over in [`Actor::start`].
struct Reader {
    port: Box<dyn SerialTransport>,
    parser: SbusParser,
    sticks: StickMap,
    stats: Arc<Mutex<SbusStats>>,
    out: Publisher<ManualControl>,
}

impl Reader {
    async fn run(mut self, clock: Arc<dyn Clock>, stop: CancellationToken) -> Result<(), String> {
        let mut buf = [0u8; 256];
        let mut counts = SbusStats::default();
        loop {
            let n = tokio::select! {
                _ = stop.cancelled() => return Ok(()),
                read = self.port.read(&mut buf) => read.map_err(|e| format!("SBUS read: {e}"))?,
            };
            if n == 0 {
                return Err("SBUS serial port closed".into());
            }
            let now = clock.now();
            self.parser.push(&buf[..n]);
            while let Some(frame) = self.parser.next_frame() {
                counts.frames_lost += u64::from(frame.frame_lost);
                if frame.failsafe && counts.failsafe == 0 {
                    tracing::warn!("SBUS receiver in failsafe: no sticks published");
                }
                counts.failsafe += u64::from(frame.failsafe);
                if let Some(sticks) = self.sticks.manual_control(&frame, now) {
                    self.out.publish(sticks);
                }
            }
            counts.frames = self.parser.frames;
            counts.rejected = self.parser.rejected;
            *self.stats.lock().unwrap_or_else(|e| e.into_inner()) = counts;
        }
    }
}

/// The SBUS actor. Outputs: `manual_control`, `health`.
pub struct SbusActor {
    reader: Option<Reader>,
    stats: Arc<Mutex<SbusStats>>,
    task: ReaderTask,
}

impl SbusActor {
    /// Builds the actor on an already opened port (any [`SerialTransport`]); `device` names
    /// it in health reports.
    pub fn with_port(
        port: Box<dyn SerialTransport>,
        device: &str,
        params: &SbusActorParams,
        setup: &mut impl Setup<SbusInput>,
    ) -> SbusActor {
        let stats = Arc::new(Mutex::new(SbusStats::default()));
        setup.timer("health_report", HEALTH_PERIOD, SbusInput::Health);
        let reader = Reader {
            port,
            parser: SbusParser::new(),
            sticks: params.sticks.clone(),
            stats: Arc::clone(&stats),
            out: setup.output("manual_control"),
        };
        SbusActor {
            reader: Some(reader),
            stats,
            task: ReaderTask::new("SBUS", device, setup.output("health")),
        }
    }
}

impl Actor for SbusActor {
    type Params = SbusActorParams;
    type Input = SbusInput;

    fn build(params: &SbusActorParams, setup: &mut impl Setup<SbusInput>) -> Result<SbusActor, ActorError> {
        setup.claim_device(&params.device)?;
        let port = serial::open(&params.device, LineSettings::sbus(), "SBUS receiver at 100000 baud 8E2")
            .map_err(|e| ActorError::Failed(e.to_string()))?;
        Ok(SbusActor::with_port(Box::new(port), &params.device.display().to_string(), params, setup))
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let reader =
            self.reader.take().ok_or_else(|| ActorError::Failed("SBUS reader already started".into()))?;
        self.task.start(ctx, reader.run(Arc::clone(ctx.clock()), ctx.shutdown().clone()));
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: SbusInput) -> Result<(), ActorError> {
        let SbusInput::Health(now) = input;
        let stats = *self.stats.lock().unwrap_or_else(|e| e.into_inner());
        let totals = Counters { published: stats.frames, errors: stats.rejected, clipped: 0 };
        self.task.tick(now, totals).await
    }

    async fn stop(&mut self, _ctx: &Context) {
        self.task.stop();
    }
}
