//! The simulator core: physics, world and sensors stepped together on integer-microsecond time.
//!
//! One *tick* is one IMU sample period (2.5 ms at 400 Hz); each tick runs `physics_substeps`
//! Runge–Kutta steps (default 2, so physics runs at 800 Hz), then samples every sensor that is
//! due and releases every sample whose lag has elapsed into an output buffer the caller drains.
//! The buffer and the lag queues keep their capacity, so steady-state stepping does not
//! allocate. Everything is deterministic given the seed.
//!
//! The world's `[[faults]]` are a [`FaultSchedule`]: each tick takes the effects of the faults
//! active at its time and hands each model its part (the models apply them to their own output),
//! and releases a [`SimOutput::Fault`] for every start and end.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::calibration::SensorCalibration;
use kestrel_proto::esc::EscRanges;
use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{
    ActuatorOutputs, BaroSample, BatteryStatus, EscTelemetry, GpsFix, GroundTruth, ImuSample, MAX_MOTORS,
    MagSample, Motion, RangefinderOrientation, RangefinderSample, SimFault,
};
use nalgebra::{UnitQuaternion, Vector3};

use crate::battery::Battery;
use crate::error::{InvalidParam, finite, rate};
use crate::faults::{Fault, FaultEffects, FaultKind, FaultSchedule, check_for_vehicle};
use crate::ground::Ground;
use crate::handling::{Handling, pose};
use crate::motors::Motors;
use crate::obstacles::Collisions;
use crate::rigid_body::{RigidBody, RigidBodyState, Wrench};
use crate::sensors::baro::Baro;
use crate::sensors::gps::Gps;
use crate::sensors::imu::{Imu, ImuFaults};
use crate::sensors::mag::Mag;
use crate::sensors::noise::{Stream, rng};
use crate::sensors::rangefinder::Rangefinder;
use crate::sensors::schedule::{Delayed, Periodic, period_us};
use crate::vehicle::VehicleParams;
use crate::wind::Wind;
use crate::world::World;
use kestrel_proto::units::GRAVITY_M_S2;

/// The physics must run at least this fast (Hz).
const MIN_PHYSICS_RATE_HZ: f64 = 400.0;

/// Run settings that belong to neither the vehicle nor the world.
#[derive(Clone, Debug)]
pub struct SimOptions {
    /// Seed of every random stream (wind, sensor noise).
    pub seed: u64,
    /// Physics steps per IMU sample; IMU rate × substeps must reach 400 Hz.
    pub physics_substeps: u32,
    /// Rate of `GroundTruth` outputs (Hz).
    pub ground_truth_rate_hz: f64,
    /// Rate of `BatteryStatus` outputs (Hz).
    pub battery_rate_hz: f64,
    /// Simulation time at start; sensor schedules count from here.
    pub start_time: Time,
    pub initial: InitialState,
}

impl Default for SimOptions {
    fn default() -> SimOptions {
        SimOptions {
            seed: 0,
            physics_substeps: 2,
            ground_truth_rate_hz: 50.0,
            battery_rate_hz: 10.0,
            start_time: Time::ZERO,
            initial: InitialState::default(),
        }
    }
}

/// Where the vehicle starts and how its motors are already spinning.
#[derive(Clone, Debug, Default)]
pub struct InitialState {
    /// Default: at rest, level, facing north, on the ground at home.
    pub body: RigidBodyState,
    /// The motors start settled at these commands (default: disarmed, stopped), so a test can
    /// start in hover without a spin-up transient. They stay commanded until the next
    /// [`Simulator::set_actuators`].
    pub actuators: ActuatorOutputs,
}

/// Something the simulator released, in release order.
#[derive(Clone, Debug, PartialEq)]
pub enum SimOutput {
    Imu(ImuSample),
    /// A sample of the second IMU (`[sensors.imu2]`), at the same tick as the first's.
    Imu2(ImuSample),
    Gps(GpsFix),
    Baro(BaroSample),
    Mag(MagSample),
    /// A rangefinder's sample (`[sensors.rangefinder_up]`, `[sensors.rangefinder_down]`); its
    /// `orientation` says which.
    Rangefinder(RangefinderSample),
    GroundTruth(GroundTruth),
    Battery(BatteryStatus),
    /// What the motors produce, every tick, as bidirectional-DShot ESCs report it with each
    /// command (the fault included: a lost motor reports no thrust).
    Esc(EscTelemetry),
    /// A fault started or ended at this tick (released before the tick's samples).
    Fault(SimFault),
}

/// A simulated multirotor in its world.
#[derive(Clone, Debug)]
pub struct Simulator {
    vehicle: VehicleParams,
    world: World,
    body: RigidBody,
    state: RigidBodyState,
    motors: Motors,
    wind: Wind,
    battery: Battery,
    ground: Ground,
    collisions: Collisions,
    frame: LocalFrame,
    field_ned_gauss: Vector3<f64>,
    imu: Imu,
    imu2: Option<Imu>,
    gps: Gps,
    baro: Baro,
    mag: Mag,
    /// The rangefinders the vehicle file fits (none, up, down or both), each with its own
    /// schedule and lag.
    rangefinders: Vec<Rangefinder>,
    gps_due: Periodic,
    baro_due: Periodic,
    mag_due: Periodic,
    truth_due: Periodic,
    battery_due: Periodic,
    gps_pending: Delayed<GpsFix>,
    baro_pending: Delayed<BaroSample>,
    mag_pending: Delayed<MagSample>,
    faults: FaultSchedule,
    /// What the faults active at the last tick did.
    effects: FaultEffects,
    time: Time,
    tick_us: u64,
    substeps: u32,
    accel_ned_m_s2: Vector3<f64>,
    /// Applied to IMU and magnetometer samples as a driver would; `None` until set, so an
    /// uncalibrated run does no arithmetic it did not do before.
    calibration: Option<SensorCalibration>,
    outputs: Vec<SimOutput>,
    /// What the calibration asks of the person handling the vehicle, since when, and from which
    /// heading; while it is not idle the physics stops and the pose is the person's.
    motion: Motion,
    motion_since: Time,
    motion_yaw_rad: f64,
    handling: Handling,
    /// Raw board-frame samples (before `calibration`) taken while a motion is asked for.
    raw: Vec<RawSample>,
    /// The newest motor commands.
    actuators: ActuatorOutputs,
    /// Direct pulses the ESCs get instead while disarmed (µs; ESC calibration).
    direct_pulses_us: Option<[f64; MAX_MOTORS]>,
}

/// A sensor sample before calibration, for the calibration itself.
#[derive(Clone, Debug, PartialEq)]
pub enum RawSample {
    Imu(ImuSample),
    Mag(MagSample),
}

impl Simulator {
    /// A simulator for `vehicle` in `world`; checks every parameter first.
    pub fn new(vehicle: VehicleParams, world: World, options: SimOptions) -> Result<Simulator, InvalidParam> {
        vehicle.validate()?;
        world.validate()?;
        validate_options(&options, vehicle.sensors.imu.rate_hz)?;
        check_for_vehicle(&world.faults, vehicle.frame.motor_count())?;
        let seed = options.seed;
        let start = options.start_time;
        let sensors = &vehicle.sensors;
        let mut motors = Motors::new(&vehicle.motor, vehicle.frame, vehicle.arm_length_m);
        motors.command(&options.initial.actuators);
        motors.settle();
        let body = RigidBody {
            mass_kg: vehicle.mass_kg,
            inertia_frd_kg_m2: Vector3::from(vehicle.inertia_frd_kg_m2),
        };
        let state = options.initial.body;
        let mut collisions = Collisions::new();
        collisions.update(&world.obstacles, &state.position_ned_m, vehicle.contact.collision_radius_m);
        let ground = Ground { landed: state.position_ned_m.z >= 0.0, crashed: false };
        Ok(Simulator {
            body,
            state,
            motors,
            wind: Wind::new(&world.wind, rng(seed, Stream::Wind)),
            battery: Battery::new(&vehicle.battery),
            ground,
            collisions,
            frame: LocalFrame::new(world.home.geodetic()),
            field_ned_gauss: world.magnetic_field.ned_gauss(),
            imu: Imu::new(&sensors.imu, sensors.board_rotation(), rng(seed, Stream::Imu)),
            imu2: sensors
                .imu2
                .as_ref()
                .map(|p| Imu::new(p, sensors.board_rotation(), rng(seed, Stream::Imu2))),
            gps: Gps::new(&sensors.gps, rng(seed, Stream::Gps)),
            baro: Baro::new(&sensors.baro, rng(seed, Stream::Baro)),
            mag: Mag::new(&sensors.mag, sensors.board_rotation(), rng(seed, Stream::Mag)),
            rangefinders: [
                (RangefinderOrientation::Up, &sensors.rangefinder_up, Stream::RangefinderUp),
                (RangefinderOrientation::Down, &sensors.rangefinder_down, Stream::RangefinderDown),
            ]
            .into_iter()
            .filter_map(|(orientation, params, stream)| {
                Some(Rangefinder::new(orientation, params.as_ref()?, rng(seed, stream), start))
            })
            .collect(),
            gps_due: Periodic::new(sensors.gps.rate_hz, start),
            baro_due: Periodic::new(sensors.baro.rate_hz, start),
            mag_due: Periodic::new(sensors.mag.rate_hz, start),
            truth_due: Periodic::new(options.ground_truth_rate_hz, start),
            battery_due: Periodic::new(options.battery_rate_hz, start),
            gps_pending: Delayed::new(sensors.gps.lag_s, sensors.gps.rate_hz),
            baro_pending: Delayed::new(sensors.baro.lag_s, sensors.baro.rate_hz),
            mag_pending: Delayed::new(sensors.mag.lag_s, sensors.mag.rate_hz),
            faults: FaultSchedule::new(&world.faults),
            effects: FaultEffects::default(),
            time: start,
            tick_us: period_us(sensors.imu.rate_hz),
            substeps: options.physics_substeps,
            accel_ned_m_s2: Vector3::zeros(),
            calibration: None,
            outputs: Vec::with_capacity(64),
            motion: Motion::Idle,
            motion_since: start,
            motion_yaw_rad: 0.0,
            handling: Handling::Careful,
            raw: Vec::new(),
            actuators: options.initial.actuators.clone(),
            direct_pulses_us: None,
            vehicle,
            world,
        })
    }

    /// Simulation time of the last completed tick.
    pub fn time(&self) -> Time {
        self.time
    }

    /// Length of one tick (the IMU sample period).
    pub fn tick_period(&self) -> Duration {
        Duration::from_micros(self.tick_us)
    }

    /// The vehicle being simulated.
    pub fn vehicle(&self) -> &VehicleParams {
        &self.vehicle
    }

    /// The world it flies in.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Corrects every IMU and magnetometer sample measured from now on with `calibration`, as
    /// the hardware drivers do: the sensor path of a simulated vehicle whose calibration ran.
    pub fn set_calibration(&mut self, calibration: SensorCalibration) {
        self.calibration = Some(calibration);
    }

    /// The calibration applied to sensor samples, if one was set.
    pub fn calibration(&self) -> Option<&SensorCalibration> {
        self.calibration.as_ref()
    }

    /// How the simulated person handles the vehicle during calibrations.
    pub fn set_handling(&mut self, handling: Handling) {
        self.handling = handling;
    }

    /// Handles the vehicle as a calibration asks (see `handling.rs`), only while it stands on
    /// the ground: in flight the request is ignored. Back to idle, it is set down level on its
    /// legs where it stood, facing as it did.
    pub fn set_calibration_motion(&mut self, motion: Motion) {
        if motion == self.motion || (self.motion == Motion::Idle && !self.ground.landed) {
            return;
        }
        if self.motion == Motion::Idle {
            self.motion_yaw_rad = self.state.attitude.euler_angles().2;
        }
        self.motion = motion;
        self.motion_since = self.time;
        // The simulated person takes the propellers off for an ESC calibration, and back on.
        self.motors.set_props_on(motion != Motion::PropsOff);
        if motion == Motion::Idle {
            self.state.attitude = UnitQuaternion::from_euler_angles(0.0, 0.0, self.motion_yaw_rad);
            self.state.angular_velocity_frd_rad_s = Vector3::zeros();
            self.state.velocity_ned_m_s = Vector3::zeros();
        }
    }

    /// The motion being carried out.
    pub fn calibration_motion(&self) -> Motion {
        self.motion
    }

    /// Takes the raw samples taken since the last call.
    pub fn drain_raw(&mut self) -> std::vec::Drain<'_, RawSample> {
        self.raw.drain(..)
    }

    /// One tick in the person's hands: the pose at `time`, its rate from the last pose, still.
    fn handle_vehicle(&mut self, time: Time, tick_s: f64) -> bool {
        let t_s = time.saturating_since(self.motion_since).as_secs_f64();
        let Some(attitude) = pose(self.motion, self.handling, t_s, self.motion_yaw_rad) else {
            return false;
        };
        let step = self.state.attitude.inverse() * attitude;
        self.state.angular_velocity_frd_rad_s = step.scaled_axis() / tick_s;
        self.state.attitude = attitude;
        self.state.velocity_ned_m_s = Vector3::zeros();
        true
    }

    /// Sets the motor commands used from now on.
    pub fn set_actuators(&mut self, outputs: &ActuatorOutputs) {
        self.actuators.clone_from(outputs);
        self.command_motors();
    }

    /// The outputs' command → pulse map (`SERVOn_MIN`/`SERVOn_MAX`) from now on.
    pub fn set_esc_ranges(&mut self, ranges: &EscRanges) {
        self.motors.set_output_ranges(ranges);
        self.command_motors();
    }

    /// Pulses (µs) the ESCs get directly while the commands say disarmed, or `None` for the
    /// commands again: the caller has checked and timed them out (`kestrel_proto::esc::DirectPulses`).
    pub fn set_direct_pulses(&mut self, pulses_us: Option<&[f64; MAX_MOTORS]>) {
        if self.direct_pulses_us.as_ref() != pulses_us {
            self.direct_pulses_us = pulses_us.copied();
            self.command_motors();
        }
    }

    fn command_motors(&mut self) {
        match &self.direct_pulses_us {
            Some(pulses_us) if !self.actuators.armed => self.motors.command_pulses(pulses_us),
            _ => self.motors.command(&self.actuators),
        }
    }

    /// Runs whole ticks until the next one would pass `time`.
    pub fn advance_to(&mut self, time: Time) {
        while self.time.0 + self.tick_us <= time.0 {
            self.step();
        }
    }

    /// The fault schedule (the world's `[[faults]]`, and any added since).
    pub fn faults(&self) -> &FaultSchedule {
        &self.faults
    }

    /// Adds a fault from the next tick on, to the end of the run or until [`Simulator::end_fault`]
    /// (a live parameter or MAV_CMD_INJECT_FAILURE); returns its index in the schedule.
    pub fn add_fault(&mut self, kind: FaultKind) -> Result<usize, InvalidParam> {
        let fault = Fault { at_s: self.time.0 as f64 * 1e-6, for_s: None, kind };
        fault.validate()?;
        check_for_vehicle(std::slice::from_ref(&fault), self.vehicle.frame.motor_count())?;
        self.faults.push(fault);
        Ok(self.faults.faults().len() - 1)
    }

    /// Ends fault `index` (added by [`Simulator::add_fault`]) from the next tick on.
    pub fn end_fault(&mut self, index: usize) {
        self.faults.end_after(index, self.time);
    }

    /// What the faults active at the last tick did.
    pub fn fault_effects(&self) -> &FaultEffects {
        &self.effects
    }

    /// Runs one tick: faults, physics, then sensors, then releases.
    pub fn step(&mut self) {
        let tick_s = self.tick_us as f64 * 1e-6;
        let dt_s = tick_s / f64::from(self.substeps);
        let tick_time = Time(self.time.0 + self.tick_us);
        self.apply_faults(tick_time);
        let velocity_before = self.state.velocity_ned_m_s;
        let air_ned_m_s = self.wind.advance(self.tick_us, !self.ground.landed, self.effects.wind.as_ref());
        let weight_ned_n = Vector3::new(0.0, 0.0, self.body.mass_kg * GRAVITY_M_S2);
        let handled = self.handle_vehicle(tick_time, tick_s);
        for _ in 0..if handled { 0 } else { self.substeps } {
            self.motors.advance(dt_s);
            let (thrust_frd_n, torque_frd_n_m) = self.motors.force_torque_frd();
            let drag = &self.vehicle.drag;
            self.body.step(&mut self.state, dt_s, |s| Wrench {
                force_ned_n: s.attitude * thrust_frd_n
                    + weight_ned_n
                    + drag.force_ned_n(&(s.velocity_ned_m_s - air_ned_m_s)),
                torque_frd_n_m: torque_frd_n_m + drag.torque_frd_n_m(&s.angular_velocity_frd_rad_s),
            });
            self.ground.resolve(&self.vehicle.contact, &mut self.state);
        }
        self.time = tick_time;
        self.accel_ned_m_s2 = (self.state.velocity_ned_m_s - velocity_before) / tick_s;
        self.battery.draw(self.motors.shaft_power_w() / self.vehicle.motor.efficiency, tick_s);
        self.collisions.update(
            &self.world.obstacles,
            &self.state.position_ned_m,
            self.vehicle.contact.collision_radius_m,
        );
        self.sample_sensors(tick_s);
    }

    /// Takes the effects of the faults active at `time` (the tick about to run), hands the
    /// motors and the battery theirs, and releases every start and end.
    fn apply_faults(&mut self, time: Time) {
        if self.faults.faults().is_empty() {
            return;
        }
        for event in self.faults.poll(time) {
            self.outputs.push(SimOutput::Fault(self.faults.message(&event)));
        }
        self.effects = self.faults.effects_at(time);
        self.motors.set_faults(&self.effects.motors);
        self.battery.set_faults(&self.effects.battery);
    }

    fn sample_sensors(&mut self, tick_s: f64) {
        let now = self.time;
        let faults = &self.effects;
        let mut imu = self.imu.measure(now, tick_s, &self.state, &self.accel_ned_m_s2, &faults.imu);
        let raw = self.motion.wants_raw_samples();
        if raw {
            self.raw.push(RawSample::Imu(imu.clone()));
        }
        if let Some(calibration) = &self.calibration {
            imu = calibration.apply_imu(&imu);
        }
        if !faults.imu.stopped {
            self.outputs.push(SimOutput::Imu(imu));
        }
        if let Some(imu2) = &mut self.imu2 {
            // The faults are the first IMU's: one stream stopping is what the second is for.
            let sample = imu2.measure(now, tick_s, &self.state, &self.accel_ned_m_s2, &ImuFaults::default());
            self.outputs.push(SimOutput::Imu2(sample));
        }
        if self.gps_due.due(now) {
            let fix = self.gps.measure(now, &self.state, &self.frame, &faults.gps);
            self.gps_pending.push(now, fix);
        }
        if self.baro_due.due(now) {
            let altitude_msl_m = self.world.home.alt_msl_m - self.state.position_ned_m.z;
            let sample = self.baro.measure(now, altitude_msl_m, &faults.baro);
            self.baro_pending.push(now, sample);
        }
        if self.mag_due.due(now) {
            let mut sample = self.mag.measure(now, &self.state, &self.field_ned_gauss, &faults.mag);
            if raw {
                self.raw.push(RawSample::Mag(sample.clone()));
            }
            if let Some(calibration) = &self.calibration {
                sample = calibration.apply_mag(&sample);
            }
            self.mag_pending.push(now, sample);
        }
        self.gps_pending.release(now, |m| self.outputs.push(SimOutput::Gps(m)));
        self.baro_pending.release(now, |m| self.outputs.push(SimOutput::Baro(m)));
        self.mag_pending.release(now, |m| self.outputs.push(SimOutput::Mag(m)));
        for rangefinder in &mut self.rangefinders {
            rangefinder.step(now, &self.state, &self.world.obstacles, |m| {
                self.outputs.push(SimOutput::Rangefinder(m));
            });
        }
        if self.truth_due.due(now) {
            let truth = self.ground_truth();
            self.outputs.push(SimOutput::GroundTruth(truth));
        }
        if self.battery_due.due(now) {
            let status = self.battery_status();
            self.outputs.push(SimOutput::Battery(status));
        }
        let esc = self.esc_telemetry();
        self.outputs.push(SimOutput::Esc(esc));
    }

    /// Takes everything released so far, in release order. Undrained outputs accumulate.
    pub fn drain(&mut self) -> std::vec::Drain<'_, SimOutput> {
        self.outputs.drain(..)
    }

    /// The true kinematic state.
    pub fn state(&self) -> &RigidBodyState {
        &self.state
    }

    /// Current motor speeds in mixer order (rad/s).
    pub fn motor_speeds_rad_s(&self) -> &[f64] {
        self.motors.speeds_rad_s()
    }

    /// True while the vehicle rests on the ground.
    pub fn landed(&self) -> bool {
        self.ground.landed
    }

    /// True once the vehicle has touched the ground too fast or too tilted.
    pub fn crashed(&self) -> bool {
        self.ground.crashed
    }

    /// Collisions with obstacles so far.
    pub fn collisions(&self) -> u32 {
        self.collisions.count
    }

    /// Distance from the vehicle's centre to the nearest obstacle surface (m).
    pub fn clearance_m(&self) -> f64 {
        self.collisions.clearance_m
    }

    /// The ground-truth message for now.
    pub fn ground_truth(&self) -> GroundTruth {
        let s = &self.state;
        let q = s.attitude.into_inner();
        let position = self.frame.to_geodetic(s.position_ned_m.into());
        GroundTruth {
            time: self.time,
            position_ned_m: s.position_ned_m.into(),
            velocity_ned_m_s: s.velocity_ned_m_s.into(),
            acceleration_ned_m_s2: self.accel_ned_m_s2.into(),
            attitude: [q.w, q.i, q.j, q.k],
            angular_velocity_rad_s: s.angular_velocity_frd_rad_s.into(),
            lat_deg: position.lat_deg,
            lon_deg: position.lon_deg,
            alt_msl_m: position.alt_m,
            landed: self.ground.landed,
            crashed: self.ground.crashed,
            collisions: self.collisions.count,
            clearance_m: Some(self.collisions.clearance_m).filter(|c| c.is_finite()),
        }
    }

    /// The ESC telemetry for now.
    pub fn esc_telemetry(&self) -> EscTelemetry {
        EscTelemetry {
            time: self.time,
            count: self.vehicle.frame.motor_count() as u8,
            thrust: self.motors.thrust_fractions(),
            speed_rad_s: self.motors.speeds_all_rad_s(),
        }
    }

    /// The battery message for now.
    pub fn battery_status(&self) -> BatteryStatus {
        BatteryStatus {
            time: self.time,
            voltage_v: self.battery.voltage_v(),
            current_a: self.battery.current_a(),
            consumed_mah: self.battery.consumed_mah(),
            remaining: self.battery.remaining(),
        }
    }
}

fn validate_options(options: &SimOptions, imu_rate_hz: f64) -> Result<(), InvalidParam> {
    if !(1..=64).contains(&options.physics_substeps) {
        return Err(InvalidParam::new("physics_substeps", "must be within 1..=64"));
    }
    let physics_rate_hz = imu_rate_hz * f64::from(options.physics_substeps);
    if physics_rate_hz < MIN_PHYSICS_RATE_HZ {
        return Err(InvalidParam::new(
            "physics_substeps",
            format!(
                "gives {physics_rate_hz} Hz physics with a {imu_rate_hz} Hz IMU; at least 400 Hz is needed"
            ),
        ));
    }
    rate("ground_truth_rate_hz", options.ground_truth_rate_hz)?;
    rate("battery_rate_hz", options.battery_rate_hz)?;
    let body = &options.initial.body;
    finite("initial.position_ned_m", body.position_ned_m.as_slice())?;
    finite("initial.velocity_ned_m_s", body.velocity_ned_m_s.as_slice())?;
    finite("initial.angular_velocity_frd_rad_s", body.angular_velocity_frd_rad_s.as_slice())?;
    if body.position_ned_m.z > 0.0 {
        return Err(InvalidParam::new(
            "initial.position_ned_m",
            "must not start below the ground (down > 0)",
        ));
    }
    Ok(())
}
