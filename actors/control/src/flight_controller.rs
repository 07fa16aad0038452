//! One iteration of the control loop: the newest setpoint and NavState → motor commands.
//!
//! `FlightController` composes the cascade (position → attitude on SO(3) → body rate → mixer)
//! and decides which part runs for each kind of setpoint. It also owns the loop's own
//! failsafes, which act before the commander can: a rejected (non-finite) NavState or none at
//! all flies *blind* (zero torque, thrust a little below hover: level-ish and descending), and a
//! lost setpoint brakes to a stop and descends. It is pure: the lockstep actor calls it once
//! per NavState, the real-time thread once per period.
//!
//! Beside the cascade it runs the [`BackupAttitude`] on the raw IMU, compass and barometer
//! (`on_imu`, `on_mag`, `on_baro`): when the estimator's NavState is stale or unusable the loop
//! flies on the backup's state instead of blind (`fly_without_nav`) — level, on the barometer's
//! height and climb rate, horizontal position unknown — and says so (`flown_backup`), as
//! ArduPilot falls back to DCM when EKF3 fails. Blind flight remains for when the backup has
//! nothing either (not aligned, or no IMU).
//!
//! A quad that lost a motor (the setpoint names it) cannot hold a heading, nor its attitude on
//! the cascade: from then on the outer loops' thrust axis and collective go to
//! [`SpinDescent`], which lets it spin and steers the axis with the three motors left.

use kestrel_proto::Time;
use kestrel_proto::attitude::unit_quaternion;
use kestrel_proto::messages::{
    ActuatorOutputs, BaroSample, MAX_MOTORS, MagSample, NavState, Setpoint, SetpointTarget,
    TrajectorySetpoint,
};
use nalgebra::{UnitQuaternion, Vector3};

use crate::attitude::AttitudeController;
use crate::backup_attitude::{BackupAttitude, ImuReading};
use crate::error::{InvalidParam, RejectedInput};
use crate::live_params::Gains;
use crate::mixer::{Mixer, Saturation};
use crate::params::ControlParams;
use crate::position::{PositionController, yaw_of};
use crate::rate::RateController;
use crate::spin_descent::SpinDescent;

/// Largest step the integrators accept (s): a longer gap (a paused simulation, a stall) is
/// treated as this long.
const MAX_DT_S: f64 = 0.02;
/// Step assumed for the first iteration (s).
const FIRST_DT_S: f64 = 0.0025;

/// What the loop counted since it started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoopCounters {
    /// Setpoints refused (non-finite values, thrust outside 0..1).
    pub rejected_setpoints: u64,
    /// NavStates refused (non-finite values).
    pub rejected_nav: u64,
    /// Iterations flown blind (no usable NavState).
    pub blind_steps: u64,
    /// Iterations flown on the lost-setpoint fallback.
    pub lost_setpoint_steps: u64,
    /// Iterations flown on the backup attitude (the estimator's NavState stale or unusable).
    pub backup_steps: u64,
}

/// The intermediate demands of the last iteration, for logs and tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Demand {
    /// Attitude setpoint (body FRD → NED), when the attitude loop ran.
    pub attitude: Option<UnitQuaternion<f64>>,
    /// Body-rate setpoint (FRD, rad/s).
    pub rates_rad_s: Vector3<f64>,
    /// Torque demand (FRD, N·m).
    pub torque_n_m: Vector3<f64>,
    /// Collective thrust demand (N).
    pub thrust_n: f64,
    pub saturation: Saturation,
}

impl Default for Demand {
    fn default() -> Demand {
        Demand {
            attitude: None,
            rates_rad_s: Vector3::zeros(),
            torque_n_m: Vector3::zeros(),
            thrust_n: 0.0,
            saturation: Saturation::default(),
        }
    }
}

/// The whole control cascade and its state.
#[derive(Clone, Debug)]
pub struct FlightController {
    params: ControlParams,
    hover_thrust: f64,
    mixer: Mixer,
    /// The spinning flight for each motor a quad may lose (`None` on other frames).
    spin: [Option<SpinDescent>; MAX_MOTORS],
    attitude: AttitudeController,
    rate: RateController,
    position: PositionController,
    setpoint: Option<Setpoint>,
    last_step: Option<Time>,
    yaw_hold_rad: Option<f64>,
    counters: LoopCounters,
    demand: Demand,
    /// The complementary filter flown when the estimator's NavState is gone.
    backup: BackupAttitude,
    /// The backup's state the last iteration flew on; `None` when it flew on the estimator's,
    /// blind or idle.
    flown_backup: Option<NavState>,
}

impl FlightController {
    /// A controller with validated parameters.
    pub fn new(params: ControlParams) -> Result<FlightController, InvalidParam> {
        params.validate()?;
        let hover_thrust = params.hover_thrust();
        Ok(FlightController {
            backup: BackupAttitude::new(params.backup)?,
            flown_backup: None,
            mixer: Mixer::new(&params.airframe),
            spin: std::array::from_fn(|lost| SpinDescent::new(&params.airframe, lost)),
            attitude: AttitudeController::new(params.attitude),
            rate: RateController::new(params.rate, params.airframe.inertia_frd_kg_m2),
            position: PositionController::new(params.position, hover_thrust),
            hover_thrust,
            params,
            setpoint: None,
            last_step: None,
            yaw_hold_rad: None,
            counters: LoopCounters::default(),
            demand: Demand::default(),
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &ControlParams {
        &self.params
    }

    /// Takes new gains and limits from the next iteration on (integrators kept). Copies only:
    /// the real-time thread calls this between iterations.
    pub fn retune(&mut self, gains: &Gains) {
        self.params.attitude = gains.attitude;
        self.params.rate = gains.rate;
        self.params.position = gains.position;
        self.attitude.set_gains(gains.attitude);
        self.rate.set_gains(gains.rate);
        self.position.set_gains(gains.position);
    }

    /// The mixer, with the allocation in use.
    pub fn mixer(&self) -> &Mixer {
        &self.mixer
    }

    /// What the loop counted.
    pub fn counters(&self) -> LoopCounters {
        self.counters
    }

    /// The demands of the last iteration.
    pub fn demand(&self) -> &Demand {
        &self.demand
    }

    /// The setpoint being tracked.
    pub fn setpoint(&self) -> Option<&Setpoint> {
        self.setpoint.as_ref()
    }

    /// Takes a new setpoint; a malformed one is refused and counted, and the previous one kept.
    /// Its failed motor, if any, is removed from the allocation from the next iteration on
    /// (a copy of a precomputed allocation: no allocation on the loop).
    pub fn set_setpoint(&mut self, sp: &Setpoint) -> Result<(), RejectedInput> {
        let failed = sp.failed_motor.map(usize::from);
        let checked = check_setpoint(sp)
            .and_then(|()| self.mixer.set_failed_motor(failed).map_err(RejectedInput::NoSuchMotor));
        match checked {
            Ok(()) => {
                // A new kind of target starts a new heading hold; a moving one of the same kind
                // keeps it.
                let previous = self.setpoint.map_or(SetpointTarget::MotorsOff, |s| s.target);
                if std::mem::discriminant(&sp.target) != std::mem::discriminant(&previous) {
                    self.yaw_hold_rad = None;
                }
                self.setpoint = Some(*sp);
                Ok(())
            }
            Err(e) => {
                self.counters.rejected_setpoints += 1;
                Err(e)
            }
        }
    }

    /// An IMU sample for the backup attitude (a refused one is counted there).
    pub fn on_imu(&mut self, imu: &ImuReading) {
        let _ = self.backup.on_imu(imu);
    }

    /// A compass sample for the backup attitude (a refused one is counted there).
    pub fn on_mag(&mut self, mag: &MagSample) {
        let _ = self.backup.on_mag(mag);
    }

    /// A barometer sample for the backup attitude (a refused one is counted there).
    pub fn on_baro(&mut self, baro: &BaroSample) {
        let _ = self.backup.on_baro(baro);
    }

    /// The backup attitude filter.
    pub fn backup(&self) -> &BackupAttitude {
        &self.backup
    }

    /// The backup's state the last iteration flew on, if it flew on it.
    pub fn flown_backup(&self) -> Option<&NavState> {
        self.flown_backup.as_ref()
    }

    /// One loop iteration at `nav.time` on the estimator's state; one it cannot fly on (not
    /// finite, attitude not valid) is flown on the backup instead.
    pub fn update(&mut self, nav: &NavState) -> ActuatorOutputs {
        let now = nav.time;
        if unit_quaternion(nav.attitude).is_err() || !nav_is_finite(nav) {
            self.counters.rejected_nav += 1;
            return self.fly_without_nav(now);
        }
        if !nav.valid.attitude {
            return self.fly_without_nav(now);
        }
        self.backup.follow(nav);
        self.flown_backup = None;
        self.fly_on(nav)
    }

    /// An iteration without a usable NavState from the estimator (stale, or refused): on the
    /// backup attitude when it has a state at `now`, blind otherwise.
    pub fn fly_without_nav(&mut self, now: Time) -> ActuatorOutputs {
        match self.backup.nav_state(now) {
            Some(nav) => {
                self.counters.backup_steps += 1;
                let out = self.fly_on(&nav);
                self.flown_backup = Some(nav);
                out
            }
            None => self.fly_blind(now),
        }
    }

    /// The cascade on `nav`.
    fn fly_on(&mut self, nav: &NavState) -> ActuatorOutputs {
        let now = nav.time;
        let Some(q) = unit_quaternion(nav.attitude).ok().filter(|_| nav_is_finite(nav)) else {
            self.counters.rejected_nav += 1;
            return self.fly_blind(now);
        };
        let dt = self.step_dt(now);
        let Some(sp) = self.setpoint.filter(|s| s.armed) else {
            return self.idle(now, false);
        };
        let omega = Vector3::from(nav.angular_velocity_rad_s);
        let lost = now.saturating_since(sp.time).as_secs_f64() > self.params.timing.setpoint_timeout_s;
        let target = if lost {
            self.counters.lost_setpoint_steps += 1;
            let descend = self.params.timing.failsafe_descent_m_s;
            SetpointTarget::Trajectory(TrajectorySetpoint {
                velocity_ned_m_s: [Some(0.0), Some(0.0), Some(descend)],
                ..TrajectorySetpoint::default()
            })
        } else {
            sp.target
        };
        let full = self.mixer.full_thrust_n();
        // Each target's rate setpoint, collective and attitude for the cascade, and the thrust
        // axis (body down, NED) and the collective along it (N) for a spinning quad.
        let (rates, thrust_n, attitude_sp, wanted) = match target {
            SetpointTarget::MotorsOff => return self.idle(now, true),
            SetpointTarget::Rates { rates_frd_rad_s, thrust } => {
                // Spinning, rates cannot be flown: upright, on the thrust asked for.
                (Vector3::from(rates_frd_rad_s), thrust * full, None, (Vector3::z(), thrust * full))
            }
            SetpointTarget::Attitude { attitude, yaw_rate_rad_s, thrust } => {
                // `set_setpoint` took only attitudes that are rotations.
                let Ok(q_d) = unit_quaternion(attitude) else { return self.fly_blind(now) };
                let rates = self.attitude.rate_setpoint(&q, &q_d, yaw_rate_rad_s);
                (rates, thrust * full, Some(q_d), (q_d * Vector3::z(), thrust * full))
            }
            SetpointTarget::Trajectory(traj) => {
                let traj = self.usable(traj, nav, &q, dt);
                let pos = Vector3::from(nav.position_ned_m);
                let vel = Vector3::from(nav.velocity_ned_m_s);
                let out = self.position.update(&traj, &pos, &vel, yaw_of(&q), dt);
                let rates = self.attitude.rate_setpoint(&q, &out.attitude, out.yaw_rate_rad_s);
                // Lee et al.: thrust is the demanded force projected on the current thrust axis,
                // floored so the mixer keeps authority while the vehicle is far from its target.
                let axis_now = q * Vector3::z();
                let axis_wanted = out.attitude * Vector3::z();
                let projected = out.thrust * axis_now.dot(&axis_wanted);
                let floor = self.params.position.min_thrust;
                let wanted = (axis_wanted, out.thrust.max(floor) * full);
                (rates, projected.max(floor) * full, Some(out.attitude), wanted)
            }
        };
        if let Some(spin) = self.mixer.failed_motor().and_then(|lost| self.spin[lost]) {
            // The measured state passed the checks above, the axis and collective are the outer
            // loops' own: a refusal here cannot happen, and would fly blind.
            let Ok(out) = spin.update(&q, &omega, &wanted.0, wanted.1) else { return self.fly_blind(now) };
            self.demand = Demand {
                attitude: attitude_sp,
                rates_rad_s: out.rates_rad_s,
                torque_n_m: out.torque_n_m,
                thrust_n: out.thrust_n,
                saturation: Saturation { yaw: true, ..Saturation::default() },
            };
            return ActuatorOutputs { time: now, armed: true, motors: out.motors };
        }
        let torque = self.rate.torque(&rates, &omega, dt, self.demand.saturation);
        let mixed = self.mixer.mix(&torque, thrust_n);
        self.demand = Demand {
            attitude: attitude_sp,
            rates_rad_s: rates,
            torque_n_m: torque,
            thrust_n,
            saturation: mixed.saturation,
        };
        ActuatorOutputs { time: now, armed: true, motors: mixed.motors }
    }

    /// An iteration without a usable NavState: zero torque and a little less than hover thrust
    /// while armed and flying, so the vehicle sinks instead of climbing away; stopped otherwise.
    pub fn fly_blind(&mut self, now: Time) -> ActuatorOutputs {
        self.counters.blind_steps += 1;
        self.flown_backup = None;
        self.last_step = Some(now);
        let flying = self.setpoint.is_some_and(|s| s.armed && s.target != SetpointTarget::MotorsOff);
        if !flying {
            return self.idle(now, self.setpoint.is_some_and(|s| s.armed));
        }
        let thrust_n =
            self.params.timing.blind_thrust_of_hover * self.hover_thrust * self.mixer.full_thrust_n();
        let mixed = self.mixer.mix(&Vector3::zeros(), thrust_n);
        self.demand = Demand { thrust_n, saturation: mixed.saturation, ..Demand::default() };
        ActuatorOutputs { time: now, armed: true, motors: mixed.motors }
    }

    fn idle(&mut self, now: Time, armed: bool) -> ActuatorOutputs {
        self.rate.reset();
        self.position.reset();
        self.yaw_hold_rad = None;
        self.demand = Demand::default();
        ActuatorOutputs { time: now, armed, motors: Default::default() }
    }

    fn step_dt(&mut self, now: Time) -> f64 {
        let dt = match self.last_step {
            Some(last) if now > last => (now - last).as_secs_f64().min(MAX_DT_S),
            _ => FIRST_DT_S,
        };
        self.last_step = Some(now);
        dt
    }

    /// Drops the parts of a trajectory setpoint the estimator cannot support, and resolves the
    /// heading to hold.
    fn usable(
        &mut self,
        mut sp: TrajectorySetpoint,
        nav: &NavState,
        q: &UnitQuaternion<f64>,
        dt: f64,
    ) -> TrajectorySetpoint {
        let v = nav.valid;
        if !v.horizontal_position {
            sp.position_ned_m[0] = None;
            sp.position_ned_m[1] = None;
        }
        if !v.horizontal_velocity {
            sp.velocity_ned_m_s[0] = None;
            sp.velocity_ned_m_s[1] = None;
        }
        if !v.vertical_position {
            sp.position_ned_m[2] = None;
        }
        if !v.vertical_velocity {
            sp.velocity_ned_m_s[2] = None;
        }
        if sp.yaw_rad.is_none() {
            let yaw_now = yaw_of(q);
            let held = self.yaw_hold_rad.unwrap_or(yaw_now) + sp.yaw_rate_rad_s * dt;
            self.yaw_hold_rad = Some(held);
            sp.yaw_rad = Some(held);
        }
        sp
    }
}

fn all_finite<'a>(values: impl IntoIterator<Item = &'a f64>) -> bool {
    values.into_iter().all(|v| v.is_finite())
}

/// The rest of the state beside the attitude, which `unit_quaternion` checks.
fn nav_is_finite(nav: &NavState) -> bool {
    all_finite(&nav.angular_velocity_rad_s)
        && all_finite(&nav.velocity_ned_m_s)
        && all_finite(&nav.position_ned_m)
}

fn check_setpoint(sp: &Setpoint) -> Result<(), RejectedInput> {
    let thrust_ok =
        |t: f64| if (0.0..=1.0).contains(&t) { Ok(()) } else { Err(RejectedInput::ThrustOutOfRange) };
    let finite = |ok: bool| if ok { Ok(()) } else { Err(RejectedInput::NonFiniteSetpoint) };
    match &sp.target {
        SetpointTarget::MotorsOff => Ok(()),
        SetpointTarget::Rates { rates_frd_rad_s, thrust } => {
            finite(all_finite(rates_frd_rad_s) && thrust.is_finite())?;
            thrust_ok(*thrust)
        }
        SetpointTarget::Attitude { attitude, yaw_rate_rad_s, thrust } => {
            finite(unit_quaternion(*attitude).is_ok() && yaw_rate_rad_s.is_finite() && thrust.is_finite())?;
            thrust_ok(*thrust)
        }
        SetpointTarget::Trajectory(t) => finite(
            t.position_ned_m.iter().chain(&t.velocity_ned_m_s).flatten().all(|v| v.is_finite())
                && all_finite(&t.acceleration_ned_m_s2)
                && t.yaw_rad.is_none_or(f64::is_finite)
                && t.yaw_rate_rad_s.is_finite()
                && t.max_horizontal_speed_m_s.is_none_or(|v| v.is_finite() && v >= 0.0),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nav(time_us: u64) -> NavState {
        NavState::exact(Time(time_us), [1.0, 0.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0, 0.0, -10.0])
    }

    fn hold() -> Setpoint {
        Setpoint {
            time: Time(0),
            armed: true,
            target: SetpointTarget::Trajectory(TrajectorySetpoint {
                position_ned_m: [Some(0.0), Some(0.0), Some(-10.0)],
                ..TrajectorySetpoint::default()
            }),
            landing: false,
            failed_motor: None,
        }
    }

    #[test]
    fn a_nan_setpoint_is_refused_counted_and_the_previous_one_kept() {
        let mut ctl = FlightController::new(ControlParams::default()).expect("valid");
        ctl.set_setpoint(&hold()).expect("good setpoint");
        let bad = Setpoint {
            target: SetpointTarget::Rates { rates_frd_rad_s: [f64::NAN, 0.0, 0.0], thrust: 0.5 },
            ..hold()
        };
        assert_eq!(ctl.set_setpoint(&bad), Err(RejectedInput::NonFiniteSetpoint));
        let too_much =
            Setpoint { target: SetpointTarget::Rates { rates_frd_rad_s: [0.0; 3], thrust: 1.5 }, ..hold() };
        assert_eq!(ctl.set_setpoint(&too_much), Err(RejectedInput::ThrustOutOfRange));
        assert_eq!(ctl.counters().rejected_setpoints, 2);
        assert_eq!(ctl.setpoint(), Some(&hold()));
        let out = ctl.update(&nav(2500));
        assert!(out.armed && out.motors[..4].iter().all(|m| (m - 0.334).abs() < 0.01), "{out:?}");
    }

    #[test]
    fn a_nan_nav_state_flies_blind_below_hover() {
        let mut ctl = FlightController::new(ControlParams::default()).expect("valid");
        ctl.set_setpoint(&hold()).expect("good setpoint");
        let mut bad = nav(2500);
        bad.velocity_ned_m_s[0] = f64::NAN;
        let out = ctl.update(&bad);
        assert_eq!(ctl.counters().rejected_nav, 1);
        assert!(out.motors[..4].iter().all(|m| *m < 0.334 && *m > 0.25), "{out:?}");
    }

    #[test]
    fn a_lost_setpoint_descends() {
        let mut ctl = FlightController::new(ControlParams::default()).expect("valid");
        ctl.set_setpoint(&hold()).expect("good setpoint");
        let out = ctl.update(&nav(2_000_000));
        assert_eq!(ctl.counters().lost_setpoint_steps, 1);
        assert!(out.motors[0] < 0.334, "{out:?}");
    }

    #[test]
    fn disarmed_stops_the_motors() {
        let mut ctl = FlightController::new(ControlParams::default()).expect("valid");
        ctl.set_setpoint(&Setpoint { armed: false, ..hold() }).expect("good setpoint");
        let out = ctl.update(&nav(2500));
        assert!(!out.armed && out.motors.iter().all(|m| *m == 0.0));
    }
}
