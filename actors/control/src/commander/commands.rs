//! What a ground station (or the runtime) asks of the commander: a mission upload and the
//! commands of `VehicleCommand`, each accepted or refused with the reason (also in the next
//! status, as a STATUSTEXT). A command is ACKed accepted only when it is carried out.

use kestrel_proto::Time;
use kestrel_proto::messages::{Command, FlightMode, LandedState, Mission, VehicleCommand};
use nalgebra::Vector3;

use super::arming::{Refusal, refuse};
use super::guided::GuidedTarget;
use super::modes::Hold;
use super::pilot_input::PilotLimits;
use super::{Commander, feasibility, heading};
use crate::flip::Flip;

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
            Command::SetHome { point } => self.set_home(now, point),
            Command::SetGeofence { enabled } => {
                self.geofence.set_enabled(enabled);
                Ok(())
            }
            Command::SetMissionCurrent { index } => self.set_mission_current(index),
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
            Command::Reboot => self.reboot(),
            Command::MotorTest { .. } => self.motor_test(),
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

    /// MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: refused while armed, as ArduCopter refuses it (its
    /// ACK FAILED, ours DENIED). Disarmed it is refused too: nothing in the runtime restarts the
    /// process on it yet, and a command is never acknowledged unless it is carried out.
    fn reboot(&mut self) -> Result<(), Refusal> {
        if self.armed {
            return refuse("reboot refused: vehicle is armed");
        }
        refuse("reboot refused: restart the kestrel service instead")
    }

    /// MAV_CMD_DO_MOTOR_TEST: refused unless disarmed and landed, as ArduCopter's
    /// `mavlink_motor_test_check` ("vehicle not landed", and a test only starts disarmed).
    fn motor_test(&mut self) -> Result<(), Refusal> {
        if self.armed {
            return refuse("motor test refused: armed");
        }
        if self.landing.state() != LandedState::OnGround {
            return refuse("motor test refused: vehicle not landed");
        }
        refuse("motor test refused: not supported by this vehicle's outputs")
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
        if self.mode != FlightMode::Guided {
            return refuse("position/velocity targets are accepted in GUIDED only");
        }
        let finite = match target {
            GuidedTarget::Position(v) | GuidedTarget::Velocity(v) => v.iter().all(|x| x.is_finite()),
            GuidedTarget::Hold => true,
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
            GuidedTarget::Hold => {}
        }
        self.guided.set_target(target, now);
        Ok(())
    }
}
