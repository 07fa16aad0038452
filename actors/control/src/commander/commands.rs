//! What a ground station (or the runtime) asks of the commander: a mission upload and the
//! commands of `VehicleCommand`, each accepted or refused with the reason (also in the next
//! status, as a STATUSTEXT). A command is ACKed accepted only when it is carried out.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    AttitudeTarget, Command, FlightMode, LandedState, Mission, PositionTarget, VehicleCommand,
};
use nalgebra::Vector3;

use super::arming::{Refusal, refuse};
use super::guided::GuidedTarget;
use super::modes::Hold;
use super::pilot_input::PilotLimits;
use super::{Commander, feasibility, heading};
use crate::flip::Flip;

/// Largest acceleration a position target may carry (m/s²): ArduCopter refuses velocities
/// above 1000 m/s and checks no acceleration; 2 g is beyond what its position controller flies
/// (`PSC_ACC_XY_MAX` 5 m/s² by default) and keeps a wild value from reaching the loop.
const MAX_TARGET_ACCELERATION_M_S2: f64 = 2.0 * kestrel_proto::units::GRAVITY_M_S2;

impl Commander {
    /// A new mission; replaces the old one, and one of no items clears it. Refused when a field
    /// is not a number or there are too many items (`Mission::check_fields`, which the link runs
    /// before it acknowledges an upload). One that is well-formed but cannot be flown from here
    /// (below home, outside the fence, too far: `feasibility`) is kept — the ground station holds
    /// it, and flying an older one instead would be worse — and refused, by item, when AUTO is
    /// asked for; the reason is reported at once as well.
    ///
    /// While AUTO flies the old one, the new one is flown from the same item index (its last
    /// item when it is shorter: `MissionRunner::replace`), as ArduCopter restarts its current
    /// command; one that cannot be flown from here pauses the mission where the vehicle is (as
    /// DO_PAUSE_CONTINUE does), the reason said, until a ground station continues it or sends
    /// another. Held by `tests::mission::a_mission_uploaded_in_auto_is_flown_from_the_same_item`.
    pub fn on_mission(&mut self, mission: Mission) -> Result<(), Refusal> {
        let flying = self.armed && self.mode == FlightMode::Auto && self.mission.runner.is_some();
        if mission.items.is_empty() {
            // No items: the ground station cleared its mission (MISSION_CLEAR_ALL, or home
            // alone uploaded). Not while it is flown: the link refuses that clear as well.
            if flying {
                return self.refused(refuse("mission clear refused while flying AUTO"));
            }
            self.mission.clear();
            return Ok(());
        }
        let fields = feasibility::check_fields(&mission);
        self.refused(fields)?;
        let feasible = self.mission_feasible(&mission);
        let infeasible = self.refused(feasible).is_err();
        if self.mission.upload(mission, flying) {
            // Drop what AUTO latched for the old item (a landing under way, a held position).
            let paused = self.mission.paused || infeasible;
            self.enter(FlightMode::Auto);
            self.mission.paused = paused;
        }
        Ok(())
    }

    /// A command; refused ones say why (also in the next status).
    pub fn on_command(&mut self, cmd: &VehicleCommand) -> Result<(), Refusal> {
        let now = cmd.time;
        let result = match cmd.command {
            Command::Heartbeat { system_id } => {
                // Another system's heartbeat is answered by the link and holds off nothing here.
                self.pilot.on_heartbeat(system_id, now, &PilotLimits::of(&self.params));
                Ok(())
            }
            Command::Arm => self.arm(now),
            Command::Disarm { force } => {
                if self.landing.state() == LandedState::OnGround || force {
                    self.disarm("commanded");
                    Ok(())
                } else {
                    refuse("disarm refused in flight (use force)")
                }
            }
            Command::SetMode(mode) => self.set_mode(now, mode),
            Command::Takeoff { altitude_m } => {
                if !(altitude_m.is_finite()
                    && altitude_m > 1.0
                    && altitude_m <= self.params.geofence.max_altitude_m)
                {
                    refuse(format!("take-off altitude {altitude_m} m out of range"))
                } else if !self.armed {
                    refuse("take-off refused: not armed")
                } else {
                    self.guided.set_takeoff_height_m(altitude_m);
                    self.set_mode(now, FlightMode::Takeoff)
                }
            }
            Command::Land => self.set_mode(now, FlightMode::Land),
            Command::Shutdown => {
                self.on_shutdown(now);
                Ok(())
            }
            Command::ReturnToLaunch => self.set_mode(now, FlightMode::ReturnToLaunch),
            Command::MissionStart => self.mode_allowed(now, FlightMode::Auto).and_then(|()| {
                // MISSION_START in AUTO restarts the mission from its first item (or the one a
                // ground station made current since): a fresh run replaces the one flying.
                let restart = self.mode == FlightMode::Auto;
                if restart {
                    self.mission.runner = None;
                }
                let r = self.set_mode(now, FlightMode::Auto);
                if restart {
                    self.enter(FlightMode::Auto);
                }
                r
            }),
            Command::Flip => self.start_flip(now),
            Command::GotoNed { position_ned_m } => {
                self.guided_command(now, GuidedTarget::Position(position_ned_m))
            }
            Command::VelocityNed { velocity_ned_m_s } => {
                self.guided_command(now, GuidedTarget::Velocity(velocity_ned_m_s))
            }
            Command::PositionTarget(t) => self.position_target(now, t),
            Command::AttitudeTarget(t) => self.attitude_target(now, t),
            Command::GuidedStop => self.guided_command(now, GuidedTarget::Hold).map(|()| {
                self.latched.hold = Hold::default();
            }),
            Command::SetHome { point } => self.set_home(now, point),
            Command::SetGeofence { enabled } => {
                self.geofence.set_enabled(enabled);
                Ok(())
            }
            Command::SetMissionCurrent { index } => self.set_mission_current(index),
            Command::LandStart => self.jump_to_landing_sequence(now),
            Command::ChangeSpeed { speed_m_s } => self.change_speed(speed_m_s),
            Command::Yaw { .. } | Command::RegionOfInterest { .. }
                if !matches!(self.mode, FlightMode::Guided | FlightMode::Auto) =>
            {
                refuse("yaw and region of interest are flown in GUIDED and AUTO only")
            }
            Command::Yaw { heading_deg, relative_deg } => {
                let current = self.nav.latest().map_or(0.0, heading);
                self.guided.set_yaw(heading_deg, relative_deg, current)
            }
            Command::RegionOfInterest { position_ned_m } => {
                self.guided.set_region_of_interest(position_ned_m)
            }
            Command::Orbit { radius_m, speed_m_s, yaw, centre_ne_m, centre_down_m } => {
                self.orbit(now, radius_m, speed_m_s, yaw, centre_ne_m, centre_down_m)
            }
            Command::Reboot { force } => self.reboot(force),
            Command::MotorTest { .. } => self.motor_test(),
            Command::FollowTarget(t) => {
                self.on_follow_target(now, &t);
                Ok(())
            }
            Command::PauseMission | Command::ContinueMission
                if self.mode != FlightMode::Auto || self.mission.runner.is_none() =>
            {
                refuse("pause/continue refused: no mission is being flown in AUTO")
            }
            Command::PauseMission => {
                if !self.mission.paused {
                    tracing::info!("mission paused");
                    self.latched.hold = Hold::default();
                }
                self.mission.paused = true;
                Ok(())
            }
            Command::ContinueMission => {
                if self.mission.paused {
                    tracing::info!("mission continued");
                }
                self.mission.paused = false;
                Ok(())
            }
        };
        self.refused(result)
    }

    /// MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: taken disarmed; the runtime then ends the process with
    /// `kestrel::reboot::REBOOT_EXIT_CODE`, which the systemd unit restarts. Armed it is refused,
    /// as ArduCopter refuses it (its ACK FAILED, ours DENIED), unless `force` (ArduPilot's
    /// param6 magic) asks for it on the ground: then the vehicle disarms first. In the air a
    /// forced reboot is refused too, where ArduCopter would stop its motors. Held by
    /// `tests/modes.rs::reboot_is_taken_disarmed_and_forced_only_on_the_ground`.
    fn reboot(&mut self, force: bool) -> Result<(), Refusal> {
        if self.armed {
            if !force {
                return refuse("reboot refused: vehicle is armed");
            }
            if self.landing.state() != LandedState::OnGround {
                return refuse("reboot refused: vehicle is flying");
            }
            self.disarm("reboot");
        }
        tracing::warn!("reboot requested: the process restarts");
        Ok(())
    }

    /// MAV_CMD_DO_MOTOR_TEST: taken only disarmed and landed, as ArduCopter's
    /// `mavlink_motor_test_check` ("vehicle not landed"; a test starts disarmed), and only where
    /// a calibration actor reports (it spins the motors on this answer, `motor_test.rs` in the
    /// sensors crate) and runs no calibration. Held by
    /// `tests/modes.rs::motor_test_is_taken_only_disarmed_landed_and_where_something_spins_them`.
    fn motor_test(&mut self) -> Result<(), Refusal> {
        if self.armed {
            return refuse("motor test refused: armed");
        }
        if self.landing.state() != LandedState::OnGround {
            return refuse("motor test refused: vehicle not landed");
        }
        match &self.calibration {
            None => refuse("motor test refused: nothing in this graph drives the motors directly"),
            Some(c) => match c.running {
                Some(step) => refuse(format!("motor test refused: {} calibration running", step.name())),
                None => Ok(()),
            },
        }
    }

    fn start_flip(&mut self, now: Time) -> Result<(), Refusal> {
        if self.mode != FlightMode::Acro {
            return refuse("flip refused: only in ACRO");
        }
        if self.landing.state() != LandedState::InAir {
            return refuse("flip refused: not flying");
        }
        let Some(nav) = self.fresh_nav(now).cloned() else {
            return refuse("flip refused: no navigation state");
        };
        if self.home.height_m(&nav) < self.params.flip_min_height_m {
            return refuse(format!("flip refused: below {} m", self.params.flip_min_height_m));
        }
        self.latched.flip = Some(Flip::start(&nav, self.params.hover_thrust));
        Ok(())
    }

    /// DO_CHANGE_SPEED: the running mission's leg speed (m/s), within the feasibility limit.
    fn change_speed(&mut self, speed_m_s: f64) -> Result<(), Refusal> {
        let max = self.params.feasibility.max_velocity_m_s;
        if !(speed_m_s.is_finite() && speed_m_s > 0.0 && speed_m_s <= max) {
            return refuse(format!("speed {speed_m_s} m/s refused: 0 < speed <= {max} m/s"));
        }
        match (&mut self.mission.runner, self.mode) {
            (Some(runner), FlightMode::Auto) => {
                runner.set_cruise(speed_m_s);
                Ok(())
            }
            _ => refuse("DO_CHANGE_SPEED refused: flown in AUTO only"),
        }
    }

    fn guided_command(&mut self, now: Time, target: GuidedTarget) -> Result<(), Refusal> {
        self.guided_target_refused(target)?;
        self.guided.set_target(target, now);
        Ok(())
    }

    /// Whether GUIDED may fly `target` now: in GUIDED, finite, the position where a goto may go,
    /// the velocity within the feasibility limit.
    fn guided_target_refused(&self, target: GuidedTarget) -> Result<(), Refusal> {
        if self.mode != FlightMode::Guided {
            return refuse("position/velocity targets are accepted in GUIDED only");
        }
        let finite = match target {
            GuidedTarget::Position(v) | GuidedTarget::Velocity(v) => v.iter().all(|x| x.is_finite()),
            GuidedTarget::Hold | GuidedTarget::Setpoint(_) | GuidedTarget::Attitude(_) => true,
        };
        if !finite {
            return refuse("guided target is not finite");
        }
        match target {
            GuidedTarget::Position(p) => {
                if let Some(why) = self.guided_position_refused(&Vector3::from(p)) {
                    return refuse(format!("guided target refused: {why}"));
                }
            }
            GuidedTarget::Velocity(v) => {
                let (speed, max) = (Vector3::from(v).norm(), self.params.feasibility.max_velocity_m_s);
                if speed > max {
                    return refuse(format!("guided velocity refused: {speed:.1} m/s, at most {max:.1} m/s"));
                }
            }
            GuidedTarget::Hold | GuidedTarget::Setpoint(_) | GuidedTarget::Attitude(_) => {}
        }
        Ok(())
    }

    /// SET_POSITION_TARGET_*: one of ArduCopter's four combinations (position; velocity with or
    /// without acceleration; acceleration; position and velocity with or without acceleration),
    /// every value finite, the position checked as a goto is and the velocity against the
    /// feasibility limit. A yaw turns the held heading to it at once. Held by
    /// `tests::guided::position_targets_are_checked_as_gotos_and_velocities_are`.
    fn position_target(&mut self, now: Time, t: PositionTarget) -> Result<(), Refusal> {
        let vectors = [t.position_ned_m, t.velocity_ned_m_s, t.acceleration_ned_m_s2];
        let scalars = [t.yaw_rad, t.yaw_rate_rad_s];
        if !(vectors.iter().flatten().flatten().chain(scalars.iter().flatten()).all(|v| v.is_finite())) {
            return refuse("position target is not finite");
        }
        if !matches!(
            vectors,
            [Some(_), None, None] | [None, Some(_), _] | [None, None, Some(_)] | [Some(_), Some(_), _]
        ) {
            return refuse("position target refused: give a position, a velocity or an acceleration");
        }
        if let Some(a) = t.acceleration_ned_m_s2
            && Vector3::from(a).norm() > MAX_TARGET_ACCELERATION_M_S2
        {
            return refuse(format!(
                "position target refused: acceleration above {MAX_TARGET_ACCELERATION_M_S2} m/s²"
            ));
        }
        if let Some(speed) = t.speed_m_s {
            let max = self.params.feasibility.max_velocity_m_s;
            if !(speed.is_finite() && speed > 0.0 && speed <= max && t.position_ned_m.is_some()) {
                return refuse(format!(
                    "position target refused: speed {speed} m/s, not 0 < speed <= {max} m/s to a position"
                ));
            }
        }
        if let Some(p) = t.position_ned_m {
            self.guided_target_refused(GuidedTarget::Position(p))?;
        }
        if let Some(v) = t.velocity_ned_m_s {
            self.guided_target_refused(GuidedTarget::Velocity(v))?;
        }
        self.guided_command(now, GuidedTarget::Setpoint(t))?;
        if let Some(yaw) = t.yaw_rad {
            self.latched.hold.yaw_rad = Some(yaw);
        }
        Ok(())
    }

    /// SET_ATTITUDE_TARGET: a unit attitude, a finite yaw rate and a climb share within -1..1.
    fn attitude_target(&mut self, now: Time, t: AttitudeTarget) -> Result<(), Refusal> {
        let norm = t.attitude.iter().map(|v| v * v).sum::<f64>().sqrt();
        // ArduCopter's `Quaternion::is_unit_length` tolerance.
        if !((norm - 1.0).abs() <= 1e-3 && t.yaw_rate_rad_s.is_finite() && (-1.0..=1.0).contains(&t.climb)) {
            return refuse(
                "attitude target refused: not a unit attitude, a finite rate and a climb in -1..1",
            );
        }
        self.guided_command(now, GuidedTarget::Attitude(t))
    }
}
