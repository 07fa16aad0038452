//! The flight controller's state from its own telemetry, as Kestrel's messages: `NavState`
//! from ATTITUDE_QUATERNION (or ATTITUDE), LOCAL_POSITION_NED (or ODOMETRY) and HOME_POSITION,
//! and `VehicleStatus` from HEARTBEAT (custom mode, armed), EXTENDED_SYS_STATE and HOME_POSITION.
//!
//! Every sample carries the flight controller's boot time; a `NavState` is stamped with its
//! attitude's boot time mapped to our clock ([`FcClock`]) and published only once the clocks are
//! aligned. A part is valid only while fresh: attitude, position and velocity older than
//! [`STALE`] (by when they arrived) are published invalid, never as the last value flown on
//! (held by `stale_attitude_is_published_invalid`). A boot time going back is a reboot: the
//! clock alignment and every sample are dropped.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::attitude::quaternion_from_euler;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{FlightMode, Home, LandedState, NavState, NavValidity, VehicleStatus};
use mavlink::dialects::ardupilotmega::{MavAutopilot, MavFrame, MavLandedState, MavMessage, MavModeFlag};

use super::fc_clock::FcClock;
use super::fc_modes;

/// A part of the state older than this is invalid (ArduPilot's proximity timeout, and 25
/// attitude periods at the requested 50 Hz).
pub const STALE: Duration = Duration::from_millis(500);

#[derive(Clone, Copy, Debug)]
struct Attitude {
    boot_us: u64,
    q: [f64; 4],
    rates_rad_s: [f64; 3],
    received: Time,
}

#[derive(Clone, Copy, Debug)]
struct Local {
    position_ned_m: [f64; 3],
    velocity_ned_m_s: [f64; 3],
    received: Time,
}

#[derive(Clone, Copy, Debug)]
struct HomeFix {
    geodetic: Geodetic,
    /// Home in the flight controller's local frame (from its EKF origin), m.
    local_ned_m: [f64; 3],
}

/// What the reader produced from one message or tick.
#[derive(Debug, Default, PartialEq)]
pub struct Published {
    pub nav: Option<NavState>,
    pub status: Option<VehicleStatus>,
}

/// The newest of each part of the flight controller's state.
#[derive(Debug, Default)]
pub struct FcState {
    attitude: Option<Attitude>,
    /// When ATTITUDE_QUATERNION last came: ATTITUDE is then ignored (one NavState per cycle).
    quaternion_seen: Option<Time>,
    local: Option<Local>,
    home: Option<HomeFix>,
    home_revision: u32,
    landed: Option<LandedState>,
    last_boot_ms: Option<u32>,
    /// Whether the last NavState published was valid (an invalid one follows once stale).
    published_valid: bool,
    last_invalid: Option<Time>,
    /// NavStates not published because the clocks were not aligned yet.
    pub unsynced: u64,
    /// Heartbeats whose custom mode Kestrel has no `FlightMode` for (no status published).
    pub unknown_modes: u64,
    /// Reboots seen (boot time going back).
    pub reboots: u64,
}

impl FcState {
    /// Nothing heard yet.
    pub fn new() -> FcState {
        FcState::default()
    }

    /// A message from the flight controller (system and component already checked), arrived
    /// at `now`.
    pub fn on_message(
        &mut self,
        msg: &MavMessage,
        autopilot: MavAutopilot,
        clock: &mut FcClock,
        now: Time,
    ) -> Published {
        match msg {
            MavMessage::ATTITUDE_QUATERNION(a) => {
                self.boot(a.time_boot_ms, clock);
                self.quaternion_seen = Some(now);
                let q = [a.q1, a.q2, a.q3, a.q4].map(f64::from);
                let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
                if !(norm.is_finite() && (0.5..1.5).contains(&norm)) {
                    return Published::default();
                }
                let rates = [a.rollspeed, a.pitchspeed, a.yawspeed].map(f64::from);
                self.on_attitude(a.time_boot_ms, q.map(|v| v / norm), rates, clock, now)
            }
            MavMessage::ATTITUDE(a) => {
                self.boot(a.time_boot_ms, clock);
                if self.quaternion_seen.is_some_and(|t| now.saturating_since(t) <= STALE) {
                    return Published::default();
                }
                let q = quaternion_from_euler(f64::from(a.roll), f64::from(a.pitch), f64::from(a.yaw));
                let rates = [a.rollspeed, a.pitchspeed, a.yawspeed].map(f64::from);
                self.on_attitude(a.time_boot_ms, q, rates, clock, now)
            }
            MavMessage::LOCAL_POSITION_NED(p) => {
                self.boot(p.time_boot_ms, clock);
                let position_ned_m = [p.x, p.y, p.z].map(f64::from);
                let velocity_ned_m_s = [p.vx, p.vy, p.vz].map(f64::from);
                self.on_local(position_ned_m, velocity_ned_m_s, now);
                Published::default()
            }
            MavMessage::ODOMETRY(o) => {
                // Position in the local NED frame only; velocity in NED, or in the body frame
                // rotated by the message's own attitude.
                if !matches!(o.frame_id, MavFrame::MAV_FRAME_LOCAL_NED) {
                    return Published::default();
                }
                let position_ned_m = [o.x, o.y, o.z].map(f64::from);
                let v = [o.vx, o.vy, o.vz].map(f64::from);
                let velocity_ned_m_s = match o.child_frame_id {
                    MavFrame::MAV_FRAME_LOCAL_NED => v,
                    MavFrame::MAV_FRAME_BODY_FRD => {
                        rotate([o.q[0], o.q[1], o.q[2], o.q[3]].map(f64::from), v)
                    }
                    _ => return Published::default(),
                };
                self.on_local(position_ned_m, velocity_ned_m_s, now);
                Published::default()
            }
            MavMessage::HOME_POSITION(h) => {
                let geodetic = Geodetic {
                    lat_deg: f64::from(h.latitude) * 1e-7,
                    lon_deg: f64::from(h.longitude) * 1e-7,
                    alt_m: f64::from(h.altitude) * 1e-3,
                };
                let local_ned_m = [h.x, h.y, h.z].map(f64::from);
                if !local_ned_m.iter().all(|v| v.is_finite()) || !(-90.0..=90.0).contains(&geodetic.lat_deg) {
                    return Published::default();
                }
                let moved =
                    self.home.is_none_or(|old| old.geodetic != geodetic || old.local_ned_m != local_ned_m);
                if moved {
                    self.home_revision = self.home_revision.wrapping_add(1);
                    self.home = Some(HomeFix { geodetic, local_ned_m });
                }
                Published::default()
            }
            MavMessage::EXTENDED_SYS_STATE(e) => {
                self.landed = match e.landed_state {
                    MavLandedState::MAV_LANDED_STATE_ON_GROUND => Some(LandedState::OnGround),
                    MavLandedState::MAV_LANDED_STATE_IN_AIR | MavLandedState::MAV_LANDED_STATE_TAKEOFF => {
                        Some(LandedState::InAir)
                    }
                    MavLandedState::MAV_LANDED_STATE_LANDING => Some(LandedState::Landing),
                    MavLandedState::MAV_LANDED_STATE_UNDEFINED => None,
                };
                Published::default()
            }
            MavMessage::HEARTBEAT(hb) => {
                let armed = hb.base_mode.contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
                let Some(mode) = fc_modes::flight_mode(autopilot, hb.custom_mode) else {
                    self.unknown_modes += 1;
                    return Published::default();
                };
                Published { nav: None, status: Some(self.status(armed, mode, now)) }
            }
            _ => Published::default(),
        }
    }

    /// Periodic check: an invalid NavState (10 Hz) while the attitude is stale.
    pub fn on_tick(&mut self, now: Time) -> Option<NavState> {
        let a = self.attitude?;
        if now.saturating_since(a.received) <= STALE {
            return None;
        }
        let due = self.published_valid
            || self.last_invalid.is_none_or(|t| now.saturating_since(t) >= Duration::from_millis(100));
        if !due {
            return None;
        }
        self.published_valid = false;
        self.last_invalid = Some(now);
        let mut nav = self.nav(a, now, now);
        nav.valid = NavValidity::default();
        Some(nav)
    }

    fn boot(&mut self, boot_ms: u32, clock: &mut FcClock) {
        if let Some(last) = self.last_boot_ms
            && boot_ms.saturating_add(1000) < last
        {
            tracing::warn!(
                last_ms = last,
                now_ms = boot_ms,
                "flight controller rebooted: its state and clock are relearnt"
            );
            *self = FcState {
                reboots: self.reboots + 1,
                unsynced: self.unsynced,
                unknown_modes: self.unknown_modes,
                ..FcState::default()
            };
            clock.reset();
        }
        self.last_boot_ms = Some(boot_ms);
    }

    fn on_local(&mut self, position_ned_m: [f64; 3], velocity_ned_m_s: [f64; 3], now: Time) {
        if position_ned_m.iter().chain(&velocity_ned_m_s).all(|v| v.is_finite()) {
            self.local = Some(Local { position_ned_m, velocity_ned_m_s, received: now });
        }
    }

    fn on_attitude(
        &mut self,
        boot_ms: u32,
        q: [f64; 4],
        rates_rad_s: [f64; 3],
        clock: &FcClock,
        now: Time,
    ) -> Published {
        if !q.iter().chain(&rates_rad_s).all(|v| v.is_finite()) {
            return Published::default();
        }
        let a = Attitude { boot_us: u64::from(boot_ms) * 1000, q, rates_rad_s, received: now };
        self.attitude = Some(a);
        let Some(time) = clock.to_local(a.boot_us) else {
            self.unsynced += 1;
            return Published::default();
        };
        self.published_valid = true;
        Published { nav: Some(self.nav(a, time, now)), status: None }
    }

    fn nav(&self, a: Attitude, time: Time, now: Time) -> NavState {
        let fresh = |t: Time| now.saturating_since(t) <= STALE;
        let local = self.local.filter(|l| fresh(l.received));
        let (position_ned_m, velocity_ned_m_s) =
            self.local.map_or(([0.0; 3], [0.0; 3]), |l| (l.position_ned_m, l.velocity_ned_m_s));
        let observed = local.is_some();
        NavState {
            time,
            attitude: a.q,
            angular_velocity_rad_s: a.rates_rad_s,
            velocity_ned_m_s,
            position_ned_m,
            // The flight controller's estimator keeps its biases and variances to itself.
            gyro_bias_rad_s: [0.0; 3],
            accel_bias_m_s2: [0.0; 3],
            covariance_diagonal: [0.0; 16],
            origin: self.origin(),
            valid: NavValidity {
                attitude: fresh(a.received),
                horizontal_velocity: observed,
                horizontal_velocity_from_drag: false,
                horizontal_position: observed,
                vertical_velocity: observed,
                vertical_position: observed,
            },
        }
    }

    /// The flight controller's local origin: home moved back by home's local position.
    fn origin(&self) -> Option<Geodetic> {
        let h = self.home?;
        Some(LocalFrame::new(h.geodetic).to_geodetic(h.local_ned_m.map(|v| -v)))
    }

    fn status(&self, armed: bool, mode: FlightMode, now: Time) -> VehicleStatus {
        VehicleStatus {
            time: now,
            armed,
            mode,
            // Without EXTENDED_SYS_STATE: a disarmed multirotor is on the ground, an armed one
            // is taken as flying (the conservative reading for an avoider).
            landed: self.landed.unwrap_or(if armed { LandedState::InAir } else { LandedState::OnGround }),
            failsafe: None,
            mission: Default::default(),
            last_refusal: None,
            refusals: 0,
            armable: false,
            home: self.home.map(|h| Home { position_ned_m: h.local_ned_m, revision: self.home_revision }),
            geofence_enabled: false,
            failed_motor: None,
            speed_cap: None,
            vertical_limit: None,
            fence: Default::default(),
        }
    }
}

/// `v` rotated from the body frame to NED by the attitude quaternion `q` (`[w, x, y, z]`).
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let [w, x, y, z] = q;
    let r = [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ];
    r.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}
