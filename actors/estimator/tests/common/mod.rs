//! A closed-loop simulated flight for the estimator tests: the simulator core stepped
//! synchronously, its motors driven by a small geometric controller on ground truth, its sensor
//! streams fed to the EKF, and the estimate scored against ground truth.

use kestrel_estimator::{Ekf, EkfParams};
use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{ActuatorOutputs, GpsFix, GroundTruth, MagSample, NavState};
use kestrel_sim::{
    FrameLayout, GRAVITY_M_S2, RigidBodyState, SimOptions, SimOutput, Simulator, VehicleParams, WindParams,
    World,
};
use nalgebra::{Matrix3, Matrix4, UnitQuaternion, Vector3, Vector4};

/// Seconds the vehicle sits still on the ground before take-off (alignment).
pub const GROUND_S: f64 = 3.0;
/// Seconds after take-off before errors are scored (climb-out, filter convergence).
pub const SETTLE_S: f64 = 20.0;

/// The reference trajectory at flight time `tau` (s after take-off): position NED (m) and yaw
/// (rad). A Lissajous figure with climbs and turns, faded in over the first seconds.
fn reference(tau: f64) -> (Vector3<f64>, f64) {
    let tau = tau.max(0.0);
    let ramp = smoothstep(tau / 12.0);
    let w = 2.0 * std::f64::consts::PI / 40.0;
    let north = 20.0 * (w * tau).sin() * ramp;
    let east = 12.0 * (2.0 * w * tau).sin() * ramp;
    let down = -(10.0 + 4.0 * (0.5 * w * tau).sin() * ramp) * smoothstep(tau / 8.0);
    let yaw = 1.2 * (2.0 * std::f64::consts::PI * tau / 50.0).sin() * ramp;
    (Vector3::new(north, east, down), yaw)
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)
}

/// Position, velocity, acceleration and yaw of the reference (numerical derivatives).
fn reference_kinematics(tau: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>, f64) {
    let h = 1e-3;
    let (p0, yaw) = reference(tau);
    let (pm, _) = reference(tau - h);
    let (pp, _) = reference(tau + h);
    (p0, (pp - pm) / (2.0 * h), (pp - 2.0 * p0 + pm) / (h * h), yaw)
}

/// A geometric position/attitude controller and quad-X mixer, on ground truth.
struct Controller {
    mass_kg: f64,
    inertia: Vector3<f64>,
    mixer_inverse: Matrix4<f64>,
    max_thrust_n: f64,
}

impl Controller {
    fn new(vehicle: &VehicleParams) -> Controller {
        let k =
            vehicle.motor.torque_coefficient_n_m_per_rad2_s2 / vehicle.motor.thrust_coefficient_n_per_rad2_s2;
        let mut mixer = Matrix4::zeros();
        for (i, m) in FrameLayout::QuadX.motors(vehicle.arm_length_m).enumerate() {
            let r = m.position_frd_m;
            mixer.set_column(i, &Vector4::new(1.0, -r.y, r.x, m.spin.yaw_sign() * k));
        }
        Controller {
            mass_kg: vehicle.mass_kg,
            inertia: Vector3::from(vehicle.inertia_frd_kg_m2),
            mixer_inverse: mixer.try_inverse().expect("quad-X mixer is invertible"),
            max_thrust_n: vehicle.motor.max_thrust_n(),
        }
    }

    fn outputs(&self, s: &RigidBodyState, tau: f64) -> ActuatorOutputs {
        let (p_ref, v_ref, a_ref, yaw) = reference_kinematics(tau);
        let mut a = a_ref + (p_ref - s.position_ned_m) * 1.2 + (v_ref - s.velocity_ned_m_s) * 2.2;
        let horizontal = a.xy().norm();
        if horizontal > 5.0 {
            a.x *= 5.0 / horizontal;
            a.y *= 5.0 / horizontal;
        }
        let force = (a - Vector3::new(0.0, 0.0, GRAVITY_M_S2)) * self.mass_kg;
        let z_b = -force.normalize();
        let x_c = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
        let y_b = z_b.cross(&x_c).normalize();
        let x_b = y_b.cross(&z_b);
        let r_des = Matrix3::from_columns(&[x_b, y_b, z_b]);
        let r = s.attitude.to_rotation_matrix().into_inner();
        let e = r_des.transpose() * r - r.transpose() * r_des;
        let e_r = Vector3::new(e[(2, 1)], e[(0, 2)], e[(1, 0)]) * 0.5;
        let alpha = -e_r * 40.0 - s.angular_velocity_frd_rad_s * 10.0;
        let torque = alpha.component_mul(&self.inertia);
        let thrust = force.dot(&-(r * Vector3::z()));
        let per_motor = self.mixer_inverse * Vector4::new(thrust.max(0.0), torque.x, torque.y, torque.z);
        let mut out = ActuatorOutputs { time: Time::ZERO, armed: true, motors: [0.0; 8] };
        for (m, t) in out.motors.iter_mut().zip(per_motor.iter()) {
            *m = (t / self.max_thrust_n).clamp(0.0, 1.0);
        }
        out
    }
}

/// What to do to the sensor streams before the EKF sees them.
#[derive(Clone, Copy, Debug, Default)]
pub struct Faults {
    /// GPS fixes valid in this flight-time window are shifted 50 m north.
    pub gps_jump: Option<(f64, f64)>,
    /// GPS fixes valid in this flight-time window are dropped.
    pub gps_loss: Option<(f64, f64)>,
    /// Magnetometer samples in this flight-time window are rotated 60° about body down.
    pub mag_disturbance: Option<(f64, f64)>,
}

/// One scored instant.
#[derive(Clone, Debug)]
pub struct Sample {
    /// Flight time (s after take-off).
    pub tau: f64,
    pub truth: GroundTruth,
    pub nav: NavState,
    /// Estimated position in the simulator's home frame (m).
    pub est_pos_home_m: Vector3<f64>,
}

/// A GPS fix as it arrived: arrival flight time and its NED position/velocity in home frame.
#[derive(Clone, Debug)]
pub struct Arrival {
    pub tau: f64,
    pub pos_home_m: Vector3<f64>,
    pub vel_ned_m_s: Vector3<f64>,
}

/// Everything a flight recorded.
pub struct FlightLog {
    pub samples: Vec<Sample>,
    /// Present estimate at every IMU tick: (flight time, position home frame, velocity).
    pub track: Vec<(f64, Vector3<f64>, Vector3<f64>)>,
    pub gps: Vec<Arrival>,
    /// Normalised estimation error squared of attitude, velocity and height at the delayed
    /// horizon: (flight time, NEES with 7 degrees of freedom).
    pub nees: Vec<(f64, f64)>,
    pub ekf: Ekf,
}

/// The simulated world: Moratuwa, wind from the south-west with gusts.
pub fn world() -> World {
    World {
        wind: WindParams { steady_ned_m_s: [2.0, 1.5, 0.0], gust_std_m_s: 0.8, gust_time_constant_s: 2.0 },
        ..World::default()
    }
}

/// Estimator parameters for the simulated vehicle (declination from the world file).
pub fn params() -> EkfParams {
    EkfParams { mag_declination_deg: world().magnetic_field.declination_deg, ..EkfParams::default() }
}

fn flight_time(t: Time) -> f64 {
    t.as_secs_f64() - GROUND_S
}

/// Flies the reference for `flight_s` seconds after `GROUND_S` on the ground.
pub fn fly(params: EkfParams, flight_s: f64, faults: Faults, seed: u64) -> FlightLog {
    let vehicle = VehicleParams::default();
    let world = world();
    let home = LocalFrame::new(world.home.geodetic());
    let controller = Controller::new(&vehicle);
    let options = SimOptions { seed, ..SimOptions::default() };
    let mut sim = Simulator::new(vehicle, world, options).expect("valid simulator setup");
    let mut ekf = Ekf::new(params).expect("valid parameters");
    let mut samples = Vec::new();
    let mut track = Vec::new();
    let mut gps = Vec::new();
    let mut nees = Vec::new();
    let mut truths: std::collections::HashMap<u64, GroundTruth> = std::collections::HashMap::new();
    let end = Time::from_secs_f64(GROUND_S + flight_s);
    let in_window = |w: Option<(f64, f64)>, tau: f64| w.is_some_and(|(a, b)| tau >= a && tau < b);
    while sim.time() < end {
        let tau = flight_time(sim.time());
        if tau >= 0.0 {
            sim.set_actuators(&controller.outputs(sim.state(), tau));
        }
        sim.step();
        let outputs: Vec<SimOutput> = sim.drain().collect();
        for out in outputs {
            match out {
                SimOutput::Imu(s) => {
                    ekf.push_imu(&s).expect("simulated IMU is valid");
                    if let (Some(nav), Some(frame)) = (ekf.nav_state(), ekf.frame()) {
                        let p = home.to_ned(frame.to_geodetic(nav.position_ned_m));
                        track.push((
                            flight_time(s.time),
                            Vector3::from(p),
                            Vector3::from(nav.velocity_ned_m_s),
                        ));
                    }
                }
                SimOutput::Gps(fix) => {
                    let valid_tau = flight_time(fix.time);
                    if in_window(faults.gps_loss, valid_tau) {
                        continue;
                    }
                    let fix =
                        if in_window(faults.gps_jump, valid_tau) { shifted(&fix, &home, 50.0) } else { fix };
                    let pos = home.to_ned(Geodetic {
                        lat_deg: fix.lat_deg,
                        lon_deg: fix.lon_deg,
                        alt_m: fix.alt_msl_m,
                    });
                    gps.push(Arrival {
                        tau: flight_time(sim.time()),
                        pos_home_m: Vector3::from(pos),
                        vel_ned_m_s: Vector3::from(fix.vel_ned_m_s),
                    });
                    ekf.push_gps(&fix).expect("finite fix");
                }
                SimOutput::Baro(b) => ekf.push_baro(&b).expect("finite baro"),
                SimOutput::Mag(m) => {
                    let m =
                        if in_window(faults.mag_disturbance, flight_time(m.time)) { rotated(&m) } else { m };
                    ekf.push_mag(&m).expect("finite mag");
                }
                SimOutput::GroundTruth(truth) => {
                    truths.insert(truth.time.as_micros(), truth.clone());
                    if let Some(v) = delayed_nees(&ekf, &truths) {
                        nees.push((flight_time(truth.time), v));
                    }
                    if let (Some(nav), Some(frame)) = (ekf.nav_state(), ekf.frame()) {
                        let p = home.to_ned(frame.to_geodetic(nav.position_ned_m));
                        // Height is scored against the barometric reference the filter uses
                        // (zero at the alignment spot), not against the first fix's altitude.
                        let est = Vector3::new(p[0], p[1], nav.position_ned_m[2]);
                        samples.push(Sample {
                            tau: flight_time(truth.time),
                            truth,
                            nav,
                            est_pos_home_m: est,
                        });
                    }
                }
                SimOutput::Battery(_) => {}
            }
        }
    }
    FlightLog { samples, track, gps, nees, ekf }
}

/// NEES of attitude, velocity and height of the delayed state against the truth at its time.
fn delayed_nees(ekf: &Ekf, truths: &std::collections::HashMap<u64, GroundTruth>) -> Option<f64> {
    let state = ekf.delayed_state()?;
    let truth = truths.get(&state.time.as_micros())?;
    let p = ekf.covariance()?;
    let [w, x, y, z] = truth.attitude;
    let q_true = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
    let mut e = nalgebra::SVector::<f64, 7>::zeros();
    e.fixed_rows_mut::<3>(0).copy_from(&(q_true * state.attitude.inverse()).scaled_axis());
    e.fixed_rows_mut::<3>(3).copy_from(&(Vector3::from(truth.velocity_ned_m_s) - state.vel_ned_m_s));
    e[6] = truth.position_ned_m[2] - state.pos_ned_m.z;
    let mut sub = nalgebra::SMatrix::<f64, 7, 7>::zeros();
    let idx = [0, 1, 2, 3, 4, 5, 8];
    for (i, &a) in idx.iter().enumerate() {
        for (j, &b) in idx.iter().enumerate() {
            sub[(i, j)] = p[(a, b)];
        }
    }
    Some((e.transpose() * sub.try_inverse()? * e)[(0, 0)])
}

fn shifted(fix: &GpsFix, home: &LocalFrame, north_m: f64) -> GpsFix {
    let mut ned = home.to_ned(Geodetic { lat_deg: fix.lat_deg, lon_deg: fix.lon_deg, alt_m: fix.alt_msl_m });
    ned[0] += north_m;
    let g = home.to_geodetic(ned);
    GpsFix { lat_deg: g.lat_deg, lon_deg: g.lon_deg, alt_msl_m: g.alt_m, ..fix.clone() }
}

fn rotated(m: &MagSample) -> MagSample {
    let r = UnitQuaternion::from_euler_angles(0.0, 0.0, 60f64.to_radians());
    MagSample { field_gauss: (r * Vector3::from(m.field_gauss)).into(), ..m.clone() }
}

/// Roll, pitch, yaw errors (rad) of `est` against `truth`, both `[w, x, y, z]` body→NED.
pub fn euler_errors(est: &[f64; 4], truth: &[f64; 4]) -> [f64; 3] {
    let q = |a: &[f64; 4]| UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(a[0], a[1], a[2], a[3]));
    let (re, pe, ye) = q(est).euler_angles();
    let (rt, pt, yt) = q(truth).euler_angles();
    [wrap(re - rt), wrap(pe - pt), wrap(ye - yt)]
}

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
}

/// RMS errors over samples with `tau` in `from..to`.
#[derive(Clone, Copy, Debug)]
pub struct Rms {
    pub horizontal_m: f64,
    pub vertical_m: f64,
    pub velocity_m_s: f64,
    pub roll_deg: f64,
    pub pitch_deg: f64,
    pub yaw_deg: f64,
}

pub fn rms(samples: &[Sample], from: f64, to: f64) -> Rms {
    let mut sums = [0.0; 6];
    let mut n = 0.0;
    for s in samples.iter().filter(|s| s.tau >= from && s.tau < to) {
        let truth_p = Vector3::from(s.truth.position_ned_m);
        let dp = s.est_pos_home_m - truth_p;
        let dv = Vector3::from(s.nav.velocity_ned_m_s) - Vector3::from(s.truth.velocity_ned_m_s);
        let e = euler_errors(&s.nav.attitude, &s.truth.attitude);
        for (sum, v) in sums.iter_mut().zip([
            dp.xy().norm_squared(),
            dp.z * dp.z,
            dv.norm_squared(),
            e[0] * e[0],
            e[1] * e[1],
            e[2] * e[2],
        ]) {
            *sum += v;
        }
        n += 1.0;
    }
    let r = sums.map(|s| (s / n).sqrt());
    Rms {
        horizontal_m: r[0],
        vertical_m: r[1],
        velocity_m_s: r[2],
        roll_deg: r[3].to_degrees(),
        pitch_deg: r[4].to_degrees(),
        yaw_deg: r[5].to_degrees(),
    }
}

/// The shift (s) by which the present estimate leads the raw GPS: the shift minimising the
/// mean squared difference between each arrived fix (position and velocity, normalised by
/// their noise) and the estimate that long before its arrival — the peak of their
/// cross-correlation.
pub fn gps_lead_s(log: &FlightLog, from: f64) -> f64 {
    let dt = 0.0025;
    let t0 = log.track[0].0;
    let at = |tau: f64| {
        let i = ((tau - t0) / dt).round();
        (i >= 0.0).then(|| log.track.get(i as usize)).flatten()
    };
    let mut best = (f64::INFINITY, 0.0);
    for k in 0..=200 {
        let shift = k as f64 * dt;
        let mut cost = 0.0;
        let mut n = 0.0;
        for a in log.gps.iter().filter(|a| a.tau >= from) {
            if let Some((_, p, v)) = at(a.tau - shift) {
                cost +=
                    (p - a.pos_home_m).xy().norm_squared() / 0.25 + (v - a.vel_ned_m_s).norm_squared() / 0.01;
                n += 1.0;
            }
        }
        let cost = cost / n;
        if cost < best.0 {
            best = (cost, shift);
        }
    }
    best.1
}

/// How much the flight covered: horizontal extent (m), height range (m), yaw range (degrees).
pub fn flown(samples: &[Sample]) -> (f64, f64, f64) {
    let range = |f: &dyn Fn(&Sample) -> f64| {
        let (lo, hi) = samples
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
        hi - lo
    };
    let yaw = |s: &Sample| {
        let [w, x, y, z] = s.truth.attitude;
        (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z)).to_degrees()
    };
    let north = range(&|s| s.truth.position_ned_m[0]);
    let east = range(&|s| s.truth.position_ned_m[1]);
    (north.hypot(east), range(&|s| s.truth.position_ned_m[2]), range(&yaw))
}
