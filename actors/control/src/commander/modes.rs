//! What each flight mode flies: sticks, targets, the mission, RTL and landing → a setpoint.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    FlightMode, LandedState, ManualControl, NavState, SetpointTarget, TrajectorySetpoint,
};
use nalgebra::{UnitQuaternion, Vector3};

use super::arming::Refusal;
use super::avoidance::{Blend, Leg, Limits};
use super::brake::Brake;
use super::circle::Circle;
use super::follow::FollowLatch;
use super::guided::GuidedTarget;
use super::mission_runner::MissionStep;
use super::{Commander, heading};
use crate::flip::Flip;
use kestrel_proto::units::GRAVITY_M_S2;

/// A landing target closer than this is descended onto directly (m); farther, flown to first.
const LAND_APPROACH_RADIUS_M: f64 = 1.5;
/// An altitude counts as reached within this (m).
const ALTITUDE_TOLERANCE_M: f64 = 0.5;
/// TAKEOFF stays on the ground when the upward rangefinder leaves less room than this (m)
/// between home and the ceiling it sets.
const MIN_TAKEOFF_ROOM_M: f64 = 1.0;
/// RTL counts as home within this horizontal distance and below this speed (m, m/s).
const HOME_RADIUS_M: f64 = 1.0;
const HOME_SPEED_M_S: f64 = 0.5;
/// Sticks closer to centre than this count as centred.
const STICK_CENTRED: f64 = 0.05;
/// Largest collective thrust the sticks may ask for (share): the mixer keeps the rest for torque.
const MAX_STICK_THRUST: f64 = 0.9;

/// What the current mode latched when it started or the sticks were let go.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Hold {
    /// Held NED position (m).
    pub position: Option<Vector3<f64>>,
    /// Held down coordinate (m).
    pub down_m: Option<f64>,
    /// Held heading (rad).
    pub yaw_rad: Option<f64>,
    /// AUTO is descending onto a landing item.
    pub landing: bool,
}

/// What the current mode latched; a mode change starts it afresh.
#[derive(Clone, Debug)]
pub(crate) struct ModeLatches {
    pub hold: Hold,
    pub rtl: RtlPhase,
    /// Where RTL returns (home or a rally point, `rally`), chosen when it starts (m, NED).
    pub rtl_target: Option<Vector3<f64>>,
    /// A flip under way (ACRO).
    pub flip: Option<Flip>,
    /// The orbit CIRCLE flies (set by DO_ORBIT, or on entry).
    pub circle: Option<Circle>,
    /// BRAKE's velocity still to shed, then the point held.
    pub brake: Option<Brake>,
    /// FOLLOW's offset taken on entry and its stop while there is no target.
    pub follow: FollowLatch,
}

impl Default for ModeLatches {
    fn default() -> ModeLatches {
        ModeLatches {
            hold: Hold::default(),
            rtl: RtlPhase::Climb,
            rtl_target: None,
            flip: None,
            circle: None,
            brake: None,
            follow: FollowLatch::default(),
        }
    }
}

/// Where RTL is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum RtlPhase {
    Climb,
    Return { down_m: f64 },
    Loiter { down_m: f64, until: Time },
    Land,
}

fn traj(position: [Option<f64>; 3], velocity: [Option<f64>; 3], yaw_rad: Option<f64>) -> SetpointTarget {
    SetpointTarget::Trajectory(TrajectorySetpoint {
        position_ned_m: position,
        velocity_ned_m_s: velocity,
        yaw_rad,
        ..TrajectorySetpoint::default()
    })
}

fn at(p: &Vector3<f64>) -> [Option<f64>; 3] {
    [Some(p.x), Some(p.y), Some(p.z)]
}

impl Commander {
    pub(super) fn set_mode(&mut self, now: Time, mode: FlightMode) -> Result<(), Refusal> {
        self.mode_allowed(now, mode)?;
        self.boot_mode = false;
        // ArduCopter starts a manual recovery on a change of mode only, not on the same one.
        if self.armed && mode != self.mode {
            self.geofence.manual_recovery_start(now);
        }
        if mode == FlightMode::Auto && (self.mission.runner.is_none() || self.mode != FlightMode::Auto) {
            self.mission.start_run();
        }
        // The mode already active is accepted without re-entering it: RTL must not climb again
        // from its landing phase, nor LAND restart the land detector.
        if mode != self.mode {
            self.enter(mode);
        }
        Ok(())
    }

    /// Switches mode and resets what the new mode latches.
    pub(super) fn enter(&mut self, mode: FlightMode) {
        if mode != self.mode {
            tracing::info!(from = ?self.mode, to = ?mode, "mode");
        }
        self.mode = mode;
        self.latched = ModeLatches::default();
        self.mission.paused = false;
        self.guided.on_mode_change();
        self.landing.on_mode_change();
        self.avoidance.reset();
        self.vertical.reset_landing_search();
    }

    /// The setpoint of the current mode (armed only).
    pub(super) fn fly(&mut self, now: Time, dt_s: f64) -> SetpointTarget {
        let Some(nav) = self.nav.latest().cloned() else {
            return traj([None; 3], [None, None, Some(self.params.land_slow_m_s)], None);
        };
        if let Some(flip) = &mut self.latched.flip {
            let target = flip.update(&nav);
            if flip.done() {
                self.latched.flip = None;
            }
            return target;
        }
        // Stale sticks are centred ones: the vehicle holds rather than fly a deflection
        // remembered from seconds ago (the `ManualControlLost` failsafe acts on the loss).
        let sticks =
            self.sticks(now).copied().unwrap_or(ManualControl { throttle: 0.5, ..ManualControl::default() });
        let on_ground = self.landing.state() == LandedState::OnGround;
        if matches!(self.mode, FlightMode::Guided | FlightMode::Auto)
            && !self.avoidance.active()
            && let Some(yaw) = self.guided.aimed_yaw(&nav, self.latched.hold.yaw_rad)
        {
            self.latched.hold.yaw_rad = Some(yaw);
        }
        match self.mode {
            FlightMode::Stabilize => self.stabilize(&nav, &sticks, dt_s),
            FlightMode::Acro => self.acro(&sticks),
            FlightMode::AltHold | FlightMode::PosHold if on_ground && !self.climb_requested(&sticks) => {
                SetpointTarget::MotorsOff
            }
            FlightMode::AltHold => self.alt_hold(&nav, &sticks, dt_s),
            FlightMode::PosHold => self.pos_hold(now, &nav, &sticks, dt_s),
            FlightMode::Guided => self.guided(now, dt_s, &nav, on_ground),
            FlightMode::Auto => self.auto(now, dt_s, &nav),
            FlightMode::Takeoff => {
                let home = self.home.or_here(&nav);
                let p = *self.latched.hold.position.get_or_insert(Vector3::from(nav.position_ned_m));
                let yaw = *self.latched.hold.yaw_rad.get_or_insert(heading(&nav));
                // Under something the upward rangefinder sees, the take-off ends below it; with
                // less than a metre of room it does not leave the ground (and DISARM_DELAY
                // disarms), and it never counts as done on the ground.
                let down = self.vertical.under_ceiling(
                    now,
                    &nav,
                    home.z - self.guided.takeoff_height_m(),
                    &self.params.vertical,
                );
                if self.landing.state() == LandedState::OnGround && home.z - down < MIN_TAKEOFF_ROOM_M {
                    return SetpointTarget::MotorsOff;
                }
                let done_at = self.vertical.under_steady_ceiling(
                    now,
                    &nav,
                    home.z - self.guided.takeoff_height_m(),
                    &self.params.vertical,
                );
                if self.landing.state() != LandedState::OnGround
                    && (nav.position_ned_m[2] - done_at).abs() < ALTITUDE_TOLERANCE_M
                {
                    // Up: hold there in GUIDED, as ArduCopter's take-off ends, so targets are
                    // taken at once instead of refused until the mode is set again.
                    self.enter(FlightMode::Guided);
                    self.latched.hold.position = Some(Vector3::new(p.x, p.y, down));
                    self.latched.hold.yaw_rad = Some(yaw);
                }
                traj([Some(p.x), Some(p.y), Some(down)], [None; 3], Some(yaw))
            }
            FlightMode::Circle | FlightMode::Brake | FlightMode::Follow if on_ground => {
                SetpointTarget::MotorsOff
            }
            FlightMode::Follow => self.follow(now, dt_s, &nav),
            FlightMode::Circle => self.circle(dt_s, &nav),
            FlightMode::Brake => self.brake(dt_s, &nav),
            FlightMode::ReturnToLaunch => self.rtl(now, dt_s, &nav),
            FlightMode::Land => {
                let p = *self.latched.hold.position.get_or_insert(Vector3::from(nav.position_ned_m));
                self.land_at(now, dt_s, &nav, Some([p.x, p.y]))
            }
        }
    }

    /// Throttle → collective thrust share: mid-stick hovers (ArduPilot's `THR_MID` idea).
    fn stick_thrust(&self, throttle: f64) -> f64 {
        let h = self.params.hover_thrust;
        if throttle <= 0.5 { throttle * 2.0 * h } else { h + (throttle - 0.5) * 2.0 * (MAX_STICK_THRUST - h) }
    }

    fn held_yaw(&mut self, nav: &NavState, rate_rad_s: f64, dt_s: f64) -> f64 {
        let yaw = self.latched.hold.yaw_rad.unwrap_or_else(|| heading(nav)) + rate_rad_s * dt_s;
        self.latched.hold.yaw_rad = Some(yaw);
        yaw
    }

    fn stabilize(&mut self, nav: &NavState, s: &ManualControl, dt_s: f64) -> SetpointTarget {
        let tilt = self.params.max_tilt_deg.to_radians();
        let yaw_rate = s.yaw * self.params.yaw_rate_deg_s.to_radians();
        let yaw = self.held_yaw(nav, yaw_rate, dt_s);
        let q = UnitQuaternion::from_euler_angles(s.roll * tilt, -s.pitch * tilt, yaw);
        SetpointTarget::Attitude {
            attitude: [q.w, q.i, q.j, q.k],
            yaw_rate_rad_s: yaw_rate,
            thrust: self.stick_thrust(s.throttle),
        }
    }

    fn acro(&self, s: &ManualControl) -> SetpointTarget {
        let rate = self.params.acro_rate_deg_s.to_radians();
        SetpointTarget::Rates {
            rates_frd_rad_s: [
                s.roll * rate,
                -s.pitch * rate,
                s.yaw * self.params.yaw_rate_deg_s.to_radians(),
            ],
            thrust: self.stick_thrust(s.throttle),
        }
    }

    fn climb_requested(&self, s: &ManualControl) -> bool {
        s.throttle > 0.5 + 0.5 * self.params.throttle_deadband
    }

    /// Vertical part of ALT_HOLD/POSHOLD: hold the height with the throttle centred, else climb
    /// or descend in proportion.
    fn vertical(&mut self, nav: &NavState, s: &ManualControl) -> (Option<f64>, Option<f64>) {
        let stick = (s.throttle - 0.5) * 2.0;
        let band = self.params.throttle_deadband;
        if stick.abs() <= band {
            (Some(*self.latched.hold.down_m.get_or_insert(nav.position_ned_m[2])), None)
        } else {
            self.latched.hold.down_m = None;
            let scaled = (stick.abs() - band) / (1.0 - band) * stick.signum();
            (None, Some(-scaled * self.params.stick_climb_m_s))
        }
    }

    fn alt_hold(&mut self, nav: &NavState, s: &ManualControl, dt_s: f64) -> SetpointTarget {
        let yaw_rate = s.yaw * self.params.yaw_rate_deg_s.to_radians();
        let yaw = self.held_yaw(nav, yaw_rate, dt_s);
        let (pz, vz) = self.vertical(nav, s);
        // Sticks tilt: horizontal acceleration g·tan(stick·max tilt), in the heading's frame.
        let a = |stick: f64| GRAVITY_M_S2 * (stick * self.params.max_tilt_deg.to_radians()).tan();
        let (fwd, right) = (a(s.pitch), a(s.roll));
        let (sin, cos) = yaw.sin_cos();
        SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: [None, None, pz],
            velocity_ned_m_s: [None, None, vz],
            acceleration_ned_m_s2: [fwd * cos - right * sin, fwd * sin + right * cos, 0.0],
            yaw_rad: Some(yaw),
            yaw_rate_rad_s: yaw_rate,
            max_horizontal_speed_m_s: None,
            desired_speed_m_s: None,
        })
    }

    /// POSHOLD: the sticks fly a velocity (`stick_speed_m_s` at full deflection, in the held
    /// heading's frame) and the throttle a climb rate; centred, the vehicle holds where it is.
    /// With the avoider in the loop the stick velocity is flown as a leg ([`Leg::Sticks`]):
    /// the correction is blended in while the pilot flies forward, and a stale stream slows
    /// and holds as in AUTO; the yaw stick keeps the heading and the throttle the height,
    /// unless the avoider climbs (then the height reached is held afterwards). Centred sticks
    /// hold as without the avoider, whatever its state.
    fn pos_hold(&mut self, now: Time, nav: &NavState, s: &ManualControl, dt_s: f64) -> SetpointTarget {
        let yaw_rate = s.yaw * self.params.yaw_rate_deg_s.to_radians();
        let yaw = self.held_yaw(nav, yaw_rate, dt_s);
        let (pz, vz) = self.vertical(nav, s);
        let centred = s.roll.abs() < STICK_CENTRED && s.pitch.abs() < STICK_CENTRED;
        let (pn, pe, vn, ve) = if centred {
            self.avoidance.reset();
            let p = *self.latched.hold.position.get_or_insert(Vector3::from(nav.position_ned_m));
            (Some(p.x), Some(p.y), None, None)
        } else {
            self.latched.hold.position = None;
            let v = self.params.stick_speed_m_s;
            let (sin, cos) = yaw.sin_cos();
            let (fwd, right) = (s.pitch * v, s.roll * v);
            let (vn, ve) = (fwd * cos - right * sin, fwd * sin + right * cos);
            if self.avoidance.active() {
                let velocity = Vector3::new(vn, ve, vz.unwrap_or(0.0));
                let leg = Leg::Sticks { velocity, forward_m_s: fwd, hold_down_m: pz };
                let blend = self.avoiding(now, dt_s, nav, leg);
                if blend.vertical_takeover {
                    // Re-latched at the height reached once the avoider lets go.
                    self.latched.hold.down_m = None;
                }
                let sp = TrajectorySetpoint { yaw_rate_rad_s: yaw_rate, ..blend.setpoint };
                return SetpointTarget::Trajectory(sp);
            }
            (None, None, Some(vn), Some(ve))
        };
        SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: [pn, pe, pz],
            velocity_ned_m_s: [vn, ve, vz],
            yaw_rad: Some(yaw),
            yaw_rate_rad_s: yaw_rate,
            ..TrajectorySetpoint::default()
        })
    }

    fn guided(&mut self, now: Time, dt_s: f64, nav: &NavState, on_ground: bool) -> SetpointTarget {
        if self.guided.drop_stale_stream(now, self.params.guided_timeout_s) {
            // A stream nobody repeats is not flown on for ever: hold where it stopped.
            self.latched.hold = Hold::default();
            self.announce(format!(
                "GUIDED: no velocity target for {} s, holding",
                self.params.guided_timeout_s
            ));
        }
        self.guided.advance(dt_s);
        let yaw = *self.latched.hold.yaw_rad.get_or_insert(heading(nav));
        if self.avoidance.active() {
            let leg = match self.guided.target() {
                GuidedTarget::Hold => None,
                GuidedTarget::Position(p) => {
                    Some(Leg::To { target: Vector3::from(p), speed_m_s: self.params.guided_speed_m_s })
                }
                GuidedTarget::Velocity(v) => Some(Leg::Velocity(Vector3::from(v))),
                GuidedTarget::Setpoint(t) => match (t.position_ned_m, t.velocity_ned_m_s) {
                    (Some(p), _) => Some(Leg::To {
                        target: Vector3::from(p),
                        speed_m_s: t.speed_m_s.unwrap_or(self.params.guided_speed_m_s),
                    }),
                    (None, Some(v)) => Some(Leg::Velocity(Vector3::from(v))),
                    (None, None) => None,
                },
                GuidedTarget::Attitude(_) => None,
            };
            match leg {
                Some(leg) => return SetpointTarget::Trajectory(self.avoiding(now, dt_s, nav, leg).setpoint),
                None => self.avoidance.reset(),
            }
        }
        match self.guided.target() {
            GuidedTarget::Hold if on_ground => SetpointTarget::MotorsOff,
            GuidedTarget::Hold => self.hold_here(nav),
            GuidedTarget::Position(p) => traj(p.map(Some), [None; 3], Some(yaw)),
            GuidedTarget::Velocity(v) => traj([None; 3], v.map(Some), Some(yaw)),
            GuidedTarget::Setpoint(t) => self.fly_position_target(nav, &t, dt_s),
            GuidedTarget::Attitude(t) => self.fly_attitude_target(nav, &t, dt_s),
        }
    }

    fn auto(&mut self, now: Time, dt_s: f64, nav: &NavState) -> SetpointTarget {
        if self.mission.paused {
            self.avoidance.reset();
            return self.hold_here(nav);
        }
        let ceiling = self.vertical.rangefinders().steady_ceiling_down_m(now, nav, &self.params.vertical);
        let (Some(frame), Some(runner)) = (self.home.frame(), self.mission.runner.as_mut()) else {
            self.avoidance.reset();
            return self.hold_here(nav);
        };
        let pos = Vector3::from(nav.position_ned_m);
        let home = self.home.ned().unwrap_or(pos);
        let step = runner.update(now, &pos, heading(nav), &frame, &home, ceiling);
        self.report_mission_events();
        let Some(runner) = self.mission.runner.as_mut() else { return self.hold_here(nav) };
        if !matches!(step, MissionStep::Fly(_) | MissionStep::Land { .. }) {
            self.avoidance.reset();
        }
        match step {
            MissionStep::Fly(sp @ TrajectorySetpoint { position_ned_m: [Some(n), Some(e), Some(d)], .. })
                if self.avoidance.active() =>
            {
                let speed_m_s = sp.max_horizontal_speed_m_s.unwrap_or(self.params.guided_speed_m_s);
                let leg = Leg::To { target: Vector3::new(n, e, d), speed_m_s };
                SetpointTarget::Trajectory(self.avoiding(now, dt_s, nav, leg).setpoint)
            }
            MissionStep::Fly(mut sp) => {
                // The mission's nose (a region of interest, a CONDITION_YAW turn, a circle's
                // centre) is latched, so that it is held once the mission lets go of it.
                let yaw =
                    sp.yaw_rad.unwrap_or_else(|| *self.latched.hold.yaw_rad.get_or_insert(heading(nav)));
                self.latched.hold.yaw_rad = Some(yaw);
                sp.yaw_rad = Some(yaw);
                SetpointTarget::Trajectory(sp)
            }
            MissionStep::Land { north_m, east_m } => self.land_at(now, dt_s, nav, Some([north_m, east_m])),
            MissionStep::ReturnToLaunch => {
                self.mission.last_progress = runner.progress();
                self.enter(FlightMode::ReturnToLaunch);
                self.rtl(now, dt_s, nav)
            }
            MissionStep::Finished => self.hold_here(nav),
        }
    }

    /// A leg flown with the avoider in the loop (`avoidance` module); a stale stream holds and
    /// says so once in the status (→ STATUSTEXT) and the log.
    fn avoiding(&mut self, now: Time, dt_s: f64, nav: &NavState, leg: Leg) -> Blend {
        let mut yaw = *self.latched.hold.yaw_rad.get_or_insert(heading(nav));
        let limits = Limits {
            timeout_s: self.params.avoidance_timeout_s,
            yaw_rate_rad_s: self.params.yaw_rate_deg_s.to_radians(),
        };
        let blend = self.avoidance.step(now, dt_s, nav, leg, &mut yaw, limits);
        self.latched.hold.yaw_rad = Some(yaw);
        match blend.hold_changed {
            Some(true) => {
                let why = "avoidance stale: slowing and holding position";
                tracing::warn!(mode = ?self.mode, "{why}");
                self.announce(why.to_owned());
            }
            Some(false) => tracing::info!(mode = ?self.mode, "avoidance hold over: flying the leg"),
            None => {}
        }
        blend
    }

    fn hold_here(&mut self, nav: &NavState) -> SetpointTarget {
        let p = *self.latched.hold.position.get_or_insert(Vector3::from(nav.position_ned_m));
        let yaw = *self.latched.hold.yaw_rad.get_or_insert(heading(nav));
        traj(at(&p), [None; 3], Some(yaw))
    }

    /// RTL: climb where it is to the RTL altitude (or stay higher), fly home at that altitude (or
    /// at the higher one an avoider climb on the way reached), loiter, land. With the avoider in
    /// the loop the way home is flown as an AUTO leg is ([`Leg::To`]): the nose turns homewards so
    /// that the forward camera looks along it, and what stands in the way (a tree above the RTL
    /// altitude) is sidestepped or climbed over as the avoider says, as ArduCopter's object
    /// avoidance acts in RTL (`OA_TYPE`); a stale stream slows and holds there, as in AUTO, until
    /// it is fresh again or a failsafe lands. The straight line is kept rather than the flown path
    /// retraced: the avoider corrects any leg, and a retraced path is no clearer once the wind or a
    /// moved obstacle has changed it. The climb and the descent are vertical, where the forward
    /// camera sees nothing: the rangefinders hold them (`vertical`).
    /// "Home" here is the return target chosen when RTL starts: home or a rally point (`rally`);
    /// a rally point's altitude above home raises the return altitude, as ArduCopter's does.
    fn rtl(&mut self, now: Time, dt_s: f64, nav: &NavState) -> SetpointTarget {
        let Some(launch) = self.home.ned() else { return self.land_at(now, dt_s, nav, None) };
        let pos = Vector3::from(nav.position_ned_m);
        let home = match self.latched.rtl_target {
            Some(target) => target,
            None => {
                let frame = self.home.frame();
                let target = self.rally.return_target(&self.params.rally, frame.as_ref(), &launch, &pos);
                if let Some(i) = target.rally {
                    tracing::info!(rally_point = i, ned_m = ?target.ned_m, "RTL to a rally point");
                }
                *self.latched.rtl_target.insert(target.ned_m)
            }
        };
        let yaw = *self.latched.hold.yaw_rad.get_or_insert(heading(nav));
        match self.latched.rtl {
            RtlPhase::Climb => {
                let down = self.rtl_down_m(&pos, &launch, &home);
                let start = *self.latched.hold.position.get_or_insert(pos);
                let down = *self.latched.hold.down_m.get_or_insert(down);
                // Held under something overhead, the climb ends there and the return sets off
                // at it, climbing the rest once out from under.
                if (pos.z - self.vertical.under_steady_ceiling(now, nav, down, &self.params.vertical)).abs()
                    < ALTITUDE_TOLERANCE_M
                {
                    self.latched.rtl = RtlPhase::Return { down_m: down };
                }
                traj([Some(start.x), Some(start.y), Some(down)], [None; 3], Some(yaw))
            }
            RtlPhase::Return { down_m } | RtlPhase::Loiter { down_m, .. } => {
                let distance = (pos.x - home.x).hypot(pos.y - home.y);
                let speed = nav.velocity_ned_m_s[0].hypot(nav.velocity_ned_m_s[1]);
                match self.latched.rtl {
                    RtlPhase::Return { .. } if distance < HOME_RADIUS_M && speed < HOME_SPEED_M_S => {
                        let loiter = std::time::Duration::from_secs_f64(self.params.rtl_loiter_s);
                        self.latched.rtl = RtlPhase::Loiter { down_m, until: now + loiter };
                        self.avoidance.reset();
                    }
                    RtlPhase::Loiter { until, .. } if now >= until => {
                        self.latched.rtl = RtlPhase::Land;
                        self.latched.hold.down_m = None;
                    }
                    _ => {}
                }
                if matches!(self.latched.rtl, RtlPhase::Return { .. }) && self.avoidance.active() {
                    let leg = Leg::To {
                        target: Vector3::new(home.x, home.y, down_m),
                        speed_m_s: self.params.rtl_speed_m_s,
                    };
                    let blend = self.avoiding(now, dt_s, nav, leg);
                    if blend.vertical_takeover && pos.z < down_m {
                        // Climbed over what stood in the way: home is flown at this altitude,
                        // not back down at the RTL altitude onto what was climbed over (the
                        // forward camera cannot see below), as PX4 (`RTL_RETURN_ALT`) and
                        // ArduPilot (`RTL_ALT`) return at the current altitude when above theirs.
                        self.latched.rtl = RtlPhase::Return { down_m: pos.z };
                    }
                    return SetpointTarget::Trajectory(blend.setpoint);
                }
                SetpointTarget::Trajectory(TrajectorySetpoint {
                    position_ned_m: [Some(home.x), Some(home.y), Some(down_m)],
                    max_horizontal_speed_m_s: Some(self.params.rtl_speed_m_s),
                    yaw_rad: Some(yaw),
                    ..TrajectorySetpoint::default()
                })
            }
            RtlPhase::Land => self.land_at(now, dt_s, nav, Some([home.x, home.y])),
        }
    }

    /// The altitude RTL returns at (NED down, m), as ArduCopter's `compute_return_target`: the
    /// highest of the RTL altitude, the current one and the return target's, then no higher
    /// than the ceiling less its margin (`FENCE_ALT_MAX - FENCE_MARGIN` above home) while the
    /// ceiling is enforced, and never below the current altitude: a vehicle above the ceiling
    /// returns where it is rather than descend on the way. Held by
    /// `tests::fence::rtl_returns_under_the_ceiling_and_never_descends_to_it`.
    pub(super) fn rtl_down_m(&self, pos: &Vector3<f64>, launch: &Vector3<f64>, home: &Vector3<f64>) -> f64 {
        let mut down = pos.z.min(launch.z - self.params.rtl_altitude_m).min(home.z.min(launch.z));
        let limits = &self.params.geofence;
        if self.geofence.enabled() && limits.types & kestrel_proto::messages::FENCE_ALT_MAX != 0 {
            down = down.max(launch.z - (limits.max_altitude_m - limits.margin_m));
        }
        down.min(pos.z)
    }

    /// Descends onto `xy` (NED north/east, m), flying there first if it is far; without a
    /// horizontal position it levels and descends. The approach is level, so with the avoider
    /// in the loop it is flown as a leg ([`Leg::To`], at the GUIDED speed): a landing item a
    /// few metres beside where a sidestep left the vehicle is no reason to fly blind. The
    /// descent is vertical, where the forward camera sees nothing: the downward rangefinder
    /// keeps it off an obstacle's top (`vertical::LandingSearch`).
    pub(super) fn land_at(
        &mut self,
        now: Time,
        dt_s: f64,
        nav: &NavState,
        xy: Option<[f64; 2]>,
    ) -> SetpointTarget {
        // The nearer of the height above home and the rangefinder's distance to what is below:
        // ground higher than home, or a top, slows the descent in time.
        let below = self.vertical.rangefinders().below_m(now, nav, &self.params.vertical);
        let height = below.map_or(self.home.height_m(nav), |b| b.min(self.home.height_m(nav)));
        let rate = if height > self.params.land_slow_height_m {
            self.params.land_fast_m_s
        } else {
            self.params.land_slow_m_s
        };
        let yaw = self.latched.hold.yaw_rad;
        match xy.filter(|_| nav.valid.horizontal_position) {
            Some([n, e]) => {
                let far =
                    (nav.position_ned_m[0] - n).hypot(nav.position_ned_m[1] - e) > LAND_APPROACH_RADIUS_M;
                if far && !self.latched.hold.landing {
                    let down = *self.latched.hold.down_m.get_or_insert(nav.position_ned_m[2]);
                    if self.avoidance.active() {
                        let leg = Leg::To {
                            target: Vector3::new(n, e, down),
                            speed_m_s: self.params.guided_speed_m_s,
                        };
                        return SetpointTarget::Trajectory(self.avoiding(now, dt_s, nav, leg).setpoint);
                    }
                    return traj([Some(n), Some(e), Some(down)], [None; 3], yaw);
                }
                self.latched.hold.landing = true;
                self.avoidance.reset();
                let reading = self.vertical.rangefinders().below(now, nav, &self.params.vertical);
                // Without a downward rangefinder there is nothing to search with: land as before.
                if reading.is_some() || self.vertical.landing_search.searching() {
                    let home_down = self.home.or_here(nav).z;
                    let facing = yaw.unwrap_or_else(|| heading(nav));
                    self.vertical.landing_search.step(
                        nav,
                        [n, e],
                        reading,
                        home_down,
                        facing,
                        &self.params.vertical,
                    );
                }
                let [sn, se] = self.vertical.landing_search.spot_ne_m.unwrap_or([n, e]);
                let [dn, de] = self.vertical.landing_search.offset_ne_m;
                let (n, e) = (sn + dn, se + de);
                match self
                    .vertical
                    .landing_search
                    .hold_down_m
                    .filter(|_| self.vertical.landing_search.searching())
                {
                    // Over an obstacle's top: hold above it and move off it (`vertical`).
                    Some(down) => traj([Some(n), Some(e), Some(down)], [None; 3], yaw),
                    None => traj([Some(n), Some(e), None], [None, None, Some(rate)], yaw),
                }
            }
            None => {
                self.latched.hold.landing = true;
                self.avoidance.reset();
                let v = nav.valid.horizontal_velocity.then_some(0.0);
                traj([None; 3], [v, v, Some(rate)], yaw)
            }
        }
    }
}
