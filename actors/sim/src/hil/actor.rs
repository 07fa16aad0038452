//! The simulator driving an emulated Navio2 (`kestrel run --hil`): every IMU period on the wall
//! clock it reads the pulses the motor driver wrote as the ESCs would, advances the physics to
//! now, and hands each released sample to the chip that measures it — the IMU and compass to
//! the MPU-9250, the pressure to the MS5611, each GPS solution to the u-blox receiver as
//! NAV-PVT, the battery to the RCIO's ADC — instead of publishing it. The graph's drivers read
//! them through their own protocols; only `ground_truth` and `sim_fault` are published, for the
//! flight report and the log.

use std::sync::Arc;
use std::time::Duration;

use kestrel_proto::messages::{ActuatorOutputs, GroundTruth, MAX_MOTORS, SimFault, SimFaultPhase};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};

use super::bench::{BENCH_ASA, Navio2Bench};
use super::navio2_sysfs::EscInput;
use crate::actor::{SimActorParams, simulator};
use crate::simulator::{SimOutput, Simulator};

/// What the HIL simulator handles.
#[derive(Debug)]
pub enum HilSimInput {
    /// Advance to this time (timer `step`, every IMU period).
    Step(Time),
}

/// The simulator of a hardware-in-the-loop run. Outputs: `ground_truth`, `sim_fault`.
pub struct HilSimActor {
    sim: Simulator,
    bench: Arc<Navio2Bench>,
    ground_truth: Publisher<GroundTruth>,
    sim_fault: Publisher<SimFault>,
    /// The barometer's latest temperature, which the IMU's die reads too (°C).
    board_temperature_c: f64,
}

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
        let (sim, tick_us) = simulator(params, setup.config_dir(), setup.clock().now())?;
        setup.timer("step", Duration::from_micros(tick_us), HilSimInput::Step);
        Ok(HilSimActor {
            sim,
            bench,
            ground_truth: setup.output("ground_truth"),
            sim_fault: setup.output("sim_fault"),
            board_temperature_c: 25.0,
        })
    }

    async fn handle(&mut self, _ctx: &Context, input: HilSimInput) -> Result<(), ActorError> {
        let HilSimInput::Step(time) = input;
        let bench = Arc::clone(&self.bench);
        let io = |what: &str| {
            let what = what.to_owned();
            move |source| ActorError::Io { what, source }
        };
        let escs = bench.pwm.read().map_err(io("the emulated PWM chip"))?;
        self.sim.set_actuators(&actuators(&escs, time));
        self.sim.advance_to(time);
        let config = &bench.config;
        for output in self.sim.drain() {
            match output {
                SimOutput::Imu(m) => bench.imu.set_motion(
                    chip_axes(m.accel_m_s2),
                    chip_axes(m.gyro_rad_s),
                    self.board_temperature_c,
                ),
                SimOutput::Mag(m) => bench.imu.set_field(chip_axes(m.field_gauss), BENCH_ASA),
                SimOutput::Baro(m) => {
                    self.board_temperature_c = m.temperature_c;
                    bench.baro.set_reading(m.pressure_pa, m.temperature_c);
                }
                SimOutput::Gps(fix) => {
                    let mut line = bench.gps();
                    let frame = line.receiver.solution(&fix);
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
                SimOutput::GroundTruth(m) => self.ground_truth.publish(m),
                SimOutput::Fault(m) => {
                    let what = if m.phase == SimFaultPhase::Started { "started" } else { "ended" };
                    tracing::info!(at = %m.time, kind = %m.kind, values = %m.values, "simulated fault {what}");
                    self.sim_fault.publish(m);
                }
            }
        }
        serve_gps(&bench).map_err(io("the GPS pty"))
    }
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
        tracing::debug!(n, baud, state = ?line.receiver.state(), "GPS bytes");
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
