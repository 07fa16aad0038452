//! The avoider in the loop (thesis §3.3.8): AUTO and GUIDED legs, and the pilot's sticks in
//! POSHOLD, flown as velocity demands with the avoider's correction added, integrated into the
//! position setpoint.
//!
//! Used only once an [`AvoidanceCommand`] has arrived (the commander's `avoidance` port is
//! routed); without one every mode flies exactly as before.
//!
//! Each step while flying a leg:
//! 1. the leg's desired velocity: towards the target at the leg's speed (cruise in AUTO),
//!    braking at `APPROACH_DECEL_M_S2` to stop on it, and towards the target altitude; or the
//!    GUIDED velocity; or the pilot's stick velocity ([`Leg::Sticks`]);
//! 2. if the newest command is fresh (younger than `avoidance_timeout_s` and not `stale`), its
//!    body FRD correction is rotated into NED with the vehicle's **heading only**
//!    ([`frd_to_ned`], the one conversion: level-flight approximation, as the thesis) and
//!    added. While the avoider asks for a vertical correction (or climbs because every
//!    region is blocked) the leg's own altitude demand is dropped, so the climb is honoured;
//!    The forward part of the horizontal demand (along the heading: what the camera sees) is
//!    then capped so that the vehicle can stop inside the distance ahead the avoider's view
//!    vouches for (`AvoidanceCommand::clear_range`), braking at `CAP_DECEL_M_S2`
//!    after the grid's age plus `CAP_REACTION_S`, `CAP_MARGIN_M` short of it
//!    ([`kestrel_proto::speed_cap`]); [`AvoidanceLoop::speed_cap`] says the cap, the range and
//!    the reason for the status;
//! 3. if the stream is stale the horizontal demand is zero (and the vertical one too, except
//!    the pilot's throttle): the vehicle slows at `AVOID_ACCEL_M_S2` and holds where it
//!    stopped, and says so in `VehicleStatus.last_refusal` (→ STATUSTEXT);
//! 4. the demand is rate-limited at `AVOID_ACCEL_M_S2` (the ramp's acceleration fed forward)
//!    and flown as a velocity: while it is non-zero the horizontal position setpoint follows
//!    the vehicle, and where it reaches zero the setpoint stays and the vehicle holds
//!    ([`LEASH_M`], [`HOLD_LEASH_M`]); the trajectory setpoint carries that position with the
//!    velocity as feed-forward. On AUTO, GUIDED and RTL legs the nose turns towards the leg's
//!    direction (at the yaw stick rate) so that the forward camera looks where the vehicle
//!    goes, and while the leg is more than [`LEG_IN_VIEW_RAD`] off the nose its horizontal
//!    demand is zero: the vehicle stops and turns first, as PX4's collision prevention moves
//!    only where its sensor has data (`CP_GO_NO_DATA` = 0); in POSHOLD the pilot keeps the
//!    heading.
//!
//! The desired speed handed to the avoider (`TrajectorySetpoint::desired_speed_m_s`, its
//! `V_in`) is the leg's horizontal speed (0 while turning first); for the sticks it is the forward part of the pilot's
//! demand, the speed at which the vehicle closes on what the forward camera sees.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    AvoidanceCommand, ClearRangeReason, NavState, SpeedCapStatus, TrajectorySetpoint,
};
use kestrel_proto::speed_cap::Braking;
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
/// Deceleration the speed cap plans on (m/s²): below `AVOID_ACCEL_M_S2`, the demand's ramp,
/// because the vehicle trails the ramp a little even with its acceleration fed forward.
const CAP_DECEL_M_S2: f64 = 2.0;
/// Time the speed cap allows, beyond the grid's age, before the vehicle brakes (s): the
/// demand's low-pass in the avoider and the velocity loop's response.
const CAP_REACTION_S: f64 = 0.3;
/// Clearance the speed cap keeps from what lies ahead (m): the airframe's half-width and a
/// margin, as PX4's `CP_DIST`.
const CAP_MARGIN_M: f64 = 1.0;
/// While the demand moves the vehicle, the (vertical) position setpoint stays within this of
/// the vehicle (m): a setpoint left metres ahead while the demand drops to zero would keep
/// pulling the vehicle on towards the obstacle it is braking for.
const LEASH_M: f64 = 0.3;
/// While the demand is zero the setpoint holds still, at most this far from the vehicle (m),
/// so that a gust cannot drag the held position along (a leash of [`LEASH_M`] did: the
/// vehicle drifted onto a trunk while climbing beside it).
const HOLD_LEASH_M: f64 = 1.0;
/// A vertical correction above this (m/s) takes the altitude over from the leg.
const VERTICAL_TAKEOVER_M_S: f64 = 0.1;
/// The nose turns towards the leg only while the leg asks for at least this speed (m/s).
const TURN_MIN_SPEED_M_S: f64 = 0.5;
/// ... and, flying to a position, while it is at least this far away horizontally (m): the
/// few decimetres of drift from a take-off or landing spot are no direction to look in (the
/// nose swung 29° on a take-off item).
const TURN_MIN_DISTANCE_M: f64 = 2.0;
/// An AUTO, GUIDED or RTL leg is flown only while the nose points within this of it (rad);
/// farther off the vehicle stops and turns first, so that the forward camera (±55°) looks
/// where it goes. Flying while turning, an RTL started facing away from home reached 3.8 m/s
/// backwards into trees before the camera faced them (decision 0044).
const LEG_IN_VIEW_RAD: f64 = 30.0 * std::f64::consts::PI / 180.0;
/// Descending along an AUTO, GUIDED or RTL leg, at most this far down per metre forward: the
/// path stays inside the image's centre row band, which is all the speed cap reads (its
/// regions and its `OBSTACLE_DISTANCE` sectors). The default camera (110° across, 4:3) sees
/// that band to tan 19.6° = 0.357 below its axis; the quad's 0.35 m collision radius takes
/// 0.04 of it at the 9.25 m stopping reach from 5 m/s, and a 3° nose-up pitch while braking
/// 0.05, leaving 0.27. Steeper, a descent after a climb over trees went at 2 m/s while
/// flying on at 2.5 m/s (39°) and met a trunk below the band (decision 0040).
pub(crate) const DESCENT_SLOPE: f64 = 0.25;

/// What the leg wants, before the avoider.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Leg {
    /// Fly to this NED position (m) at up to this horizontal speed (m/s).
    To { target: Vector3<f64>, speed_m_s: f64 },
    /// Fly this NED velocity (m/s).
    Velocity(Vector3<f64>),
    /// The pilot's sticks in POSHOLD. `velocity` is the NED stick velocity (m/s): north and
    /// east from pitch and roll in the held heading's frame, down from the throttle (0 while
    /// it is centred and `hold_down_m` is the held altitude, NED down in m). `forward_m_s` is
    /// the pitch stick's part along the heading (m/s): the forward camera sees only what lies
    /// ahead, so the avoider's correction (and a stale stream's hold) applies only while it is
    /// positive; flying sideways or backwards the pilot is unprotected, as with PX4's collision
    /// prevention in a direction without sensor data (`CP_GO_NO_DATA` = 1). The nose stays
    /// where the pilot's yaw stick puts it.
    Sticks { velocity: Vector3<f64>, forward_m_s: f64, hold_down_m: Option<f64> },
}

impl Leg {
    /// The avoider has a say: it looks where the leg goes.
    fn avoided(&self) -> bool {
        match self {
            Leg::To { .. } | Leg::Velocity(_) => true,
            Leg::Sticks { forward_m_s, .. } => *forward_m_s > 0.0,
        }
    }
}

/// Vertical speed (m/s, NED down) towards an altitude `error_m` below (positive) or above the
/// setpoint.
fn towards_altitude(error_m: f64) -> f64 {
    (VERTICAL_GAIN * error_m).clamp(-LEG_VERTICAL_SPEED_M_S, LEG_VERTICAL_SPEED_M_S)
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
    /// Stamp of the newest command that was not flagged stale (of the first command, until one
    /// is): how long the avoider has had nothing to say, for the `avoidance_lost` failsafe.
    pub last_fresh: Option<Time>,
    /// The forward speed cap of the last step of a leg the avoider had a say in.
    pub speed_cap: Option<SpeedCapStatus>,
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
    /// The avoider's vertical correction replaced the leg's altitude demand at this step.
    pub vertical_takeover: bool,
}

impl AvoidanceLoop {
    /// In the loop at all: a command has arrived.
    pub fn active(&self) -> bool {
        self.command.is_some()
    }

    /// Seconds at `now` since the avoider's last fresh command; `None` outside the loop.
    pub fn silent_for_s(&self, now: Time) -> Option<f64> {
        self.last_fresh.map(|t| now.saturating_since(t).as_secs_f64())
    }

    /// Takes a command; one with a non-finite correction or a clear range that is not a
    /// finite distance is ignored.
    pub fn on_command(&mut self, cmd: &AvoidanceCommand) -> bool {
        let range_m = cmd.clear_range.range_m;
        if cmd.velocity_frd_m_s.iter().all(|v| v.is_finite()) && range_m.is_finite() && range_m >= 0.0 {
            self.command = Some(*cmd);
            if !cmd.health.stale || self.last_fresh.is_none() {
                self.last_fresh = Some(cmd.time);
            }
            true
        } else {
            false
        }
    }

    /// The end of a leg (another step, another mode).
    pub fn reset(&mut self) {
        self.state = None;
        self.holding = false;
        self.speed_cap = None;
    }

    /// The fresh correction at `now`, or `None` if the stream is stale.
    pub fn fresh(&self, now: Time, timeout_s: f64) -> Option<&AvoidanceCommand> {
        self.command
            .as_ref()
            .filter(|c| !c.health.stale && now.saturating_since(c.time).as_secs_f64() < timeout_s)
    }

    /// The setpoint for `leg` at `now`, `dt_s` after the last step; `yaw_rad` is the heading
    /// held so far (turned towards an AUTO or GUIDED leg here).
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
                Vector3::new(h.x, h.y, towards_altitude(to.z))
            }
            Leg::Velocity(v) => v,
            Leg::Sticks { velocity, hold_down_m, .. } => {
                let vz = hold_down_m.map_or(velocity.z, |down| towards_altitude(down - p_sp.z));
                Vector3::new(velocity.x, velocity.y, vz)
            }
        };
        let leg_horizontal = Vector3::new(desired.x, desired.y, 0.0);
        let avoided = leg.avoided();
        let fresh = self.fresh(now, timeout_s).copied();
        let heading = super::heading(nav);
        // Nose along an AUTO or GUIDED leg, at the yaw rate; the leg waits while it is out of view.
        let turns = match leg {
            Leg::To { target, .. } => (target - pos).xy().norm() >= TURN_MIN_DISTANCE_M,
            Leg::Velocity(_) => true,
            Leg::Sticks { .. } => false,
        } && leg_horizontal.norm() >= TURN_MIN_SPEED_M_S;
        let bearing = leg_horizontal.y.atan2(leg_horizontal.x);
        let turning_first = turns && wrap_pi(bearing - heading).abs() > LEG_IN_VIEW_RAD;
        let mut vertical_takeover = false;
        self.speed_cap = None;
        match fresh {
            _ if !avoided => {}
            Some(cmd) => {
                let correction = frd_to_ned(cmd.velocity_frd_m_s, heading);
                if cmd.health.climbing || correction.z.abs() > VERTICAL_TAKEOVER_M_S {
                    desired.z = 0.0;
                    vertical_takeover = true;
                }
                desired += correction;
                self.speed_cap = Some(cap_forward(&mut desired, &cmd, now, heading));
            }
            // The pilot keeps the throttle: the camera never looked up or down, and climbing
            // is the pilot's way out.
            None if matches!(leg, Leg::Sticks { .. }) => (desired.x, desired.y) = (0.0, 0.0),
            None => desired = Vector3::zeros(),
        }
        if turning_first {
            (desired.x, desired.y) = (0.0, 0.0);
        }
        // A leg's own descent, while it still goes somewhere, follows what the camera sees
        // ahead ([`DESCENT_SLOPE`]); over its target it descends straight down, out of the
        // forward camera's sight as a landing is.
        if matches!(leg, Leg::To { .. })
            && fresh.is_some()
            && !vertical_takeover
            && leg_horizontal.norm() >= TURN_MIN_SPEED_M_S
        {
            let along = desired.dot(&frd_to_ned([1.0, 0.0, 0.0], heading));
            desired.z = desired.z.min(DESCENT_SLOPE * along.max(0.0));
        }
        let holding = avoided && fresh.is_none();
        if holding {
            let limiting = leg_horizontal.norm() > 0.0;
            let reason = ClearRangeReason::Stale;
            self.speed_cap = Some(SpeedCapStatus { cap_m_s: 0.0, range_m: 0.0, reason, limiting });
        }
        let hold_changed = (holding != self.holding).then_some(holding);
        self.holding = holding;
        // Rate-limit the demand, then fly it as a velocity with the ramp fed forward.
        let change = desired - v_cmd;
        let max_change = AVOID_ACCEL_M_S2 * dt_s;
        let step = if change.norm() > max_change { change * (max_change / change.norm()) } else { change };
        v_cmd += step;
        // The ramp's acceleration goes to the controller as feed-forward, as PX4's trajectory
        // generator does: without it the velocity loop (MPC_XY_VEL_P_ACC = 1.8/s) trails the
        // ramp by about half a second, and a vehicle braking for a trunk decelerated at about
        // 1.2 m/s² where the avoider planned on 2.
        let acceleration = step / dt_s.max(1e-6);
        if v_cmd.x.hypot(v_cmd.y) > 0.0 {
            // A velocity is flown, as in PX4's position mode: while the demand moves the
            // vehicle the horizontal setpoint follows it, without the lead that a lagging
            // vehicle would catch up on (up to 1 m/s faster than the demand, towards what the
            // avoider is braking for, or sideways into a trunk after a sidestep); it stays
            // where the demand reaches zero, and the vehicle holds there.
            (p_sp.x, p_sp.y) = (pos.x, pos.y);
        }
        p_sp += v_cmd * dt_s;
        let lead = p_sp - pos;
        let leash = if v_cmd.norm() > 0.0 { LEASH_M } else { HOLD_LEASH_M };
        if lead.norm() > leash {
            p_sp = pos + lead * (leash / lead.norm());
        }
        self.state = Some((p_sp, v_cmd));
        if turns && !holding {
            let error = wrap_pi(bearing - *yaw_rad);
            let max_turn = yaw_rate_rad_s * dt_s;
            *yaw_rad = wrap_pi(*yaw_rad + error.clamp(-max_turn, max_turn));
        }
        let horizontal_speed = v_cmd.x.hypot(v_cmd.y);
        let desired_speed = match leg {
            Leg::Sticks { forward_m_s, .. } => forward_m_s.max(0.0),
            // Turning on the spot, the avoider has no forward speed to correct.
            Leg::To { .. } | Leg::Velocity(_) if turning_first => 0.0,
            Leg::To { .. } | Leg::Velocity(_) => leg_horizontal.norm(),
        };
        let setpoint = TrajectorySetpoint {
            position_ned_m: [Some(p_sp.x), Some(p_sp.y), Some(p_sp.z)],
            velocity_ned_m_s: [Some(v_cmd.x), Some(v_cmd.y), Some(v_cmd.z)],
            acceleration_ned_m_s2: acceleration.into(),
            yaw_rad: Some(*yaw_rad),
            max_horizontal_speed_m_s: Some(horizontal_speed + 1.0),
            desired_speed_m_s: Some(desired_speed),
            ..TrajectorySetpoint::default()
        };
        Blend { setpoint, hold_changed, vertical_takeover }
    }
}

/// The braking the speed cap plans on for a depth grid `grid_age_s` old (s).
pub fn cap_braking(grid_age_s: f64) -> Braking {
    Braking { decel_m_s2: CAP_DECEL_M_S2, latency_s: grid_age_s + CAP_REACTION_S, margin_m: CAP_MARGIN_M }
}

/// Caps the forward part (along `heading_rad`) of the horizontal demand `desired` (NED, m/s)
/// so that the vehicle can stop inside `cmd`'s clear range; lateral and vertical parts stay.
fn cap_forward(
    desired: &mut Vector3<f64>,
    cmd: &AvoidanceCommand,
    now: Time,
    heading_rad: f64,
) -> SpeedCapStatus {
    let range = cmd.clear_range;
    let age_s = cmd.grid_time.map_or(0.0, |t| now.saturating_since(t).as_secs_f64());
    let braking = cap_braking(age_s);
    // `on_command` admits only finite ranges ≥ 0 and the constants are valid; a refusal would
    // still stop forward motion rather than lift the cap.
    let cap_m_s = braking.speed_cap_m_s(range.range_m).unwrap_or(0.0);
    let forward = frd_to_ned([1.0, 0.0, 0.0], heading_rad);
    let along = desired.dot(&forward);
    let limiting = along > cap_m_s;
    if limiting {
        *desired -= forward * (along - cap_m_s);
    }
    SpeedCapStatus { cap_m_s, range_m: range.range_m, reason: range.reason, limiting }
}

fn wrap_pi(a: f64) -> f64 {
    let a = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU);
    a - std::f64::consts::PI
}
