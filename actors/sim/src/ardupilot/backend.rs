//! The simulator as ArduPilot SITL's JSON physics backend: one servo packet in, one physics
//! frame stepped, one JSON state out. Pure and synchronous; [`super::server`] is its UDP shell.
//!
//! Lockstep: every new `frame_count` runs exactly one simulator tick, whose length is the
//! backend's `frame_rate_hz` (the simulator's IMU rate is set to it, one physics step a tick).
//! SITL advances its own clock by the difference of the `timestamp`s it receives
//! (`SIM_JSON.cpp`, `recv_fdm`), so ArduCopter's clock *is* the simulator's, whatever rate its
//! packets announce. A repeated `frame_count` (SITL resends after a second without an answer)
//! gets the same answer again and steps nothing (`a_resent_frame_steps_nothing`).
//!
//! Motors: channel `i` (SERVO`i+1`) drives motor `i` of the frame in
//! `kestrel_proto::frame_layout`'s order, which is ArduCopter's own motor numbering (Motor1 is
//! the default SERVO1_FUNCTION 33, …). The pulses go to the simulated ESCs as they are, each read
//! against its own `esc_range_us` exactly as a pulse from a PWM output would be (0, "no pulse",
//! stops the motor). A pulse no ESC accepts (outside 800..2200 µs and not 0) stops its motor and
//! is counted in [`Summary::refused_pulses`]: ArduCopter never sends one, so one is a fault to see.
//!
//! State out, in the protocol's frames and units: `imu.gyro` (rad/s, body FRD), `imu.accel_body`
//! (m/s², specific force in body FRD: `[0, 0, −g]` at rest), `position` (m, NED from home),
//! `velocity` (m/s, NED), `quaternion` ([w, x, y, z], body FRD to NED — the simulator's own
//! convention), `timestamp` (s of physics time) and, when the vehicle has a downward
//! rangefinder, `rng_1` (m, its newest reading, its maximum when nothing returned).

use std::fmt::Write;

use kestrel_proto::esc::{SAFE_PULSE_MAX_US, SAFE_PULSE_MIN_US};
use kestrel_proto::messages::{ActuatorOutputs, MAX_MOTORS, RangefinderOrientation};
use kestrel_proto::units::GRAVITY_M_S2;
use nalgebra::Vector3;

use super::packet::{PacketError, ServoPacket};
use crate::error::InvalidParam;
use crate::faults::Fault;
use crate::rigid_body::RigidBodyState;
use crate::simulator::{InitialState, SimOptions, SimOutput, Simulator};
use crate::vehicle::VehicleParams;
use crate::world::World;

/// Slowest physics the backend runs (Hz): the simulator's own floor.
pub const MIN_FRAME_RATE_HZ: f64 = 400.0;
/// Fastest (Hz): the simulator's IMU ceiling.
pub const MAX_FRAME_RATE_HZ: f64 = 10_000.0;

/// What a run did, from the simulator's side.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Physics frames stepped.
    pub frames: u64,
    /// Physics time at the last frame (s).
    pub time_s: f64,
    /// Collisions with the world's obstacles (the simulator's count).
    pub collisions: u32,
    /// Least distance from the vehicle's centre to an obstacle surface over the run (m);
    /// `None` in a world without obstacles.
    pub least_clearance_m: Option<f64>,
    /// Whether the vehicle rests on the ground now.
    pub landed: bool,
    /// Whether it touched the ground too fast or too tilted at some point.
    pub crashed: bool,
    /// Position at the last frame, NED from home (m).
    pub position_ned_m: [f64; 3],
    /// Pulses outside every ESC's range (see the module docs), over the run.
    pub refused_pulses: u64,
    /// Packets that were not servo packets, over the run (counted by the shell).
    pub refused_packets: u64,
    /// Physics time the vehicle first left the ground (s); `None` while it never has.
    pub take_off_s: Option<f64>,
    /// Faults started counting from take-off ([`JsonBackend::with_faults_from_take_off`]).
    pub faults_started: u32,
}

/// One sample of the truth trace (`JsonBackend::trace_every`): what a scenario runner scores
/// ArduCopter's flight on, in the units and frames of `GroundTruth`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TraceSample {
    /// Physics time (s): the `timestamp` SITL was sent with this state.
    pub t_s: f64,
    /// Position north, east, down from home (m).
    pub position_ned_m: [f64; 3],
    /// Velocity north, east, down (m/s).
    pub velocity_ned_m_s: [f64; 3],
    /// Attitude `[w, x, y, z]`, body FRD to NED.
    pub attitude: [f64; 4],
    /// Resting on the ground.
    pub landed: bool,
    /// The simulated battery: terminal voltage (V) and current drawn (A).
    pub voltage_v: f64,
    pub current_a: f64,
}

/// Samples a trace keeps without growing: ten minutes at 50 Hz.
const TRACE_CAPACITY: usize = 30_000;

/// The simulator answering ArduPilot SITL.
#[derive(Debug)]
pub struct JsonBackend {
    sim: Simulator,
    last_frame: Option<u32>,
    /// The answer to the last frame, kept for a resend; its capacity is kept, so steady-state
    /// answering does not allocate.
    reply: String,
    pulses_us: [f64; MAX_MOTORS],
    range_down_m: Option<f64>,
    range_down_max_m: f64,
    has_range_down: bool,
    least_clearance_m: f64,
    summary: Summary,
    /// Frames between truth samples; 0 = no trace.
    trace_every: u64,
    trace: Vec<TraceSample>,
    /// The world's faults when they count from take-off: each with the schedule index it got
    /// once started.
    from_take_off: Vec<(Fault, Option<usize>)>,
}

impl JsonBackend {
    /// A backend flying `vehicle` in `world` at `frame_rate_hz` physics frames a second, from
    /// `start` (`RigidBodyState::default()`: at rest on the ground at home, facing north).
    pub fn new(
        mut vehicle: VehicleParams,
        world: World,
        seed: u64,
        frame_rate_hz: f64,
        start: RigidBodyState,
    ) -> Result<JsonBackend, InvalidParam> {
        if !(MIN_FRAME_RATE_HZ..=MAX_FRAME_RATE_HZ).contains(&frame_rate_hz) {
            return Err(InvalidParam::new(
                "frame_rate_hz",
                format!("{frame_rate_hz} Hz: must be within {MIN_FRAME_RATE_HZ}..={MAX_FRAME_RATE_HZ}"),
            ));
        }
        // One tick per frame, one physics step per tick: the frame is the physics step.
        vehicle.sensors.imu.rate_hz = frame_rate_hz;
        if let Some(imu2) = &mut vehicle.sensors.imu2 {
            imu2.rate_hz = frame_rate_hz;
        }
        let initial = InitialState { body: start, ..InitialState::default() };
        let options = SimOptions { seed, physics_substeps: 1, initial, ..SimOptions::default() };
        let has_range_down = vehicle.sensors.rangefinder_down.is_some();
        let range_down_max_m = vehicle.sensors.rangefinder_down.as_ref().map_or(0.0, |r| r.max_range_m);
        let mut sim = Simulator::new(vehicle, world, options)?;
        // Disarmed commands, so the ESCs take the pulses (`Simulator::set_direct_pulses`).
        sim.set_actuators(&ActuatorOutputs::default());
        Ok(JsonBackend {
            sim,
            last_frame: None,
            reply: String::with_capacity(512),
            pulses_us: [0.0; MAX_MOTORS],
            range_down_m: None,
            range_down_max_m,
            has_range_down,
            least_clearance_m: f64::INFINITY,
            summary: Summary::default(),
            trace_every: 0,
            trace: Vec::new(),
            from_take_off: Vec::new(),
        })
    }

    /// The same, but the world's `[[faults]]` count their `at_s` from the moment the vehicle
    /// first leaves the ground instead of from the start: ArduCopter takes off after EKF3's GPS
    /// wait and a ground station's commands, at no physics time known in advance, and a fault
    /// "mid-leg" must come mid-leg (`faults_from_take_off_start_at_take_off_plus_at_s`). The
    /// faults are checked against the vehicle here, as `Simulator::new` checks a world's.
    pub fn with_faults_from_take_off(
        vehicle: VehicleParams,
        mut world: World,
        seed: u64,
        frame_rate_hz: f64,
        start: RigidBodyState,
    ) -> Result<JsonBackend, InvalidParam> {
        // Validation only: the faults against this vehicle, exactly as a world that holds them.
        JsonBackend::new(vehicle.clone(), world.clone(), seed, frame_rate_hz, start)?;
        let faults = std::mem::take(&mut world.faults);
        let mut backend = JsonBackend::new(vehicle, world, seed, frame_rate_hz, start)?;
        backend.from_take_off = faults.into_iter().map(|f| (f, None)).collect();
        Ok(backend)
    }

    /// Answers one datagram from SITL: the JSON to send back (newline-framed), or why the
    /// datagram was refused (then nothing is stepped and nothing should be sent).
    pub fn answer(&mut self, datagram: &[u8]) -> Result<&str, PacketError> {
        let packet = ServoPacket::parse(datagram)?;
        if self.last_frame == Some(packet.frame_count) && !self.reply.is_empty() {
            return Ok(&self.reply);
        }
        self.last_frame = Some(packet.frame_count);
        self.set_pulses(&packet);
        self.step();
        self.write_reply();
        Ok(&self.reply)
    }

    fn set_pulses(&mut self, packet: &ServoPacket) {
        let motors = self.sim.vehicle().frame.motor_count().min(packet.channels);
        for (i, pulse) in self.pulses_us.iter_mut().enumerate() {
            let pwm = if i < motors { f64::from(packet.pwm_us[i]) } else { 0.0 };
            let accepted = pwm == 0.0 || (SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US).contains(&pwm);
            if !accepted {
                self.summary.refused_pulses += 1;
            }
            *pulse = if accepted { pwm } else { 0.0 };
        }
        self.sim.set_direct_pulses(Some(&self.pulses_us));
    }

    fn step(&mut self) {
        self.sim.step();
        for output in self.sim.drain() {
            if let SimOutput::Rangefinder(sample) = output
                && sample.orientation == RangefinderOrientation::Down
            {
                self.range_down_m = sample.distance_m;
            }
        }
        self.least_clearance_m = self.least_clearance_m.min(self.sim.clearance_m());
        self.summary.frames += 1;
        let now_s = self.sim.time().0 as f64 * 1e-6;
        if self.summary.take_off_s.is_none() && !self.sim.landed() {
            self.summary.take_off_s = Some(now_s);
        }
        if let Some(take_off_s) = self.summary.take_off_s {
            self.start_and_end_faults(now_s - take_off_s);
        }
        if self.trace_every > 0 && self.summary.frames.is_multiple_of(self.trace_every) {
            let (state, battery) = (self.sim.state(), self.sim.battery_status());
            let q = state.attitude;
            self.trace.push(TraceSample {
                t_s: self.sim.time().0 as f64 * 1e-6,
                position_ned_m: state.position_ned_m.into(),
                velocity_ned_m_s: state.velocity_ned_m_s.into(),
                attitude: [q.w, q.i, q.j, q.k],
                landed: self.sim.landed(),
                voltage_v: battery.voltage_v,
                current_a: battery.current_a,
            });
        }
    }

    /// Starts each fault held for take-off once `since_s` (s since take-off) reaches its `at_s`,
    /// and ends it `for_s` later.
    fn start_and_end_faults(&mut self, since_s: f64) {
        for (fault, started) in &mut self.from_take_off {
            match *started {
                None if since_s >= fault.at_s => {
                    // Checked against the vehicle in `with_faults_from_take_off`, so this holds.
                    if let Ok(index) = self.sim.add_fault(fault.kind.clone()) {
                        *started = Some(index);
                        self.summary.faults_started += 1;
                    }
                }
                Some(index) if fault.for_s.is_some_and(|f| since_s >= fault.at_s + f) => {
                    self.sim.end_fault(index);
                    fault.for_s = None;
                }
                _ => {}
            }
        }
    }

    /// Keeps a truth sample every `period_s` of physics time (rounded to whole frames, at least
    /// one) from now on: [`JsonBackend::trace`]. Its first ten minutes at 50 Hz are reserved
    /// here, so tracing a flight of that length does not allocate per frame.
    pub fn trace_every(&mut self, period_s: f64) -> Result<(), InvalidParam> {
        if !(period_s.is_finite() && period_s > 0.0) {
            return Err(InvalidParam::new("trace period", format!("{period_s} s: must be positive")));
        }
        let frame_s = self.sim.tick_period().as_secs_f64();
        self.trace_every = ((period_s / frame_s).round() as u64).max(1);
        self.trace.reserve(TRACE_CAPACITY);
        Ok(())
    }

    /// The truth samples kept so far (`trace_every`).
    pub fn trace(&self) -> &[TraceSample] {
        &self.trace
    }

    fn write_reply(&mut self) {
        let state = self.sim.state();
        let q = state.attitude;
        let accel_ned_m_s2 = Vector3::from(self.sim.ground_truth().acceleration_ned_m_s2);
        let specific_force_frd = q.inverse() * (accel_ned_m_s2 - Vector3::new(0.0, 0.0, GRAVITY_M_S2));
        let gyro = state.angular_velocity_frd_rad_s;
        let p = state.position_ned_m;
        let v = state.velocity_ned_m_s;
        let time_s = self.sim.time().0 as f64 * 1e-6;
        let r = &mut self.reply;
        r.clear();
        // SIM_JSON's parser wants no space after a colon; the values are finite (the simulator
        // checks its inputs), so `{}` never writes NaN here.
        let _ = write!(
            r,
            "\n{{\"timestamp\":{time_s:.6},\"imu\":{{\"gyro\":[{:.7},{:.7},{:.7}],\"accel_body\":[{:.6},{:.6},{:.6}]}},\
             \"position\":[{:.5},{:.5},{:.5}],\"velocity\":[{:.6},{:.6},{:.6}],\"quaternion\":[{:.8},{:.8},{:.8},{:.8}]",
            gyro.x,
            gyro.y,
            gyro.z,
            specific_force_frd.x,
            specific_force_frd.y,
            specific_force_frd.z,
            p.x,
            p.y,
            p.z,
            v.x,
            v.y,
            v.z,
            q.w,
            q.i,
            q.j,
            q.k,
        );
        if self.has_range_down {
            let _ = write!(r, ",\"rng_1\":{:.3}", self.range_down_m.unwrap_or(self.range_down_max_m));
        }
        r.push_str("}\n");
    }

    /// The simulator core, for inspection.
    pub fn simulator(&self) -> &Simulator {
        &self.sim
    }

    /// What the run did so far.
    pub fn summary(&self) -> Summary {
        let sim = &self.sim;
        Summary {
            time_s: sim.time().0 as f64 * 1e-6,
            collisions: sim.collisions(),
            least_clearance_m: Some(self.least_clearance_m).filter(|c| c.is_finite()),
            landed: sim.landed(),
            crashed: sim.crashed(),
            position_ned_m: sim.state().position_ned_m.into(),
            ..self.summary.clone()
        }
    }

    /// Counts a datagram the shell refused (for the summary).
    pub fn count_refused_packet(&mut self) {
        self.summary.refused_packets += 1;
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use nalgebra::{UnitQuaternion, Vector3};

    use super::*;
    use crate::ardupilot::packet::MAX_CHANNELS;

    const RATE_HZ: f64 = 1200.0;

    fn vehicle(file: &str) -> VehicleParams {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/vehicles").join(file);
        VehicleParams::load(&path).unwrap()
    }

    /// A backend with the vehicle at rest `height_m` above home, facing `yaw_deg`.
    fn backend(vehicle: VehicleParams, height_m: f64, yaw_deg: f64) -> JsonBackend {
        let start = RigidBodyState {
            position_ned_m: Vector3::new(0.0, 0.0, -height_m),
            attitude: UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_deg.to_radians()),
            ..RigidBodyState::default()
        };
        JsonBackend::new(vehicle, World::default(), 1, RATE_HZ, start).unwrap()
    }

    fn packet(frame_count: u32, pwm: &[u16]) -> Vec<u8> {
        let mut pwm_us = [0; MAX_CHANNELS];
        pwm_us[..pwm.len()].copy_from_slice(pwm);
        ServoPacket { frame_rate_hz: 1200, frame_count, pwm_us, channels: 16 }.to_bytes()
    }

    /// The state SITL would read: parses the reply as JSON (which SIM_JSON's parser is not).
    fn fly(backend: &mut JsonBackend, first_frame: u32, frames: u32, pwm: &[u16]) -> serde_json::Value {
        let mut reply = String::new();
        for n in first_frame..first_frame + frames {
            reply = backend.answer(&packet(n, pwm)).unwrap().to_owned();
        }
        serde_json::from_str(&reply).unwrap()
    }

    fn vector(json: &serde_json::Value, path: &[&str]) -> Vec<f64> {
        let mut value = json;
        for key in path {
            value = &value[key];
        }
        value.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
    }

    /// The quad's hover pulse by hand: weight / (4 motors × k_f·ω_max²) = 1.5 × 9.80665 /
    /// (4 × 1.1e-5 × 1000²) = 0.33432 of full thrust, on a 1000..2000 µs ESC 1334.3 µs.
    const QUAD_HOVER_US: u16 = 1334;

    #[test]
    fn quad_hovers_at_the_hand_computed_pulse_and_climbs_or_sinks_either_side() {
        let mut quad = vehicle("quad_x.toml");
        // Without airframe drag, so the fall while the motors spin up does not decay and read as
        // thrust: the speed then changes only by thrust minus weight.
        quad.drag.linear_n_per_m_s = 0.0;
        quad.drag.quadratic_n_per_m2_s2 = 0.0;
        assert_eq!(quad.mass_kg, 1.5);
        assert_eq!(quad.motor.max_thrust_n(), 11.0);
        let vz_after_2_s = |pwm_us: u16| {
            let mut b = backend(quad.clone(), 50.0, 0.0);
            // The motors spin up from rest for 0.5 s, then the vertical speed is measured 2 s on.
            let settled = fly(&mut b, 0, 600, &[pwm_us; 4]);
            let later = fly(&mut b, 600, 2400, &[pwm_us; 4]);
            (vector(&later, &["velocity"])[2] - vector(&settled, &["velocity"])[2], later)
        };
        let (dv_hover, hover) = vz_after_2_s(QUAD_HOVER_US);
        assert!(
            dv_hover.abs() < 0.05,
            "at {QUAD_HOVER_US} µs the vertical speed changed by {dv_hover} m/s in 2 s"
        );
        // Hovering, the IMU feels one g upwards: specific force [0, 0, −g] in FRD.
        let accel = vector(&hover, &["imu", "accel_body"]);
        assert!(accel[0].abs() < 1e-6 && accel[1].abs() < 1e-6, "{accel:?}");
        assert!((accel[2] + GRAVITY_M_S2).abs() < 0.05, "{accel:?}");
        assert!(vz_after_2_s(QUAD_HOVER_US + 20).0 < -0.5, "20 µs above hover climbs (NED down < 0)");
        assert!(vz_after_2_s(QUAD_HOVER_US - 20).0 > 0.5, "20 µs below hover sinks");
    }

    #[test]
    fn at_rest_on_the_ground_the_imu_feels_one_g_up_and_nothing_moves() {
        let mut b = backend(vehicle("quad_x.toml"), 0.0, 0.0);
        let state = fly(&mut b, 0, 120, &[1000; 4]);
        assert_eq!(
            vector(&state, &["imu", "accel_body"]),
            [0.0, 0.0, -GRAVITY_M_S2].map(|x| (x * 1e6f64).round() / 1e6)
        );
        assert_eq!(vector(&state, &["imu", "gyro"]), [0.0; 3]);
        assert_eq!(vector(&state, &["position"]), [0.0; 3]);
        assert_eq!(vector(&state, &["velocity"]), [0.0; 3]);
        assert_eq!(vector(&state, &["quaternion"]), [1.0, 0.0, 0.0, 0.0]);
        assert!((state["timestamp"].as_f64().unwrap() - 0.1).abs() < 1e-3, "120 frames at 1200 Hz: {state}");
    }

    /// Quad-X, ArduCopter's order: 1 front-right CCW, 2 rear-left CCW, 3 front-left CW, 4
    /// rear-right CW. The left pair (2, 3) 50 µs up and the right pair (1, 4) 50 µs down: one CW
    /// and one CCW each side, so no yaw; one front and one rear each side, so no pitch. By hand,
    /// roll torque = 2 × (0.225 m × sin 45°) × 11 N × 0.1 = 0.3500 N·m, and over
    /// I_xx = 0.029 kg·m² a roll acceleration of +12.07 rad/s² (right side down).
    #[test]
    fn left_motors_up_is_a_pure_positive_roll_of_the_hand_computed_size() {
        let mut b = backend(vehicle("quad_x.toml"), 50.0, 0.0);
        fly(&mut b, 0, 600, &[QUAD_HOVER_US; 4]);
        let (up, down) = (QUAD_HOVER_US + 50, QUAD_HOVER_US - 50);
        let roll = [down, up, up, down];
        // 0.25 s for the motors to settle (6 time constants), then 0.05 s measured.
        let a = vector(&fly(&mut b, 600, 300, &roll), &["imu", "gyro"]);
        let b_ = vector(&fly(&mut b, 900, 60, &roll), &["imu", "gyro"]);
        let accel_rad_s2: Vec<f64> = a.iter().zip(&b_).map(|(a, b)| (b - a) / 0.05).collect();
        let expected = 2.0 * 0.225 * std::f64::consts::FRAC_1_SQRT_2 * 11.0 * 0.1 / 0.029;
        assert!((accel_rad_s2[0] - expected).abs() < 0.02 * expected, "{accel_rad_s2:?} vs {expected}");
        assert!(accel_rad_s2[1].abs() < 1e-3 && accel_rad_s2[2].abs() < 1e-3, "{accel_rad_s2:?}");
    }

    /// The counter-clockwise pair (1, 2) up and the clockwise pair (3, 4) down: their reaction
    /// turns the body clockwise seen from above, a positive yaw rate in FRD, and nothing else.
    #[test]
    fn counter_clockwise_motors_up_yaw_the_body_clockwise() {
        let mut b = backend(vehicle("quad_x.toml"), 50.0, 0.0);
        fly(&mut b, 0, 600, &[QUAD_HOVER_US; 4]);
        let (up, down) = (QUAD_HOVER_US + 50, QUAD_HOVER_US - 50);
        let gyro = vector(&fly(&mut b, 600, 300, &[up, up, down, down]), &["imu", "gyro"]);
        assert!(gyro[2] > 0.1, "{gyro:?}");
        assert!(gyro[0].abs() < 1e-6 && gyro[1].abs() < 1e-6, "{gyro:?}");
    }

    /// Hexa-X, ArduCopter's order: motor 1 at 90° (right) CW, motor 2 at −90° (left) CCW. Motor 1
    /// up and motor 2 down rolls left (negative) and, both reactions turning the body
    /// anticlockwise, yaws negative; the pair lies on the pitch axis, so no pitch torque.
    #[test]
    fn hexa_motor_one_is_right_clockwise_and_two_left_counter_clockwise() {
        let hexa = vehicle("hexa_x.toml");
        let hover_us = 1000 + (1000.0 * crate::vehicle::hover_throttle(&hexa)).round() as u16;
        let mut b = backend(hexa, 50.0, 0.0);
        fly(&mut b, 0, 600, &[hover_us; 6]);
        let mut pwm = [hover_us; 6];
        pwm[0] += 50;
        pwm[1] -= 50;
        let gyro = vector(&fly(&mut b, 600, 120, &pwm), &["imu", "gyro"]);
        assert!(gyro[0] < -0.1 && gyro[2] < -0.01, "{gyro:?}");
        // Only the gyroscopic coupling of roll and yaw, (I_zz − I_xx)·p·r, pitches it.
        assert!(gyro[1].abs() < 1e-3, "{gyro:?}");
    }

    /// Facing east (yaw +90°), ArduPilot's [w, x, y, z] body-to-NED quaternion is
    /// [cos 45°, 0, 0, sin 45°], and its Euler yaw atan2(2(wz + xy), 1 − 2(y² + z²)) is +90°.
    #[test]
    fn facing_east_is_the_quarter_turn_quaternion_about_down() {
        let mut b = backend(vehicle("quad_x.toml"), 0.0, 90.0);
        let q = vector(&fly(&mut b, 0, 12, &[1000; 4]), &["quaternion"]);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        for (got, want) in q.iter().zip([h, 0.0, 0.0, h]) {
            assert!((got - want).abs() < 1e-7, "{q:?}");
        }
        let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
        let yaw_deg = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z)).to_degrees();
        assert!((yaw_deg - 90.0).abs() < 1e-5, "{yaw_deg}");
    }

    /// On the ground at home with the motors stopped, then at 1600 µs (well above the 1334 µs
    /// hover): a trace every 0.05 s keeps one sample per 60 frames at 1200 Hz, stamped with
    /// the physics time, landed until the climb and drawing current from the battery once the
    /// motors spin.
    #[test]
    fn a_trace_samples_the_truth_every_period() {
        let mut b = backend(vehicle("quad_x.toml"), 0.0, 0.0);
        b.trace_every(0.05).unwrap();
        fly(&mut b, 0, 600, &[1000; 4]);
        fly(&mut b, 600, 1200, &[1600; 4]);
        let trace = b.trace();
        assert_eq!(trace.len(), 30);
        let frame_s = b.simulator().tick_period().as_secs_f64();
        assert!((trace[0].t_s - 60.0 * frame_s).abs() < 1e-9, "{:?}", trace[0]);
        assert!(trace[..10].iter().all(|s| s.landed && s.position_ned_m == [0.0; 3]));
        let last = trace.last().unwrap();
        assert!(!last.landed && last.position_ned_m[2] < -0.5, "climbed: {last:?}");
        assert!(last.current_a > trace[0].current_a + 1.0, "{:?} then {last:?}", trace[0]);
        assert!(b.trace_every(0.0).is_err() && b.trace_every(f64::NAN).is_err());
    }

    /// A motor lost 0.5 s after take-off, for 0.5 s: nothing while the vehicle sits on the
    /// ground for 2 s, then the fault starts 0.5 s after it leaves (the schedule has it there) and
    /// ends at 1 s.
    #[test]
    fn faults_from_take_off_start_at_take_off_plus_at_s() {
        let world = World {
            faults: vec![Fault {
                at_s: 0.5,
                for_s: Some(0.5),
                kind: crate::FaultKind::MotorLost { motor: 1 },
            }],
            ..World::default()
        };
        let mut b = JsonBackend::with_faults_from_take_off(
            vehicle("quad_x.toml"),
            world,
            1,
            RATE_HZ,
            RigidBodyState::default(),
        )
        .unwrap();
        fly(&mut b, 0, 2400, &[1000; 4]);
        assert_eq!((b.summary().take_off_s, b.summary().faults_started), (None, 0));
        assert!(b.simulator().faults().faults().is_empty());
        fly(&mut b, 2400, 2400, &[1700; 4]);
        let summary = b.summary();
        let take_off_s = summary.take_off_s.expect("took off");
        assert!(take_off_s > 2.0, "{summary:?}");
        assert_eq!(summary.faults_started, 1);
        let started = &b.simulator().faults().faults()[0];
        assert!(
            (started.at_s - (take_off_s + 0.5)).abs() < 2e-3,
            "{started:?} after take-off at {take_off_s}"
        );
        // A motor index the vehicle lacks is refused up front, as in a world file.
        let bad = World {
            faults: vec![Fault { at_s: 0.5, for_s: None, kind: crate::FaultKind::MotorLost { motor: 9 } }],
            ..World::default()
        };
        assert!(
            JsonBackend::with_faults_from_take_off(
                vehicle("quad_x.toml"),
                bad,
                1,
                RATE_HZ,
                RigidBodyState::default()
            )
            .is_err()
        );
    }

    #[test]
    fn a_resent_frame_steps_nothing_and_gets_the_same_answer() {
        let mut b = backend(vehicle("quad_x.toml"), 0.0, 0.0);
        let first = b.answer(&packet(5, &[1000; 4])).unwrap().to_owned();
        let again = b.answer(&packet(5, &[1900; 4])).unwrap().to_owned();
        assert_eq!(first, again);
        assert_eq!(b.summary().frames, 1);
        let next = b.answer(&packet(6, &[1000; 4])).unwrap().to_owned();
        assert_ne!(first, next);
        assert_eq!(b.summary().frames, 2);
    }

    #[test]
    fn the_reply_is_framed_by_newlines_with_no_space_after_a_colon() {
        let mut b = backend(vehicle("quad_x.toml"), 0.0, 0.0);
        let reply = b.answer(&packet(0, &[1000; 4])).unwrap();
        assert!(reply.starts_with("\n{") && reply.ends_with("}\n"), "{reply:?}");
        assert!(!reply.contains(": ") && !reply.contains(", "), "{reply:?}");
        for key in ["timestamp", "imu", "gyro", "accel_body", "position", "velocity", "quaternion", "rng_1"] {
            assert!(reply.contains(&format!("\"{key}\":")), "{key} missing in {reply:?}");
        }
    }

    #[test]
    fn a_pulse_no_esc_accepts_stops_its_motor_and_is_counted() {
        let mut b = backend(vehicle("quad_x.toml"), 50.0, 0.0);
        fly(&mut b, 0, 600, &[QUAD_HOVER_US, QUAD_HOVER_US, QUAD_HOVER_US, 2500]);
        assert_eq!(b.summary().refused_pulses, 600);
        assert!(b.simulator().motor_speeds_rad_s()[3] < 1.0, "{:?}", b.simulator().motor_speeds_rad_s());
        assert!(b.simulator().motor_speeds_rad_s()[0] > 500.0);
    }

    #[test]
    fn a_frame_rate_outside_the_simulators_range_is_refused_by_name() {
        let e =
            JsonBackend::new(vehicle("quad_x.toml"), World::default(), 1, 100.0, RigidBodyState::default())
                .unwrap_err();
        assert!(e.to_string().contains("frame_rate_hz"), "{e}");
    }
}
