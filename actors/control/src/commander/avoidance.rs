//! The avoider in the loop (thesis §3.3.8): AUTO and GUIDED legs flown as velocity demands
//! with the avoider's correction added, integrated into the position setpoint.
//!
//! Used only once an [`AvoidanceCommand`] has arrived (the commander's `avoidance` port is
//! routed); without one every mode flies exactly as before.
//!
//! Each step while flying a leg:
//! 1. the leg's desired velocity: towards the target at the leg's speed (cruise in AUTO),
//!    braking at `APPROACH_DECEL_M_S2` to stop on it, and towards the target altitude;
//! 2. if the newest command is fresh (younger than `avoidance_timeout_s` and not `stale`), its
//!    body FRD correction is rotated into NED with the vehicle's **heading only**
//!    ([`frd_to_ned`], the one conversion: level-flight approximation, as the thesis) and
//!    added. While the avoider asks for a vertical correction (or climbs because every
//!    region is blocked) the leg's own altitude demand is dropped, so the climb is honoured;
//! 3. if the stream is stale the demand is zero: the vehicle slows at `AVOID_ACCEL_M_S2` and
//!    holds where it stopped, and says so in `VehicleStatus.last_refusal` (→ STATUSTEXT);
//! 4. the demand is rate-limited at `AVOID_ACCEL_M_S2` and integrated into a position
//!    setpoint kept on a leash that shortens with the demand ([`LEASH_MIN_M`]); the trajectory setpoint carries that
//!    position with the velocity as feed-forward. The nose turns towards the leg's direction
//!    (at the yaw stick rate) so that the forward camera looks where the vehicle goes.

use kestrel_proto::Time;
use kestrel_proto::messages::{AvoidanceCommand, NavState, TrajectorySetpoint};
use nalgebra::Vector3;

/// The leg's desired speed falls off so as to stop at the target decelerating at this (m/s²),
/// below `AVOID_ACCEL_M_S2` so that the rate-limited demand does not overshoot.
const APPROACH_DECEL_M_S2: f64 = 1.5;
/// Vertical speed towards the leg's altitude per metre of altitude error (1/s).
const VERTICAL_GAIN: f64 = 1.0;
/// Vertical speed towards the leg's altitude, at most (m/s).
const LEG_VERTICAL_SPEED_M_S: f64 = 2.0;
/// Largest change of the velocity demand (m/s²): the slow-down of a stale hold.
pub(crate) const AVOID_ACCEL_M_S2: f64 = 2.5;
/// The integrated position setpoint stays within `LEASH_MIN_M + LEASH_TIME_S · |v|` of the
/// vehicle (m), `v` the velocity demand: a setpoint left metres ahead while the demand drops to
/// zero would keep pulling the vehicle on towards the obstacle it is braking for.
const LEASH_MIN_M: f64 = 0.3;
/// See [`LEASH_MIN_M`] (s): about the position loop's lag behind a velocity demand.
const LEASH_TIME_S: f64 = 0.5;
/// A vertical correction above this (m/s) takes the altitude over from the leg.
const VERTICAL_TAKEOVER_M_S: f64 = 0.1;
/// The nose turns towards the leg only while the leg asks for at least this speed (m/s).
const TURN_MIN_SPEED_M_S: f64 = 0.5;

/// What the leg wants, before the avoider.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Leg {
    /// Fly to this NED position (m) at up to this horizontal speed (m/s).
    To { target: Vector3<f64>, speed_m_s: f64 },
    /// Fly this NED velocity (m/s).
    Velocity(Vector3<f64>),
}

/// The body FRD vector `[forward, right, down]` in NED for a vehicle heading `yaw_rad`
/// (roll and pitch ignored: the correction is a horizontal steer plus a climb).
pub fn frd_to_ned(frd: [f64; 3], yaw_rad: f64) -> Vector3<f64> {
    let (sin, cos) = yaw_rad.sin_cos();
    let [f, r, d] = frd;
    Vector3::new(f * cos - r * sin, f * sin + r * cos, d)
}

/// The avoider loop's state: the newest command and the integrated setpoint.
#[derive(Clone, Debug, Default)]
pub(crate) struct AvoidanceLoop {
    /// Newest finite command.
    pub command: Option<AvoidanceCommand>,
    /// Integrated position setpoint (NED, m) and the velocity demand (m/s) of the leg being
    /// flown; `None` outside a leg.
    pub state: Option<(Vector3<f64>, Vector3<f64>)>,
    /// Holding because the stream is stale.
    pub holding: bool,
}

/// The commander's settings for one step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Limits {
    /// A command older than this is stale (s).
    pub timeout_s: f64,
    /// Turn rate towards the leg (rad/s).
    pub yaw_rate_rad_s: f64,
}

/// One step's outcome.
pub(crate) struct Blend {
    pub setpoint: TrajectorySetpoint,
    /// The stale hold started (true) or ended (false) at this step.
    pub hold_changed: Option<bool>,
}

impl AvoidanceLoop {
    /// In the loop at all: a command has arrived.
    pub fn active(&self) -> bool {
        self.command.is_some()
    }

    /// Takes a command; a non-finite one is ignored.
    pub fn on_command(&mut self, cmd: &AvoidanceCommand) -> bool {
        if cmd.velocity_frd_m_s.iter().all(|v| v.is_finite()) {
            self.command = Some(*cmd);
            true
        } else {
            false
        }
    }

    /// The end of a leg (another step, another mode).
    pub fn reset(&mut self) {
        self.state = None;
        self.holding = false;
    }

    /// The fresh correction at `now`, or `None` if the stream is stale.
    pub fn fresh(&self, now: Time, timeout_s: f64) -> Option<&AvoidanceCommand> {
        self.command
            .as_ref()
            .filter(|c| !c.health.stale && now.saturating_since(c.time).as_secs_f64() < timeout_s)
    }

    /// The setpoint for `leg` at `now`, `dt_s` after the last step; `yaw_rad` is the heading
    /// held so far (turned towards the leg here).
    pub fn step(
        &mut self,
        now: Time,
        dt_s: f64,
        nav: &NavState,
        leg: Leg,
        yaw_rad: &mut f64,
        limits: Limits,
    ) -> Blend {
        let Limits { timeout_s, yaw_rate_rad_s } = limits;
        let pos = Vector3::from(nav.position_ned_m);
        let (mut p_sp, mut v_cmd) = self.state.unwrap_or((pos, Vector3::from(nav.velocity_ned_m_s)));
        let mut desired = match leg {
            Leg::To { target, speed_m_s } => {
                let to = target - p_sp;
                let horizontal = Vector3::new(to.x, to.y, 0.0);
                let distance = horizontal.norm();
                let speed = speed_m_s.min((2.0 * APPROACH_DECEL_M_S2 * distance).sqrt());
                let h = if distance > 1e-9 { horizontal * (speed / distance) } else { Vector3::zeros() };
                let vz = (VERTICAL_GAIN * to.z).clamp(-LEG_VERTICAL_SPEED_M_S, LEG_VERTICAL_SPEED_M_S);
                Vector3::new(h.x, h.y, vz)
            }
            Leg::Velocity(v) => v,
        };
        let leg_horizontal = Vector3::new(desired.x, desired.y, 0.0);
        let fresh = self.fresh(now, timeout_s).copied();
        let heading = super::heading(nav);
        match fresh {
            Some(cmd) => {
                let correction = frd_to_ned(cmd.velocity_frd_m_s, heading);
                if cmd.health.climbing || correction.z.abs() > VERTICAL_TAKEOVER_M_S {
                    desired.z = 0.0;
                }
                desired += correction;
            }
            None => desired = Vector3::zeros(),
        }
        let holding = fresh.is_none();
        let hold_changed = (holding != self.holding).then_some(holding);
        self.holding = holding;
        // Rate-limit the demand, integrate, keep the setpoint on a leash.
        let change = desired - v_cmd;
        let max_change = AVOID_ACCEL_M_S2 * dt_s;
        v_cmd += if change.norm() > max_change { change * (max_change / change.norm()) } else { change };
        p_sp += v_cmd * dt_s;
        let lead = p_sp - pos;
        let leash = LEASH_MIN_M + LEASH_TIME_S * v_cmd.norm();
        if lead.norm() > leash {
            p_sp = pos + lead * (leash / lead.norm());
        }
        self.state = Some((p_sp, v_cmd));
        // Nose along the leg, at the yaw rate.
        if !holding && leg_horizontal.norm() >= TURN_MIN_SPEED_M_S {
            let bearing = leg_horizontal.y.atan2(leg_horizontal.x);
            let error = wrap_pi(bearing - *yaw_rad);
            let max_turn = yaw_rate_rad_s * dt_s;
            *yaw_rad = wrap_pi(*yaw_rad + error.clamp(-max_turn, max_turn));
        }
        let horizontal_speed = v_cmd.x.hypot(v_cmd.y);
        let setpoint = TrajectorySetpoint {
            position_ned_m: [Some(p_sp.x), Some(p_sp.y), Some(p_sp.z)],
            velocity_ned_m_s: [Some(v_cmd.x), Some(v_cmd.y), Some(v_cmd.z)],
            yaw_rad: Some(*yaw_rad),
            max_horizontal_speed_m_s: Some(horizontal_speed + 1.0),
            desired_speed_m_s: Some(leg_horizontal.norm()),
            ..TrajectorySetpoint::default()
        };
        Blend { setpoint, hold_changed }
    }
}

fn wrap_pi(a: f64) -> f64 {
    let a = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU);
    a - std::f64::consts::PI
}
