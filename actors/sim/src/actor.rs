//! The simulator as an actor: every IMU period it takes the latest actuator outputs, advances
//! the core to the tick's time and publishes what the core released.

use std::path::{Path, PathBuf};
use std::time::Duration;

use kestrel_proto::calibration::{CALIBRATION_PARAMS, CalibrationParams};
use kestrel_proto::esc::{DirectPulses, EscRanges, esc_range_params};
use kestrel_proto::messages::{
    ActuatorOutputs, BaroSample, BatteryStatus, CalibrationMotion, EscPulses, EscTelemetry, FailureInjection,
    FailureInjectionResult, GpsFix, GroundTruth, ImuSample, MagSample, ObstacleMap, ParamDecl, ParamSet,
    RangefinderOrientation, RangefinderSample, SimFault, SimFaultPhase,
};
use kestrel_proto::param_def::{ParamChange, ParamRefused, answer, apply, apply_set, declare};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::handling::Handling;
use crate::live_faults::{INTEGER_PARAMS, LIVE_FAULT_PARAMS, LiveFaults};
use crate::rigid_body::RigidBodyState;
use crate::sensors::schedule::period_us;
use crate::simulator::{InitialState, RawSample, SimOptions, SimOutput, Simulator};
use crate::vehicle::VehicleParams;
use crate::world::World;

/// `[actors.sim.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimActorParams {
    /// Vehicle file, relative to the config file's directory.
    pub vehicle: PathBuf,
    /// World file, relative to the config file's directory.
    pub world: PathBuf,
    /// Seed of wind and sensor noise.
    pub seed: u64,
    /// Physics steps per IMU period.
    pub physics_substeps: u32,
    /// Rate of the `ground_truth` output (Hz).
    pub ground_truth_rate_hz: f64,
    /// Rate of the `battery` output (Hz).
    pub battery_rate_hz: f64,
    /// Start position, north/east/down from home (m); down ≤ 0.
    pub initial_position_ned_m: [f64; 3],
    /// Which of several vehicles on one machine this is (`kestrel run --instance N`): it starts
    /// [`INSTANCE_SPACING_M`]·N east of `initial_position_ned_m` (PX4's multi-vehicle SITL
    /// spawns them a few metres apart too) and draws its noise from `seed + N`.
    pub instance: u8,
    /// How the simulated person handles the vehicle during a calibration: "careful",
    /// "one_orientation" (never turns it), "shaking" (never holds it still).
    pub handling: Handling,
}

/// East spacing of vehicles started with `--instance` (m): far enough that two vehicles
/// taking off side by side do not touch (rotor span 0.45 m), near enough to share a field.
pub const INSTANCE_SPACING_M: f64 = 5.0;

impl Default for SimActorParams {
    fn default() -> SimActorParams {
        let options = SimOptions::default();
        SimActorParams {
            vehicle: PathBuf::from("vehicles/quad_x.toml"),
            world: PathBuf::from("worlds/empty.toml"),
            seed: options.seed,
            physics_substeps: options.physics_substeps,
            ground_truth_rate_hz: options.ground_truth_rate_hz,
            battery_rate_hz: options.battery_rate_hz,
            initial_position_ned_m: [0.0; 3],
            instance: 0,
            handling: Handling::Careful,
        }
    }
}

/// What the simulator actor handles.
#[derive(Debug)]
pub enum SimInput {
    /// New motor commands (port `actuators`); until the first, the motors are stopped.
    Actuators(ActuatorOutputs),
    /// Advance to this time (timer `step`, every IMU period).
    Step(Time),
    /// How a calibration wants the vehicle handled (port `calibration_motion`).
    Motion(CalibrationMotion),
    /// A calibration or live fault parameter set (port `param_set`; others' names are ignored).
    Param(ParamSet),
    /// A MAV_CMD_INJECT_FAILURE from the link (port `inject_failure`), answered on
    /// `failure_result`.
    Inject(FailureInjection),
    /// Direct pulses for the ESCs while disarmed (port `esc_pulses`, from an ESC calibration).
    Pulses(EscPulses),
}

/// The simulator actor. Outputs: `imu`, `imu2` (the second IMU, when the vehicle has one), `gps`, `baro`, `mag`,
/// `rangefinder_up` and `rangefinder_down` (RangefinderSample, when the vehicle file fits them),
/// `ground_truth`, `battery`, `esc_telemetry` (what each motor produces, every tick),
/// `sim_fault` (each start and end of a world-file fault, also logged at INFO), and
/// `obstacle_map` once, on the first step. Like the motor driver it owns the outputs' pulse
/// ranges (`SERVOn_MIN`/`SERVOn_MAX`, applied to the commands as they are set) and takes direct
/// pulses while disarmed (`esc_pulses`, checked and timed out by [`DirectPulses`]). Like a
/// driver it owns the sensor calibration
/// (`param_decl`: [`CALIBRATION_PARAMS`], applied to the samples as they are set) and, while a
/// calibration asks for a motion, handles the vehicle so and publishes the raw board-frame
/// samples on `imu_raw` and `mag_raw`. It also owns the live fault parameters
/// ([`LIVE_FAULT_PARAMS`]: `SIM_*`, `SYS_FAILURE_EN`) and answers failure injections.
pub struct SimActor {
    sim: Simulator,
    imu: Publisher<ImuSample>,
    imu2: Publisher<ImuSample>,
    gps: Publisher<GpsFix>,
    baro: Publisher<BaroSample>,
    mag: Publisher<MagSample>,
    rangefinder_up: Publisher<RangefinderSample>,
    rangefinder_down: Publisher<RangefinderSample>,
    ground_truth: Publisher<GroundTruth>,
    battery: Publisher<BatteryStatus>,
    esc_telemetry: Publisher<EscTelemetry>,
    obstacle_map: Publisher<ObstacleMap>,
    /// Each start and end of a world-file fault, as it takes effect.
    sim_fault: Publisher<SimFault>,
    /// Whether the map has gone out. It waits for the first step rather than going out from
    /// `build`, because the recorder and subscribers are attached only after every actor is
    /// built, and a log must carry it.
    map_published: bool,
    imu_raw: Publisher<ImuSample>,
    mag_raw: Publisher<MagSample>,
    param_decl: Publisher<ParamDecl>,
    calibration: CalibrationParams,
    esc_ranges: EscRanges,
    direct: DirectPulses,
    /// Whether the newest commands say armed (direct pulses are ignored then).
    armed: bool,
    live: LiveFaults,
    failure_result: Publisher<FailureInjectionResult>,
    name: String,
}

impl SimActor {
    /// The simulator core, for inspection.
    pub fn simulator(&self) -> &Simulator {
        &self.sim
    }
}

impl Actor for SimActor {
    type Params = SimActorParams;
    type Input = SimInput;

    fn build(params: &SimActorParams, setup: &mut impl Setup<SimInput>) -> Result<SimActor, ActorError> {
        let (mut sim, tick_us) = simulator(params, setup.config_dir(), setup.clock().now(), |_| {})?;
        sim.set_handling(params.handling);
        setup.input("actuators", SimInput::Actuators);
        setup.input("calibration_motion", SimInput::Motion);
        setup.input("param_set", SimInput::Param);
        setup.input("inject_failure", SimInput::Inject);
        setup.input("esc_pulses", SimInput::Pulses);
        setup.timer("step", Duration::from_micros(tick_us), SimInput::Step);
        Ok(SimActor {
            sim,
            imu: setup.output("imu"),
            imu2: setup.output("imu2"),
            gps: setup.output("gps"),
            baro: setup.output("baro"),
            mag: setup.output("mag"),
            rangefinder_up: setup.output("rangefinder_up"),
            rangefinder_down: setup.output("rangefinder_down"),
            ground_truth: setup.output("ground_truth"),
            battery: setup.output("battery"),
            esc_telemetry: setup.output("esc_telemetry"),
            obstacle_map: setup.output("obstacle_map"),
            sim_fault: setup.output("sim_fault"),
            map_published: false,
            imu_raw: setup.output("imu_raw"),
            mag_raw: setup.output("mag_raw"),
            param_decl: setup.output("param_decl"),
            calibration: CalibrationParams::default(),
            esc_ranges: EscRanges::default(),
            direct: DirectPulses::default(),
            armed: false,
            live: LiveFaults::default(),
            failure_result: setup.output("failure_result"),
            name: setup.name().to_owned(),
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        self.param_decl.publish(self.declaration(true, ctx.now()));
        Ok(())
    }

    async fn handle(&mut self, ctx: &Context, input: SimInput) -> Result<(), ActorError> {
        match input {
            SimInput::Actuators(outputs) => {
                self.armed = outputs.armed;
                self.sim.set_actuators(&outputs);
            }
            SimInput::Pulses(pulses) => {
                if let Err(e) = self.direct.on_message(&pulses, ctx.now()) {
                    tracing::warn!(actor = %self.name, "direct ESC pulses refused, outputs at the disarmed pulse: {e}");
                }
                self.sim.set_direct_pulses(self.direct.pulses_us(ctx.now(), self.armed));
            }
            SimInput::Motion(m) => self.sim.set_calibration_motion(m.motion),
            SimInput::Param(p) => {
                // Calibration and pulse ranges are disarmed-only: refused here too while the
                // newest commands say armed (the link refuses first; a bench may not have one).
                let mut outcome =
                    apply_set(&CALIBRATION_PARAMS, &mut self.calibration, &p, self.armed, |c| {
                        c.calibration().map(|_| ())
                    });
                if let Ok(ParamChange::Applied) = outcome
                    && let Ok(calibration) = self.calibration.calibration()
                {
                    self.sim.set_calibration(calibration);
                }
                if let Ok(ParamChange::NotMine) = outcome {
                    outcome = self.set_esc_range(&p);
                }
                if let Ok(ParamChange::NotMine) = outcome {
                    outcome = self.set_live_fault(&p);
                }
                if answer(&self.name, &p, outcome) {
                    self.param_decl.publish(self.declaration(false, p.time));
                }
            }
            SimInput::Inject(request) => {
                let outcome = self.live.inject(&request, &mut self.sim);
                tracing::info!(unit = ?request.unit, failure = ?request.failure, instance = request.instance, ?outcome, "failure injection");
                self.failure_result.publish(FailureInjectionResult {
                    time: self.sim.time(),
                    id: request.id,
                    outcome,
                });
            }
            SimInput::Step(time) => {
                if !self.map_published {
                    self.obstacle_map.publish(obstacle_map(self.sim.world(), self.sim.time()));
                    self.map_published = true;
                }
                self.sim.set_direct_pulses(self.direct.pulses_us(time, self.armed));
                self.sim.advance_to(time);
                for raw in self.sim.drain_raw() {
                    match raw {
                        RawSample::Imu(m) => self.imu_raw.publish(m),
                        RawSample::Mag(m) => self.mag_raw.publish(m),
                    }
                }
                for output in self.sim.drain() {
                    match output {
                        SimOutput::Imu(m) => self.imu.publish(m),
                        SimOutput::Imu2(m) => self.imu2.publish(m),
                        SimOutput::Gps(m) => self.gps.publish(m),
                        SimOutput::Baro(m) => self.baro.publish(m),
                        SimOutput::Mag(m) => self.mag.publish(m),
                        SimOutput::Rangefinder(m) => match m.orientation {
                            RangefinderOrientation::Up => self.rangefinder_up.publish(m),
                            RangefinderOrientation::Down => self.rangefinder_down.publish(m),
                        },
                        SimOutput::GroundTruth(m) => self.ground_truth.publish(m),
                        SimOutput::Battery(m) => self.battery.publish(m),
                        SimOutput::Esc(m) => self.esc_telemetry.publish(m),
                        SimOutput::Fault(m) => {
                            let what = if m.phase == SimFaultPhase::Started { "started" } else { "ended" };
                            tracing::info!(
                                at = %m.time,
                                index = m.index,
                                kind = %m.kind,
                                values = %m.values,
                                "simulated fault {what}"
                            );
                            self.sim_fault.publish(m);
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

impl SimActor {
    /// What the simulator owns of the link's parameter table: the calibration and the live
    /// faults, as one declaration (an owner's declaration is the whole of its parameters).
    fn declaration(&self, start: bool, time: Time) -> ParamDecl {
        let mut decl = declare(&CALIBRATION_PARAMS, &self.calibration, &self.name, start, time);
        let motors = self.sim.vehicle().frame.motor_count();
        decl.params
            .extend(declare(esc_range_params(motors), &self.esc_ranges, &self.name, start, time).params);
        let mut live = declare(&LIVE_FAULT_PARAMS, self.live.params(), &self.name, start, time).params;
        for p in &mut live {
            p.integer = INTEGER_PARAMS.contains(&p.name.as_str());
        }
        decl.params.extend(live);
        decl
    }

    /// An output's pulse range: checked, then used for the commands from now on.
    fn set_esc_range(&mut self, set: &ParamSet) -> Result<ParamChange, ParamRefused> {
        let motors = self.sim.vehicle().frame.motor_count();
        let change =
            apply_set(esc_range_params(motors), &mut self.esc_ranges, set, self.armed, EscRanges::validate)?;
        if change == ParamChange::Applied {
            self.sim.set_esc_ranges(&self.esc_ranges);
        }
        Ok(change)
    }

    /// A live fault parameter: checked, then its group's fault restarted on the schedule.
    fn set_live_fault(&mut self, set: &ParamSet) -> Result<ParamChange, ParamRefused> {
        let motors = self.sim.vehicle().frame.motor_count();
        let mut params = self.live.params().clone();
        let change = apply(&LIVE_FAULT_PARAMS, &mut params, &set.name, set.value, |p| p.validate(motors))?;
        if change == ParamChange::Applied {
            self.live
                .set_params(params, &mut self.sim)
                .map_err(|e| ParamRefused::Invalid { name: set.name.clone(), reason: e.to_string() })?;
        }
        Ok(change)
    }
}

/// The simulator core `params` describe, its vehicle file changed by `adjust`, starting on the
/// IMU tick at or before `now`, and that tick's period (µs). Files resolve against `dir`.
pub(crate) fn simulator(
    params: &SimActorParams,
    dir: &Path,
    now: Time,
    adjust: fn(&mut VehicleParams),
) -> Result<(Simulator, u64), ActorError> {
    let dir = dir.to_path_buf();
    let mut vehicle =
        VehicleParams::load(&dir.join(&params.vehicle)).map_err(|e| ActorError::Params(e.to_string()))?;
    adjust(&mut vehicle);
    let world = World::load(&dir.join(&params.world)).map_err(|e| ActorError::Params(e.to_string()))?;
    let tick_us = period_us(vehicle.sensors.imu.rate_hz);
    let mut initial = params.initial_position_ned_m;
    initial[1] += INSTANCE_SPACING_M * f64::from(params.instance);
    let options = SimOptions {
        seed: params.seed.wrapping_add(u64::from(params.instance)),
        physics_substeps: params.physics_substeps,
        ground_truth_rate_hz: params.ground_truth_rate_hz,
        battery_rate_hz: params.battery_rate_hz,
        start_time: Time(now.0 / tick_us * tick_us),
        initial: InitialState {
            body: RigidBodyState { position_ned_m: initial.into(), ..RigidBodyState::default() },
            actuators: ActuatorOutputs::default(),
        },
    };
    let world_path = dir.join(&params.world);
    let sim = Simulator::new(vehicle, world, options).map_err(|e| {
        // Faults are checked against the vehicle here, so name the world file they are in.
        if e.field.starts_with("faults[") {
            ActorError::Params(format!("invalid {}: {e}", world_path.display()))
        } else {
            ActorError::Params(e.to_string())
        }
    })?;
    Ok((sim, tick_us))
}

/// The world's obstacles as loaded (generated ones included) in the log's message form, stamped
/// `time`.
fn obstacle_map(world: &World, time: Time) -> ObstacleMap {
    ObstacleMap { time, home: world.home.geodetic(), obstacles: world.obstacles.clone() }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::Obstacle;

    use super::*;

    #[test]
    fn the_map_carries_every_obstacle_and_home() {
        let world = World {
            obstacles: vec![
                Obstacle::Cylinder { base_ne_m: [15.0, -3.0], radius_m: 0.6, height_m: 8.0 },
                Obstacle::Wall {
                    from_ne_m: [50.0, -10.0],
                    to_ne_m: [50.0, 10.0],
                    height_m: 6.0,
                    thickness_m: 0.3,
                    textured: false,
                },
            ],
            ..World::default()
        };
        let map = obstacle_map(&world, Time::from_micros(2500));
        assert_eq!(map.time, Time::from_micros(2500));
        assert_eq!(map.home, world.home.geodetic());
        assert_eq!(
            map.obstacles,
            [
                Obstacle::Cylinder { base_ne_m: [15.0, -3.0], radius_m: 0.6, height_m: 8.0 },
                Obstacle::Wall {
                    from_ne_m: [50.0, -10.0],
                    to_ne_m: [50.0, 10.0],
                    height_m: 6.0,
                    thickness_m: 0.3,
                    textured: false,
                },
            ]
        );
    }
}
