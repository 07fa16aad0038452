//! The simulator driving an emulated Navio2 (`kestrel run --hil`): every IMU period on the wall
//! clock it reads the pulses the motor driver wrote as the ESCs would, advances the physics to
//! now, and hands each released sample to the chip that measures it — the IMU and compass to
//! the MPU-9250, the pressure to the MS5611, each GPS solution to the u-blox receiver as
//! NAV-PVT, the battery to the RCIO's ADC — instead of publishing it. The graph's drivers read
//! them through their own protocols; only `ground_truth` and `sim_fault` are published, for the
//! flight report and the log.

use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use kestrel_proto::messages::{ActuatorOutputs, GroundTruth, MAX_MOTORS, SimFault, SimFaultPhase};
use kestrel_proto::realtime::{RealtimePriority, set_realtime_priority};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};

use super::bench::{BENCH_ASA, Navio2Bench};
use super::navio2_sysfs::EscInput;
use crate::actor::{SimActorParams, simulator};
use crate::simulator::{SimOutput, Simulator};
use crate::vehicle::VehicleParams;

/// What the HIL simulator handles.
#[derive(Debug)]
pub enum HilSimInput {
    /// Timer `watch`, every second: is the world thread still running?
    Watch(Time),
}

/// Priority of the world thread where SCHED_FIFO is granted: above the controller's 80, so the
/// simulated world never waits for the flight stack it is testing (a real one does not).
const WORLD_PRIORITY: i32 = 90;

/// The simulator of a hardware-in-the-loop run. Outputs: `ground_truth`, `sim_fault`.
///
/// The physics runs on a thread of its own paced by the wall clock, not on a tokio timer: a
/// timer late by a few milliseconds on a loaded host would freeze what the chips read and then
/// skip samples, a world the drivers would be blamed for.
pub struct HilSimActor {
    world: Option<World>,
    thread: Option<JoinHandle<Result<World, ActorError>>>,
    period: Duration,
}

/// The simulated world and the devices it drives.
struct World {
    sim: Simulator,
    bench: Arc<Navio2Bench>,
    ground_truth: Publisher<GroundTruth>,
    sim_fault: Publisher<SimFault>,
    /// The barometer's latest temperature, which the IMU's die reads too (°C).
    board_temperature_c: f64,
}

/// The chip always holds the pressure of now: the vehicle file's barometer rate and lag model
/// a driver's delivery, which here the real driver does (polling, conversion time, its own
/// timestamps). The rate is the simulator's limit so the chip never reads a stale value.
fn live_barometer(vehicle: &mut VehicleParams) {
    vehicle.sensors.baro.rate_hz = LIVE_BARO_RATE_HZ;
    vehicle.sensors.baro.lag_s = 0.0;
}

/// How often the emulated MS5611's pressure is renewed (Hz): the chip's fastest conversions
/// (OSR 256, 0.6 ms) are far faster than any driver polls it.
const LIVE_BARO_RATE_HZ: f64 = 100.0;

/// Body FRD → the MPU-9250's axes as the driver's default mounting sees them (chip flat, X
/// forward, Z up): chip = (f, −r, −d).
fn chip_axes(frd: [f64; 3]) -> [f64; 3] {
    [frd[0], -frd[1], -frd[2]]
}

impl Actor for HilSimActor {
    type Params = SimActorParams;
    type Input = HilSimInput;

    fn build(
        params: &SimActorParams,
        setup: &mut impl Setup<HilSimInput>,
    ) -> Result<HilSimActor, ActorError> {
        let bench = Navio2Bench::installed().ok_or_else(|| {
            ActorError::Params("hil_sim drives an emulated Navio2: run it with `kestrel run --hil`".into())
        })?;
        let (sim, tick_us) = simulator(params, setup.config_dir(), setup.clock().now(), live_barometer)?;
        setup.timer("watch", Duration::from_secs(1), HilSimInput::Watch);
        let mut world = World {
            sim,
            bench,
            ground_truth: setup.output("ground_truth"),
            sim_fault: setup.output("sim_fault"),
            board_temperature_c: 25.0,
        };
        world.power_up()?;
        Ok(HilSimActor { world: Some(world), thread: None, period: Duration::from_micros(tick_us) })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        let mut world =
            self.world.take().ok_or_else(|| ActorError::Failed("the world is already running".into()))?;
        let (clock, shutdown, period) = (Arc::clone(ctx.clock()), ctx.shutdown().clone(), self.period);
        let thread = std::thread::Builder::new()
            .name("hil-world".into())
            .spawn(move || {
                match set_realtime_priority(WORLD_PRIORITY) {
                    RealtimePriority::Fifo(p) => {
                        tracing::info!(priority = p, "HIL world on a SCHED_FIFO thread")
                    }
                    RealtimePriority::Normal(why) => tracing::warn!("HIL world on a normal thread ({why})"),
                }
                let mut next = Instant::now();
                while !shutdown.is_cancelled() {
                    world.step(clock.now())?;
                    next += period;
                    let now = Instant::now();
                    match next.checked_duration_since(now) {
                        Some(wait) => std::thread::sleep(wait),
                        None => next = now,
                    }
                }
                Ok(world)
            })
            .map_err(|source| ActorError::Io { what: "cannot start the HIL world thread".into(), source })?;
        self.thread = Some(thread);
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: HilSimInput) -> Result<(), ActorError> {
        let HilSimInput::Watch(_) = input;
        if self.thread.as_ref().is_some_and(JoinHandle::is_finished) {
            self.join()?;
            return Err(ActorError::Failed("the HIL world stopped".into()));
        }
        Ok(())
    }

    async fn stop(&mut self, _ctx: &Context) {
        if let Err(e) = self.join() {
            tracing::error!("HIL world: {e}");
        }
    }
}

impl HilSimActor {
    /// Waits for the world thread and keeps its world for a restart.
    fn join(&mut self) -> Result<(), ActorError> {
        match self.thread.take().map(JoinHandle::join) {
            None => Ok(()),
            Some(Ok(Ok(world))) => {
                self.world = Some(world);
                Ok(())
            }
            Some(Ok(Err(e))) => Err(e),
            Some(Err(_)) => Err(ActorError::Failed("the HIL world thread panicked".into())),
        }
    }
}

impl World {
    /// Reads the ESCs, advances the physics to `time` and hands each released sample to its
    /// chip.
    fn step(&mut self, time: Time) -> Result<(), ActorError> {
        let bench = Arc::clone(&self.bench);
        let escs = bench.pwm.read().map_err(io("the emulated PWM chip"))?;
        self.sim.set_actuators(&actuators(&escs, time));
        self.sim.advance_to(time);
        for output in self.sim.drain() {
            if to_chip(&bench, &mut self.board_temperature_c, &output)? {
                continue;
            }
            match output {
                SimOutput::GroundTruth(m) => self.ground_truth.publish(m),
                SimOutput::Fault(m) => {
                    let what = if m.phase == SimFaultPhase::Started { "started" } else { "ended" };
                    tracing::info!(at = %m.time, kind = %m.kind, values = %m.values, "simulated fault {what}");
                    self.sim_fault.publish(m);
                }
                _ => {}
            }
        }
        serve_gps(&bench).map_err(io("the GPS pty"))
    }

    /// Steps the physics, the vehicle at rest, until the barometer, the IMU, the compass and
    /// the power module have each sensed once, and hands those samples to their chips. A chip
    /// senses the world from power-on; without this the drivers, which start beside the world's
    /// thread, could read the emulators' placeholders: a first MS5611 temperature of ISA sea
    /// level's 15 °C, with the pressure of the next conversion, gave an altitude 80 m off, from
    /// which the estimator took its height reference (a HIL flight then flew 3.9 m too high).
    fn power_up(&mut self) -> Result<(), ActorError> {
        let bench = Arc::clone(&self.bench);
        let mut sensed = [false; 4];
        for _ in 0..POWER_UP_MAX_TICKS {
            self.sim.step();
            for output in self.sim.drain() {
                let which = match output {
                    SimOutput::Baro(_) => 0,
                    SimOutput::Imu(_) => 1,
                    SimOutput::Mag(_) => 2,
                    SimOutput::Battery(_) => 3,
                    _ => continue,
                };
                sensed[which] = to_chip(&bench, &mut self.board_temperature_c, &output)?;
            }
            if sensed.iter().all(|s| *s) {
                return Ok(());
            }
        }
        Err(ActorError::Failed(format!(
            "the simulated barometer, IMU, compass and power module did not all sense within \
             {POWER_UP_MAX_TICKS} ticks (sensed {sensed:?}): check their rates in the vehicle file"
        )))
    }
}

/// Most physics ticks [`World::power_up`] waits for every chip's first sample: a second at the
/// default 400 Hz, beyond any sensor's period.
const POWER_UP_MAX_TICKS: usize = 400;

/// An I/O error of the emulated board, naming what failed.
fn io(what: &str) -> impl Fn(std::io::Error) -> ActorError {
    let what = what.to_owned();
    move |source| ActorError::Io { what: what.clone(), source }
}

/// Hands `output` to the emulated chip that senses it; false when no chip does (ground truth,
/// faults, and the outputs of sensors the Navio2 does not carry are the caller's).
fn to_chip(
    bench: &Navio2Bench,
    board_temperature_c: &mut f64,
    output: &SimOutput,
) -> Result<bool, ActorError> {
    let config = &bench.config;
    match output {
        SimOutput::Imu(m) => {
            bench.imu.set_motion(chip_axes(m.accel_m_s2), chip_axes(m.gyro_rad_s), *board_temperature_c)
        }
        // The bench emulates the MPU-9250 only: there is no LSM9DS1 driver to read a second.
        SimOutput::Imu2(_) => {}
        // The Navio2 drives its ESCs by PWM, which reports nothing back.
        SimOutput::Esc(_) => {}
        SimOutput::Mag(m) => bench.imu.set_field(chip_axes(m.field_gauss), BENCH_ASA),
        SimOutput::Baro(m) => {
            *board_temperature_c = m.temperature_c;
            bench.baro.set_reading(m.pressure_pa, m.temperature_c);
        }
        SimOutput::Gps(fix) => {
            let mut line = bench.gps();
            let frame = line.receiver.solution(fix);
            let rate = line.receiver.state().baud;
            if let (Some(frame), Some(pty)) = (frame, line.pty.as_mut())
                && pty.line_baud().map_err(io("the GPS pty"))? == rate
            {
                pty.write(&frame).map_err(io("the GPS pty"))?;
            }
        }
        SimOutput::Battery(b) => {
            let mv = |v: f64| (v * 1000.0).round().max(0.0) as u64;
            let rcio = &bench.rcio;
            rcio.set_adc_mv(config.voltage_channel, mv(b.voltage_v / config.voltage_divider))
                .and_then(|()| {
                    rcio.set_adc_mv(config.current_channel, mv(b.current_a / config.amps_per_volt))
                })
                .map_err(io("the emulated RCIO ADC"))?;
        }
        // No rangefinder is emulated on the bench (nor is there a driver to read one), so a
        // vehicle file's rangefinders go unread in HIL, as an unplugged sensor would.
        SimOutput::GroundTruth(_) | SimOutput::Fault(_) | SimOutput::Rangefinder(_) => return Ok(false),
    }
    Ok(true)
}

/// What the ESCs make of the pulses: the vehicle is armed while any ESC sees pulses; one
/// without a signal stands still.
fn actuators(escs: &[EscInput], time: Time) -> ActuatorOutputs {
    let mut motors = [0.0; MAX_MOTORS];
    for (m, esc) in motors.iter_mut().zip(escs) {
        if let EscInput::Throttle(t) = esc {
            *m = *t;
        }
    }
    let armed = escs.iter().any(|e| matches!(e, EscInput::Throttle(_)));
    ActuatorOutputs { time, armed, motors }
}

/// Reads what the GPS driver sent and answers it at the receiver's rate.
fn serve_gps(bench: &Navio2Bench) -> std::io::Result<()> {
    let mut line = bench.gps();
    let line = &mut *line;
    let Some(pty) = line.pty.as_mut() else { return Ok(()) };
    let mut buf = [0u8; 256];
    loop {
        let n = pty.read(&mut buf)?;
        if n == 0 {
            return Ok(());
        }
        let before = line.receiver.state().baud;
        let baud = pty.line_baud()?;
        let reply = line.receiver.receive(&buf[..n], baud);
        if !reply.is_empty() && baud == before {
            pty.write(&reply)?;
        }
        if line.receiver.state().baud != before {
            tracing::info!(baud = line.receiver.state().baud, "emulated u-blox receiver switched its UART");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escs_without_pulses_stand_still() {
        let t = Time::from_micros(5);
        let out = actuators(&[EscInput::NoSignal; 4], t);
        assert!(!out.armed);
        let out = actuators(
            &[EscInput::Throttle(0.5), EscInput::NoSignal, EscInput::Throttle(0.0), EscInput::Throttle(1.0)],
            t,
        );
        assert!(out.armed);
        assert_eq!(&out.motors[..4], &[0.5, 0.0, 0.0, 1.0]);
    }
}
