//! FOLLOW: fly after another system at an offset, from the position reports it sends.
//!
//! As ArduCopter 4.7's `ModeFollow` over `AP_Follow`, with its `FOLL_*` parameters:
//! * Reports (FOLLOW_TARGET, GLOBAL_POSITION_INT; the link decodes them) count only with
//!   `FOLL_ENABLE` 1 and from `FOLL_SYSID`, or with `FOLL_SYSID` 0 from the first system heard,
//!   forgotten again after [`SYSID_TIMEOUT_S`] of silence. Once a system sends FOLLOW_TARGET its
//!   GLOBAL_POSITION_INT is ignored. With a relative offset (`FOLL_OFS_TYPE` 1) a report without
//!   a heading is ignored, as the offset cannot be turned.
//! * The target is predicted from its last report to now with its velocity and acceleration
//!   ([`Report::predict`]); ArduCopter then smooths the prediction with its jerk-limited
//!   `FOLL_ACCEL_*`/`FOLL_JERK_*` shaping, which we leave to the position controller's own
//!   limits. A report older than [`TARGET_TIMEOUT_S`] (`AP_FOLLOW_TIMEOUT_MS`), or a target
//!   farther than `FOLL_DIST_MAX` from the vehicle, is no target: the vehicle stops at the
//!   waypoint acceleration and holds, as ArduCopter's FOLLOW then feeds zero velocity.
//! * The point flown is the target plus the offset (`FOLL_OFS_X/Y/Z`, north-east-down or, type 1,
//!   forward-right-down of the target's heading), with the target's velocity and acceleration as
//!   feed-forward. All-zero offsets take the vehicle's place relative to the target when the
//!   mode starts, as ArduCopter's `init_offsets_if_required` (here latched for the mode instead
//!   of written into the parameters).
//! * The nose per `FOLL_YAW_BEHAVE`: 0 held, 1 at the target (beyond 1 m), 2 as the target's
//!   heading, 3 along the velocity flown (above 1 m/s).
//! * Entering FOLLOW needs `FOLL_ENABLE` ("Set FOLL_ENABLE = 1") and a position estimate, not a
//!   target: without one it holds, as ArduCopter's does. It does not arm (`allows_arming`).
//! * Beyond ArduCopter: a point that a GUIDED target could not be (outside the fence, too far
//!   from home, below the least height; `feasibility`) is not flown either: the vehicle stops
//!   and holds there and says why, rather than fly into the fence's breach action.
//!
//! Held by `tests` here (offset frames, timeout, distance limit, sysid choice, the prediction's
//! proptest) and the closed-loop flight in `actors/control/tests/follow.rs` (tracking error
//! behind a target at 3 m/s, on a straight line and through a turn).

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{FollowSource, FollowTarget, NavState, SetpointTarget, TrajectorySetpoint};
use kestrel_proto::param_def::{self, ParamChange, ParamDef, ParamRefused, WhileArmed};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::brake::Brake;
use super::params::CommanderParams;
use super::{Commander, heading};
use crate::error::{InvalidParam, within};

/// A report older than this is no target (s): ArduPilot's `AP_FOLLOW_TIMEOUT_MS`.
pub const TARGET_TIMEOUT_S: f64 = 3.0;
/// With `FOLL_SYSID` 0, the system adopted is forgotten after this long unheard (s):
/// `AP_FOLLOW_SYSID_TIMEOUT_MS`.
pub const SYSID_TIMEOUT_S: f64 = 10.0;
/// `FOLL_YAW_BEHAVE` 1 turns to the target only when it is farther than this (m), 3 along the
/// velocity only when faster than this (m/s): ArduCopter's `length_squared() > 1`.
const YAW_MIN_DISTANCE_M: f64 = 1.0;
const YAW_MIN_SPEED_M_S: f64 = 1.0;

/// How `FOLL_OFS_X/Y/Z` are read (`FOLL_OFS_TYPE`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OffsetFrame {
    /// North, east, down (0).
    #[default]
    Ned,
    /// Forward, right, down of the target's heading (1).
    Relative,
}

/// Where the nose points (`FOLL_YAW_BEHAVE`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FollowYaw {
    /// Held (0).
    None,
    /// At the target (1, ArduCopter's default).
    #[default]
    FaceTarget,
    /// As the target's heading (2).
    SameAsTarget,
    /// Along the velocity flown (3).
    DirectionOfFlight,
}

/// Which altitude of a GLOBAL_POSITION_INT is followed (`FOLL_ALT_TYPE`); FOLLOW_TARGET has only
/// the one above mean sea level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FollowAltitude {
    /// Above mean sea level (0).
    Absolute,
    /// Above home (1, ArduCopter's default for a copter): the target's height above its home
    /// is flown above ours.
    #[default]
    Relative,
}

/// `[follow]`: ArduCopter's `FOLL_*` parameters and their defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FollowParams {
    /// `FOLL_ENABLE`: reports are taken and FOLLOW may be entered (off by default, as ArduCopter).
    pub enabled: bool,
    /// `FOLL_SYSID`: the system followed; 0 follows the first other system heard.
    pub system_id: u8,
    /// `FOLL_DIST_MAX` (m): a target farther than this is no target; 0 never too far.
    pub dist_max_m: f64,
    /// `FOLL_OFS_X/Y/Z` (m): north/forward, east/right, down of the target.
    pub offset_m: [f64; 3],
    /// `FOLL_OFS_TYPE`.
    pub offset_frame: OffsetFrame,
    /// `FOLL_YAW_BEHAVE`.
    pub yaw: FollowYaw,
    /// `FOLL_ALT_TYPE`.
    pub altitude: FollowAltitude,
}

impl Default for FollowParams {
    fn default() -> FollowParams {
        FollowParams {
            enabled: false,
            system_id: 0,
            dist_max_m: 100.0,
            offset_m: [0.0; 3],
            offset_frame: OffsetFrame::Ned,
            yaw: FollowYaw::FaceTarget,
            altitude: FollowAltitude::Relative,
        }
    }
}

impl FollowParams {
    pub fn validate(&self) -> Result<(), InvalidParam> {
        within("follow.dist_max_m", self.dist_max_m, 0.0, 1000.0)?;
        for (name, v) in
            ["follow.offset_m[0]", "follow.offset_m[1]", "follow.offset_m[2]"].iter().zip(self.offset_m)
        {
            within(name, v, -100.0, 100.0)?;
        }
        Ok(())
    }
}

/// Codes of the enumerated `FOLL_*` parameters, ArduPilot's numbering.
fn offset_frame(code: f64) -> Option<OffsetFrame> {
    [OffsetFrame::Ned, OffsetFrame::Relative].get(whole(code)?).copied()
}

fn follow_yaw(code: f64) -> Option<FollowYaw> {
    [FollowYaw::None, FollowYaw::FaceTarget, FollowYaw::SameAsTarget, FollowYaw::DirectionOfFlight]
        .get(whole(code)?)
        .copied()
}

fn follow_altitude(code: f64) -> Option<FollowAltitude> {
    [FollowAltitude::Absolute, FollowAltitude::Relative].get(whole(code)?).copied()
}

fn whole(v: f64) -> Option<usize> {
    (v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v <= 255.0).then_some(v as usize)
}

/// The `FOLL_*` parameters, under ArduCopter's names (ground station tools and scripts set them
/// by name). Each may change in flight, as ArduCopter's: the next step flies the new value.
pub const FOLLOW_PARAMS: &[ParamDef<CommanderParams>] = &[
    ParamDef {
        name: "FOLL_ENABLE",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "FOLLOW takes position reports and may be entered: 0 off, 1 on",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(u8::from(p.follow.enabled)),
        set: |p, v| p.follow.enabled = v == 1.0,
    },
    ParamDef {
        name: "FOLL_SYSID",
        unit: "",
        min: 0.0,
        max: 255.0,
        description: "MAVLink system id followed; 0 the first other system heard",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(p.follow.system_id),
        set: |p, v| p.follow.system_id = v as u8,
    },
    ParamDef {
        name: "FOLL_DIST_MAX",
        unit: "m",
        min: 0.0,
        max: 1000.0,
        description: "A target farther than this is not followed (the vehicle holds); 0 no limit",
        while_armed: WhileArmed::Tunable,
        get: |p| p.follow.dist_max_m,
        set: |p, v| p.follow.dist_max_m = v,
    },
    ParamDef {
        name: "FOLL_OFS_X",
        unit: "m",
        min: -100.0,
        max: 100.0,
        description: "Offset from the target, north (FOLL_OFS_TYPE 0) or forward (1)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.follow.offset_m[0],
        set: |p, v| p.follow.offset_m[0] = v,
    },
    ParamDef {
        name: "FOLL_OFS_Y",
        unit: "m",
        min: -100.0,
        max: 100.0,
        description: "Offset from the target, east (FOLL_OFS_TYPE 0) or right (1)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.follow.offset_m[1],
        set: |p, v| p.follow.offset_m[1] = v,
    },
    ParamDef {
        name: "FOLL_OFS_Z",
        unit: "m",
        min: -100.0,
        max: 100.0,
        description: "Offset from the target, down",
        while_armed: WhileArmed::Tunable,
        get: |p| p.follow.offset_m[2],
        set: |p, v| p.follow.offset_m[2] = v,
    },
    ParamDef {
        name: "FOLL_OFS_TYPE",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Offsets are 0 north-east-down, 1 relative to the target's heading",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(u8::from(p.follow.offset_frame == OffsetFrame::Relative)),
        set: |p, v| p.follow.offset_frame = offset_frame(v).unwrap_or_default(),
    },
    ParamDef {
        name: "FOLL_YAW_BEHAVE",
        unit: "",
        min: 0.0,
        max: 3.0,
        description: "Nose 0 held, 1 at the target, 2 as the target's heading, 3 along the flight",
        while_armed: WhileArmed::Tunable,
        get: |p| match p.follow.yaw {
            FollowYaw::None => 0.0,
            FollowYaw::FaceTarget => 1.0,
            FollowYaw::SameAsTarget => 2.0,
            FollowYaw::DirectionOfFlight => 3.0,
        },
        set: |p, v| p.follow.yaw = follow_yaw(v).unwrap_or_default(),
    },
    ParamDef {
        name: "FOLL_ALT_TYPE",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "GLOBAL_POSITION_INT altitude followed: 0 above sea level, 1 above home",
        while_armed: WhileArmed::Tunable,
        get: |p| f64::from(u8::from(p.follow.altitude == FollowAltitude::Relative)),
        set: |p, v| p.follow.altitude = follow_altitude(v).unwrap_or_default(),
    },
];

/// Sets a `FOLL_*` parameter: a switch or an enumeration takes only its whole codes (a value
/// between answers neither), then the range and the whole set's validation as every live
/// parameter (`param_def::apply`). `NotMine` for any other name.
pub fn apply_param(
    params: &mut CommanderParams,
    name: &str,
    value: f64,
) -> Result<ParamChange, ParamRefused> {
    let coded = match name {
        "FOLL_ENABLE" | "FOLL_OFS_TYPE" | "FOLL_ALT_TYPE" => value == 0.0 || value == 1.0,
        "FOLL_YAW_BEHAVE" => follow_yaw(value).is_some(),
        "FOLL_SYSID" => whole(value).is_some(),
        _ => true,
    };
    if !coded {
        return Err(ParamRefused::Invalid {
            name: name.to_owned(),
            reason: format!("takes whole codes only, got {value}"),
        });
    }
    param_def::apply(FOLLOW_PARAMS, params, name, value, CommanderParams::validate)
}

/// The newest report of the system followed, in the commander's NED frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Report {
    /// When it arrived.
    pub time: Time,
    /// NED from the estimator's origin (m), velocity (m/s) and acceleration (m/s²).
    pub position_ned_m: Vector3<f64>,
    pub velocity_ned_m_s: Vector3<f64>,
    pub accel_ned_m_s2: Vector3<f64>,
    /// Heading (rad) if reported, and its rate (rad/s).
    pub heading_rad: Option<f64>,
    pub heading_rate_rad_s: f64,
}

/// A report carried forward to a moment: where the target should be by then.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Predicted {
    pub position_ned_m: Vector3<f64>,
    pub velocity_ned_m_s: Vector3<f64>,
    pub accel_ned_m_s2: Vector3<f64>,
    pub heading_rad: Option<f64>,
    pub heading_rate_rad_s: f64,
}

impl Report {
    /// The target `dt_s` after the report, at constant acceleration and heading rate
    /// (ArduPilot's `update_estimates` projection: p + v·t + a·t²/2, v + a·t, ψ + ψ̇·t).
    pub fn predict(&self, dt_s: f64) -> Predicted {
        let t = dt_s.max(0.0);
        Predicted {
            position_ned_m: self.position_ned_m
                + self.velocity_ned_m_s * t
                + self.accel_ned_m_s2 * (0.5 * t * t),
            velocity_ned_m_s: self.velocity_ned_m_s + self.accel_ned_m_s2 * t,
            accel_ned_m_s2: self.accel_ned_m_s2,
            heading_rad: self.heading_rad.map(|h| wrap_pi(h + self.heading_rate_rad_s * t)),
            heading_rate_rad_s: self.heading_rate_rad_s,
        }
    }
}

/// Why there is no target to fly after.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoTarget {
    /// Nothing heard from the system followed.
    None,
    /// The newest report is older than [`TARGET_TIMEOUT_S`] (s).
    Stale { age_s: f64 },
    /// The target is farther than `FOLL_DIST_MAX` (m).
    TooFar { distance_m: f64 },
}

/// The reports of other systems and the one followed: `AP_Follow`'s state, kept across modes
/// (reports count whatever the mode, so FOLLOW starts on a target already known).
#[derive(Clone, Debug, Default)]
pub struct FollowTracker {
    /// The system adopted while `FOLL_SYSID` is 0.
    adopted: Option<u8>,
    /// The followed system sends FOLLOW_TARGET: its GLOBAL_POSITION_INT is ignored.
    using_follow_target: bool,
    last: Option<Report>,
    /// Reports not taken (not followed, disabled, no heading for a relative offset, no frame).
    pub ignored: u64,
}

impl FollowTracker {
    /// Takes `r` (arrived at `now`) if it comes from the system followed, converting it with
    /// `frame` (the estimator's origin) and `home_down_m` (home's down coordinate, for an
    /// altitude above home). Returns whether it was taken.
    pub fn on_report(
        &mut self,
        now: Time,
        r: &FollowTarget,
        params: &FollowParams,
        frame: Option<&LocalFrame>,
        home_down_m: f64,
    ) -> bool {
        let silent = self.last.is_none_or(|l| now.saturating_since(l.time).as_secs_f64() > SYSID_TIMEOUT_S);
        if silent {
            self.adopted = None;
            self.using_follow_target = false;
        }
        let taken = self.take(now, r, params, frame, home_down_m);
        if !taken {
            self.ignored += 1;
        }
        taken
    }

    fn take(
        &mut self,
        now: Time,
        r: &FollowTarget,
        params: &FollowParams,
        frame: Option<&LocalFrame>,
        home_down_m: f64,
    ) -> bool {
        if !params.enabled {
            return false;
        }
        let wanted = if params.system_id != 0 { Some(params.system_id) } else { self.adopted };
        if wanted.is_some_and(|id| id != r.system_id) {
            return false;
        }
        if r.source == FollowSource::GlobalPositionInt && self.using_follow_target {
            return false;
        }
        if params.offset_frame == OffsetFrame::Relative && r.heading_rad.is_none() {
            return false;
        }
        let Some(frame) = frame else { return false };
        let ned = frame.to_ned(Geodetic { lat_deg: r.lat_deg, lon_deg: r.lon_deg, alt_m: r.alt_amsl_m });
        let down_m = match (params.altitude, r.alt_above_home_m) {
            (FollowAltitude::Relative, Some(above_home)) => home_down_m - above_home,
            _ => ned[2],
        };
        self.last = Some(Report {
            time: now,
            position_ned_m: Vector3::new(ned[0], ned[1], down_m),
            velocity_ned_m_s: Vector3::from(r.velocity_ned_m_s),
            accel_ned_m_s2: Vector3::from(r.acceleration_ned_m_s2),
            heading_rad: r.heading_rad,
            heading_rate_rad_s: r.heading_rate_rad_s,
        });
        if params.system_id == 0 {
            self.adopted = Some(r.system_id);
        }
        if r.source == FollowSource::FollowTarget {
            self.using_follow_target = true;
        }
        true
    }

    /// The target at `now`, or why there is none: disabled, stale, or farther than
    /// `FOLL_DIST_MAX` from `vehicle_ned_m` (measured to the last report, as ArduPilot does).
    pub fn target(
        &self,
        now: Time,
        vehicle_ned_m: &Vector3<f64>,
        params: &FollowParams,
    ) -> Result<Predicted, NoTarget> {
        let Some(last) = self.last.filter(|_| params.enabled) else { return Err(NoTarget::None) };
        let age_s = now.saturating_since(last.time).as_secs_f64();
        if age_s > TARGET_TIMEOUT_S {
            return Err(NoTarget::Stale { age_s });
        }
        let distance_m = (last.position_ned_m - vehicle_ned_m).norm();
        if params.dist_max_m > 0.0 && distance_m > params.dist_max_m {
            return Err(NoTarget::TooFar { distance_m });
        }
        Ok(last.predict(age_s))
    }
}

/// The point flown for a target: target plus the offset, with the offset's own motion when it
/// turns with the target's heading (ω × r for a heading rate ω about the down axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FollowPoint {
    pub position_ned_m: Vector3<f64>,
    pub velocity_ned_m_s: Vector3<f64>,
    pub accel_ned_m_s2: Vector3<f64>,
}

/// `offset_m` (north-east-down, or forward-right-down turned by the target's heading) applied
/// to `target`. A relative offset needs the heading; without one it is read as north-east-down.
pub fn offset_point(target: &Predicted, offset_m: [f64; 3], frame: OffsetFrame) -> FollowPoint {
    let [x, y, z] = offset_m;
    match (frame, target.heading_rad) {
        (OffsetFrame::Relative, Some(h)) => {
            let (s, c) = h.sin_cos();
            let ofs = Vector3::new(x * c - y * s, x * s + y * c, z);
            let w = target.heading_rate_rad_s;
            // d/dt of the turned offset is ω·(−e, n); its second derivative, with ω constant,
            // is −ω²·(n, e).
            let v = Vector3::new(-w * ofs.y, w * ofs.x, 0.0);
            let a = Vector3::new(-w * w * ofs.x, -w * w * ofs.y, 0.0);
            FollowPoint {
                position_ned_m: target.position_ned_m + ofs,
                velocity_ned_m_s: target.velocity_ned_m_s + v,
                accel_ned_m_s2: target.accel_ned_m_s2 + a,
            }
        }
        _ => FollowPoint {
            position_ned_m: target.position_ned_m + Vector3::from(offset_m),
            velocity_ned_m_s: target.velocity_ned_m_s,
            accel_ned_m_s2: target.accel_ned_m_s2,
        },
    }
}

/// The offset that keeps the vehicle where it is relative to the target (all-zero `FOLL_OFS_*`
/// on entry, ArduCopter's `init_offsets_if_required`): north-east-down, or turned into the
/// target's forward-right-down with a relative offset frame.
pub fn offset_from_here(target: &Predicted, vehicle_ned_m: &Vector3<f64>, frame: OffsetFrame) -> [f64; 3] {
    let d = vehicle_ned_m - target.position_ned_m;
    match (frame, target.heading_rad) {
        (OffsetFrame::Relative, Some(h)) => {
            let (s, c) = h.sin_cos();
            [d.x * c + d.y * s, -d.x * s + d.y * c, d.z]
        }
        _ => [d.x, d.y, d.z],
    }
}

/// The heading `FOLL_YAW_BEHAVE` asks for (rad) and its rate (rad/s); `None` keeps the held one.
pub fn follow_heading(yaw: FollowYaw, target: &Predicted, point: &FollowPoint) -> Option<(f64, f64)> {
    match yaw {
        FollowYaw::None => None,
        FollowYaw::FaceTarget => {
            let d = target.position_ned_m - point.position_ned_m;
            (d.x.hypot(d.y) > YAW_MIN_DISTANCE_M).then(|| (d.y.atan2(d.x), 0.0))
        }
        FollowYaw::SameAsTarget => target.heading_rad.map(|h| (h, target.heading_rate_rad_s)),
        FollowYaw::DirectionOfFlight => {
            let v = point.velocity_ned_m_s;
            (v.x.hypot(v.y) > YAW_MIN_SPEED_M_S).then(|| (v.y.atan2(v.x), 0.0))
        }
    }
}

/// What FOLLOW latched for this stay in the mode.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct FollowLatch {
    /// The offset taken on entry when every `FOLL_OFS_*` is zero.
    pub auto_offset_m: Option<[f64; 3]>,
    /// Stopping, then holding, while there is no target (or it may not be flown to).
    pub stop: Option<Brake>,
    /// The reason last announced for holding, so each is said once.
    pub said: Option<&'static str>,
}

fn wrap_pi(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

impl Commander {
    /// A report from another system (`Command::FollowTarget`): kept if it is the one followed.
    pub(super) fn on_follow_target(&mut self, now: Time, r: &FollowTarget) {
        let frame = self.home.frame();
        let home_down_m = self.home.ned().map_or(0.0, |h| h.z);
        self.follow.on_report(now, r, &self.params.follow, frame.as_ref(), home_down_m);
    }

    /// FOLLOW's setpoint (flying).
    pub(super) fn follow(&mut self, now: Time, dt_s: f64, nav: &NavState) -> SetpointTarget {
        let here = Vector3::from(nav.position_ned_m);
        let params = self.params.follow.clone();
        let target = match self.follow.target(now, &here, &params) {
            Ok(t) => t,
            Err(NoTarget::None) => return self.follow_hold(dt_s, nav, "FOLLOW: no target, holding"),
            Err(NoTarget::Stale { .. }) => {
                return self.follow_hold(dt_s, nav, "FOLLOW: target lost, holding");
            }
            Err(NoTarget::TooFar { .. }) => {
                return self.follow_hold(dt_s, nav, "FOLLOW: target beyond FOLL_DIST_MAX, holding");
            }
        };
        let offset = if params.offset_m == [0.0; 3] {
            *self
                .latched
                .follow
                .auto_offset_m
                .get_or_insert_with(|| offset_from_here(&target, &here, params.offset_frame))
        } else {
            params.offset_m
        };
        let point = offset_point(&target, offset, params.offset_frame);
        if let Some(why) = self.guided_position_refused(&point.position_ned_m) {
            tracing::debug!(%why, "FOLLOW point refused");
            return self.follow_hold(
                dt_s,
                nav,
                "FOLLOW: target point not allowed (fence or limits), holding",
            );
        }
        self.latched.follow.stop = None;
        self.latched.follow.said = None;
        let held = *self.latched.hold.yaw_rad.get_or_insert(heading(nav));
        let (yaw, yaw_rate) = follow_heading(params.yaw, &target, &point).unwrap_or((held, 0.0));
        self.latched.hold.yaw_rad = Some(yaw);
        let p = point.position_ned_m;
        let v = point.velocity_ned_m_s;
        SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: [Some(p.x), Some(p.y), Some(p.z)],
            velocity_ned_m_s: [Some(v.x), Some(v.y), Some(v.z)],
            acceleration_ned_m_s2: point.accel_ned_m_s2.into(),
            yaw_rad: Some(yaw),
            yaw_rate_rad_s: yaw_rate,
            max_horizontal_speed_m_s: Some(self.params.guided_speed_m_s),
            desired_speed_m_s: None,
        })
    }

    /// No target to fly after: stop at the waypoint acceleration (`WPNAV_ACCEL`, the circle's
    /// `accel_m_s2`) and hold where the vehicle stopped, saying `why` once.
    fn follow_hold(&mut self, dt_s: f64, nav: &NavState, why: &'static str) -> SetpointTarget {
        if self.latched.follow.said != Some(why) {
            tracing::info!("{why}");
            self.announce(why.to_owned());
            self.latched.follow.said = Some(why);
        }
        let yaw = *self.latched.hold.yaw_rad.get_or_insert(heading(nav));
        let v = nav.velocity_ned_m_s;
        let p = nav.position_ned_m;
        let decel = self.params.circle.accel_m_s2;
        let stop = self.latched.follow.stop.get_or_insert_with(|| Brake::new([v[0], v[1]], p[2]));
        SetpointTarget::Trajectory(stop.step(dt_s, decel, p).setpoint(yaw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    const HOME: Geodetic = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };

    fn at(s: f64) -> Time {
        Time::from_secs_f64(s)
    }

    /// A report `north_m`, `east_m` from HOME, `alt_above_home_m` up, from `system_id`.
    fn report(system_id: u8, source: FollowSource, north_m: f64, east_m: f64, up_m: f64) -> FollowTarget {
        let g = LocalFrame::new(HOME).to_geodetic([north_m, east_m, -up_m]);
        FollowTarget {
            system_id,
            source,
            lat_deg: g.lat_deg,
            lon_deg: g.lon_deg,
            alt_amsl_m: g.alt_m,
            alt_above_home_m: (source == FollowSource::GlobalPositionInt).then_some(up_m),
            velocity_ned_m_s: [3.0, 0.0, 0.0],
            acceleration_ned_m_s2: [0.0; 3],
            heading_rad: Some(0.0),
            heading_rate_rad_s: 0.0,
        }
    }

    fn enabled() -> FollowParams {
        FollowParams { enabled: true, ..FollowParams::default() }
    }

    fn predicted(heading_rad: Option<f64>, heading_rate_rad_s: f64) -> Predicted {
        Predicted {
            position_ned_m: Vector3::new(10.0, 20.0, -5.0),
            velocity_ned_m_s: Vector3::new(3.0, 0.0, 0.0),
            accel_ned_m_s2: Vector3::zeros(),
            heading_rad,
            heading_rate_rad_s,
        }
    }

    #[test]
    fn a_ned_offset_is_added_as_it_is_and_a_relative_one_turns_with_the_heading() {
        let t = predicted(Some(FRAC_PI_2), 0.0);
        let ned = offset_point(&t, [-5.0, 2.0, -1.0], OffsetFrame::Ned);
        assert_eq!(ned.position_ned_m, Vector3::new(5.0, 22.0, -6.0));
        // Heading east: 5 m behind is 5 m west, 2 m to the right is 2 m south.
        let rel = offset_point(&t, [-5.0, 2.0, -1.0], OffsetFrame::Relative);
        assert!((rel.position_ned_m - Vector3::new(8.0, 15.0, -6.0)).norm() < 1e-12, "{rel:?}");
        // A relative offset without a heading is read north-east-down.
        assert_eq!(offset_point(&predicted(None, 0.0), [-5.0, 2.0, -1.0], OffsetFrame::Relative), ned);
    }

    #[test]
    fn a_turning_targets_relative_offset_moves_as_omega_cross_r() {
        // Reference: finite differences of the offset point over a heading that turns at ω.
        let w = 0.3;
        let offset = [-6.0, 1.5, 0.0];
        let point = |h: f64| offset_point(&predicted(Some(h), w), offset, OffsetFrame::Relative);
        let (h, dt) = (0.7, 1e-5);
        // The fixture's target stands still in position: the offset's own motion, over the
        // heading turned in ±dt, plus the target's velocity is the point's velocity.
        let p0 = point(h - w * dt).position_ned_m;
        let p2 = point(h + w * dt).position_ned_m;
        let p1 = point(h);
        let numeric_v = (p2 - p0) / (2.0 * dt) + Vector3::new(3.0, 0.0, 0.0);
        assert!((numeric_v - p1.velocity_ned_m_s).norm() < 1e-6, "{numeric_v} vs {}", p1.velocity_ned_m_s);
        let centripetal = p1.accel_ned_m_s2.xy().norm();
        assert!((centripetal - w * w * (6.0f64).hypot(1.5)).abs() < 1e-12);
    }

    #[test]
    fn the_offset_taken_on_entry_puts_the_point_where_the_vehicle_is() {
        let vehicle = Vector3::new(4.0, 25.0, -9.0);
        for (frame, h) in [(OffsetFrame::Ned, None), (OffsetFrame::Relative, Some(2.2))] {
            let t = predicted(h, 0.0);
            let ofs = offset_from_here(&t, &vehicle, frame);
            let p = offset_point(&t, ofs, frame).position_ned_m;
            assert!((p - vehicle).norm() < 1e-12, "{frame:?}: {p}");
        }
    }

    #[test]
    fn a_report_older_than_three_seconds_is_no_target() {
        let frame = LocalFrame::new(HOME);
        let mut f = FollowTracker::default();
        assert!(f.on_report(
            at(1.0),
            &report(7, FollowSource::FollowTarget, 10.0, 0.0, 5.0),
            &enabled(),
            Some(&frame),
            0.0
        ));
        let here = Vector3::zeros();
        let t = f.target(at(3.9), &here, &enabled()).expect("fresh at 2.9 s");
        // Predicted 2.9 s on at 3 m/s north.
        assert!((t.position_ned_m - Vector3::new(10.0 + 3.0 * 2.9, 0.0, -5.0)).norm() < 1e-3, "{t:?}");
        assert!(matches!(f.target(at(4.1), &here, &enabled()), Err(NoTarget::Stale { .. })));
    }

    #[test]
    fn a_target_beyond_foll_dist_max_is_no_target_and_zero_means_no_limit() {
        let frame = LocalFrame::new(HOME);
        let mut f = FollowTracker::default();
        let far = report(7, FollowSource::FollowTarget, 150.0, 0.0, 5.0);
        assert!(f.on_report(at(0.0), &far, &enabled(), Some(&frame), 0.0));
        let here = Vector3::zeros();
        assert!(
            matches!(f.target(at(0.0), &here, &enabled()), Err(NoTarget::TooFar { distance_m }) if (distance_m - 150.08).abs() < 0.1)
        );
        let unlimited = FollowParams { dist_max_m: 0.0, ..enabled() };
        assert!(f.target(at(0.0), &here, &unlimited).is_ok());
        let nearer = Vector3::new(60.0, 0.0, 0.0);
        assert!(f.target(at(0.0), &nearer, &enabled()).is_ok(), "within 100 m of the vehicle");
    }

    #[test]
    fn sysid_zero_adopts_the_first_system_heard_until_it_is_silent_for_ten_seconds() {
        let frame = LocalFrame::new(HOME);
        let mut f = FollowTracker::default();
        let p = enabled();
        let gpi = |id| report(id, FollowSource::GlobalPositionInt, 1.0, 1.0, 5.0);
        assert!(!f.on_report(at(0.0), &gpi(7), &FollowParams::default(), Some(&frame), 0.0), "FOLL_ENABLE 0");
        assert!(f.on_report(at(0.0), &gpi(7), &p, Some(&frame), 0.0));
        assert!(!f.on_report(at(1.0), &gpi(9), &p, Some(&frame), 0.0), "7 adopted");
        assert!(f.on_report(at(2.0), &gpi(7), &p, Some(&frame), 0.0));
        assert!(f.on_report(at(12.5), &gpi(9), &p, Some(&frame), 0.0), "7 silent for 10.5 s: 9 adopted");
        let fixed = FollowParams { system_id: 7, ..enabled() };
        assert!(!f.on_report(at(13.0), &gpi(9), &fixed, Some(&frame), 0.0), "FOLL_SYSID 7");
        assert_eq!(f.ignored, 3);
    }

    #[test]
    fn follow_target_wins_over_global_position_int_and_relative_offsets_need_a_heading() {
        let frame = LocalFrame::new(HOME);
        let mut f = FollowTracker::default();
        let p = enabled();
        assert!(f.on_report(
            at(0.0),
            &report(7, FollowSource::FollowTarget, 1.0, 1.0, 5.0),
            &p,
            Some(&frame),
            0.0
        ));
        assert!(!f.on_report(
            at(0.5),
            &report(7, FollowSource::GlobalPositionInt, 1.0, 1.0, 5.0),
            &p,
            Some(&frame),
            0.0
        ));
        let relative = FollowParams { offset_frame: OffsetFrame::Relative, ..enabled() };
        let headless =
            FollowTarget { heading_rad: None, ..report(7, FollowSource::FollowTarget, 1.0, 1.0, 5.0) };
        assert!(!f.on_report(at(1.0), &headless, &relative, Some(&frame), 0.0));
        assert!(f.on_report(at(1.0), &headless, &p, Some(&frame), 0.0));
    }

    #[test]
    fn foll_alt_type_chooses_the_height_above_home_or_above_sea_level() {
        let frame = LocalFrame::new(HOME);
        let here = Vector3::zeros();
        // The target says 5 m above its home, and its AMSL altitude is 30 m (10 m above ours).
        let r =
            FollowTarget { alt_amsl_m: 30.0, ..report(7, FollowSource::GlobalPositionInt, 0.0, 0.0, 5.0) };
        for (altitude, home_down, down) in
            [(FollowAltitude::Relative, -2.0, -7.0), (FollowAltitude::Absolute, -2.0, -10.0)]
        {
            let p = FollowParams { altitude, ..enabled() };
            let mut f = FollowTracker::default();
            assert!(f.on_report(at(0.0), &r, &p, Some(&frame), home_down));
            let t = f.target(at(0.0), &here, &p).expect("target");
            assert!((t.position_ned_m.z - down).abs() < 1e-6, "{altitude:?}: {}", t.position_ned_m.z);
        }
    }

    #[test]
    fn each_yaw_behaviour_points_as_arducopter_says() {
        let t = predicted(Some(1.0), 0.2);
        let point = offset_point(&t, [-10.0, 0.0, 0.0], OffsetFrame::Ned);
        assert_eq!(follow_heading(FollowYaw::None, &t, &point), None);
        let (face, _) = follow_heading(FollowYaw::FaceTarget, &t, &point).expect("10 m away");
        assert!(face.abs() < 1e-12, "the target is due north of the point");
        assert_eq!(follow_heading(FollowYaw::SameAsTarget, &t, &point), Some((1.0, 0.2)));
        assert_eq!(follow_heading(FollowYaw::DirectionOfFlight, &t, &point), Some((0.0, 0.0)));
        let slow = Predicted { velocity_ned_m_s: Vector3::new(0.5, 0.5, 0.0), ..t };
        let on_top = offset_point(&slow, [0.5, 0.0, 0.0], OffsetFrame::Ned);
        assert_eq!(follow_heading(FollowYaw::FaceTarget, &slow, &on_top), None, "within 1 m");
        assert_eq!(follow_heading(FollowYaw::DirectionOfFlight, &slow, &on_top), None, "below 1 m/s");
    }

    #[test]
    fn foll_parameters_take_arducopter_codes_and_refuse_others() {
        let mut p = CommanderParams::default();
        assert_eq!(apply_param(&mut p, "FOLL_ENABLE", 1.0), Ok(ParamChange::Applied));
        assert!(p.follow.enabled);
        assert_eq!(apply_param(&mut p, "FOLL_YAW_BEHAVE", 3.0), Ok(ParamChange::Applied));
        assert_eq!(p.follow.yaw, FollowYaw::DirectionOfFlight);
        assert_eq!(apply_param(&mut p, "FOLL_OFS_TYPE", 1.0), Ok(ParamChange::Applied));
        assert_eq!(p.follow.offset_frame, OffsetFrame::Relative);
        assert_eq!(apply_param(&mut p, "FOLL_SYSID", 42.0), Ok(ParamChange::Applied));
        assert_eq!(p.follow.system_id, 42);
        let before = p.clone();
        for (name, bad) in
            [("FOLL_ENABLE", 0.5), ("FOLL_YAW_BEHAVE", 4.0), ("FOLL_SYSID", 2.5), ("FOLL_OFS_X", 101.0)]
        {
            assert!(apply_param(&mut p, name, bad).is_err(), "{name} = {bad}");
        }
        assert_eq!(p, before);
        assert_eq!(apply_param(&mut p, "RTL_ALT_M", 5.0), Ok(ParamChange::NotMine));
        param_def::declare(FOLLOW_PARAMS, &CommanderParams::default(), "commander", true, Time::ZERO)
            .check()
            .expect("defaults in range, names unique and short");
    }

    proptest! {
        /// The prediction is the constant-acceleration motion: predicting in two steps is
        /// predicting once, and the velocity is the position's time derivative.
        #[test]
        fn the_prediction_is_constant_acceleration_motion(
            p in prop::array::uniform3(-500.0f64..500.0),
            v in prop::array::uniform3(-20.0f64..20.0),
            a in prop::array::uniform3(-5.0f64..5.0),
            h in -PI..PI,
            w in -1.0f64..1.0,
            t1 in 0.0f64..1.5,
            t2 in 0.0f64..1.5,
        ) {
            let r = Report {
                time: Time::ZERO,
                position_ned_m: Vector3::from(p),
                velocity_ned_m_s: Vector3::from(v),
                accel_ned_m_s2: Vector3::from(a),
                heading_rad: Some(h),
                heading_rate_rad_s: w,
            };
            let once = r.predict(t1 + t2);
            let mid = r.predict(t1);
            let again = Report {
                time: Time::ZERO,
                position_ned_m: mid.position_ned_m,
                velocity_ned_m_s: mid.velocity_ned_m_s,
                accel_ned_m_s2: mid.accel_ned_m_s2,
                heading_rad: mid.heading_rad,
                heading_rate_rad_s: mid.heading_rate_rad_s,
            }
            .predict(t2);
            prop_assert!((once.position_ned_m - again.position_ned_m).norm() < 1e-9);
            prop_assert!((once.velocity_ned_m_s - again.velocity_ned_m_s).norm() < 1e-9);
            prop_assert!(wrap_pi(once.heading_rad.unwrap() - again.heading_rad.unwrap()).abs() < 1e-9);
            let dt = 1e-4;
            let ahead = r.predict(t1 + dt).position_ned_m;
            let behind = r.predict(t1 + 2.0 * dt).position_ned_m;
            let numeric = (behind - ahead) / dt;
            prop_assert!((numeric - r.predict(t1 + 1.5 * dt).velocity_ned_m_s).norm() < 1e-6);
            // Never backwards in time: a report from the future is the report.
            prop_assert_eq!(r.predict(-1.0).position_ned_m, r.position_ned_m);
        }
    }
}
