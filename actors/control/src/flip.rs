//! The FLIP: a full 360° roll on command, then recovery to level (the thesis's "aerobatic
//! mode"; the phases follow ArduPilot's `mode_flip.cpp`).
//!
//! Phases: *climb* (a short thrust boost, level, to buy height), *roll* (a body roll rate
//! about forward, thrust boosted while the thrust still points up and cut to the minimum while
//! it points down, so the motors never drive the vehicle towards the ground), *recover* (level
//! attitude, heading as at the start, thrust above hover until level and slow). Progress is
//! the integral of the measured roll rate, which is the roll angle during a pure roll and
//! keeps counting through 180°, where Euler angles jump. A roll that takes too long is cut
//! short into recovery.

use kestrel_proto::Time;
use kestrel_proto::attitude::{tilt_rad, wxyz};
use kestrel_proto::messages::{NavState, SetpointTarget};
use nalgebra::{UnitQuaternion, Vector3};

use crate::commander::attitude;
use crate::position::yaw_of;

/// Roll rate of the flip (rad/s): about 520°/s (ArduPilot rolls at 400°/s with a weaker frame).
const ROLL_RATE_RAD_S: f64 = 9.0;
/// Length of the climb phase (s).
const CLIMB_S: f64 = 0.45;
/// The roll hands over to recovery this far short of 360° (rad): the attitude loop finishes it.
const ROLL_HANDOVER_RAD: f64 = 0.6;
/// Longest roll before it is cut short (s).
const ROLL_TIMEOUT_S: f64 = 2.0;
/// Recovery is done once tilt and body rate are below these (rad, rad/s).
const LEVEL_TILT_RAD: f64 = 0.15;
const LEVEL_RATE_RAD_S: f64 = 0.5;
/// Longest recovery (s); the flip ends regardless.
const RECOVER_TIMEOUT_S: f64 = 3.0;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Climb,
    Roll { rolled_rad: f64, since: Time },
    Recover { since: Time },
    Done,
}

/// A flip in progress.
#[derive(Clone, Debug)]
pub struct Flip {
    phase: Phase,
    started: Time,
    last: Time,
    hover_thrust: f64,
    heading: UnitQuaternion<f64>,
}

impl Flip {
    /// Starts a flip at `nav`; `hover_thrust` is the collective share that hovers.
    pub fn start(nav: &NavState, hover_thrust: f64) -> Flip {
        let q = attitude(nav);
        Flip {
            phase: Phase::Climb,
            started: nav.time,
            last: nav.time,
            hover_thrust,
            heading: UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_of(&q)),
        }
    }

    /// True once the vehicle is level again.
    pub fn done(&self) -> bool {
        self.phase == Phase::Done
    }

    /// Advances with `nav` and returns the target to fly now (a level attitude once done).
    pub fn update(&mut self, nav: &NavState) -> SetpointTarget {
        let dt = nav.time.saturating_since(self.last).as_secs_f64();
        self.last = nav.time;
        let q = attitude(nav);
        let omega = Vector3::from(nav.angular_velocity_rad_s);
        let h = self.hover_thrust;
        let level = SetpointTarget::Attitude {
            attitude: wxyz(&self.heading),
            yaw_rate_rad_s: 0.0,
            thrust: (h * 1.3).min(0.9),
        };
        match self.phase {
            Phase::Climb => {
                if nav.time.saturating_since(self.started).as_secs_f64() >= CLIMB_S {
                    self.phase = Phase::Roll { rolled_rad: 0.0, since: nav.time };
                    return self.update(nav);
                }
                SetpointTarget::Attitude {
                    attitude: wxyz(&self.heading),
                    yaw_rate_rad_s: 0.0,
                    thrust: (h * 2.1).min(0.9),
                }
            }
            Phase::Roll { rolled_rad, since } => {
                let rolled = rolled_rad + omega.x * dt;
                let timed_out = nav.time.saturating_since(since).as_secs_f64() > ROLL_TIMEOUT_S;
                if rolled >= 2.0 * std::f64::consts::PI - ROLL_HANDOVER_RAD || timed_out {
                    self.phase = Phase::Recover { since: nav.time };
                    return level;
                }
                self.phase = Phase::Roll { rolled_rad: rolled, since };
                // Thrust axis above the horizon: boost; below: minimum.
                let up = -(q * Vector3::z()).z;
                let thrust = if up > 0.3 { (h * 1.2).min(0.9) } else { 0.05 };
                SetpointTarget::Rates { rates_frd_rad_s: [ROLL_RATE_RAD_S, 0.0, 0.0], thrust }
            }
            Phase::Recover { since } => {
                let tilt = tilt_rad(&q);
                let timed_out = nav.time.saturating_since(since).as_secs_f64() > RECOVER_TIMEOUT_S;
                if (tilt < LEVEL_TILT_RAD && omega.norm() < LEVEL_RATE_RAD_S) || timed_out {
                    self.phase = Phase::Done;
                }
                level
            }
            Phase::Done => level,
        }
    }
}
