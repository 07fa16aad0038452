//! A waypoint mission, as uploaded by a ground station or loaded from a QGroundControl `.plan`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// Most items a flight mission may hold, however it arrives: MAVLink upload (which refuses a
/// larger MISSION_COUNT with NO_SPACE), a `.plan` file, or the graph. 1000 is ArduPilot's
/// practical ceiling on a board with little storage and far beyond any survey a multirotor
/// battery can fly.
pub const MAX_MISSION_ITEMS: usize = 1000;

/// What a mission item's altitude is measured from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum AltitudeFrame {
    /// Above the home position (MAVLink `MAV_FRAME_GLOBAL_RELATIVE_ALT`).
    RelativeHome,
    /// Above mean sea level (MAVLink `MAV_FRAME_GLOBAL`).
    Amsl,
}

/// A point in WGS-84 with its altitude reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct MissionPoint {
    /// Latitude (degrees).
    pub lat_deg: f64,
    /// Longitude (degrees).
    pub lon_deg: f64,
    /// Altitude (m) in `frame`.
    pub alt_m: f64,
    pub frame: AltitudeFrame,
}

/// One step of a mission. As in ArduPilot's `AP_Mission`, items are *navigation* items (flown
/// one at a time: the current item) and *do/condition* items, which run in order while the
/// navigation item after them is flown, a condition holding back the do items after it until
/// it is met; a jump is neither and only redirects the walk (`MissionItem::is_nav`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MissionItem {
    /// Climb vertically to the item's altitude (its lat/lon are ignored when not finite).
    Takeoff { point: MissionPoint },
    /// Fly to the point; reached within `acceptance_radius_m` (3D); then wait `hold_s`.
    Waypoint { point: MissionPoint, acceptance_radius_m: f64, hold_s: f64 },
    /// Fly to the point along a smooth curve through the waypoints before and after it (a
    /// cubic Hermite segment, as ArduCopter's spline legs), reached at the point; then wait
    /// `hold_s`.
    SplineWaypoint { point: MissionPoint, hold_s: f64 },
    /// Fly to `point` (where the vehicle is when `None`) and wait there `duration_s` (s).
    LoiterTime {
        duration_s: f64,
        #[serde(default)]
        point: Option<MissionPoint>,
    },
    /// Fly to `point` (where the vehicle is when `None`) and circle it `turns` times at
    /// `radius_m` (m; clockwise seen from above, counter-clockwise when negative).
    LoiterTurns { point: Option<MissionPoint>, turns: f64, radius_m: f64 },
    /// Fly to `point` (where the vehicle is when `None`) and hold there until the mission is
    /// moved on by the ground station.
    LoiterUnlimited { point: Option<MissionPoint> },
    /// Hold where the vehicle is for `duration_s` (s) (MAV_CMD_NAV_DELAY).
    Delay { duration_s: f64 },
    /// Change the cruise speed (m/s) for the following legs.
    ChangeSpeed { speed_m_s: f64 },
    /// Fly to the point's horizontal position and land there.
    Land { point: MissionPoint },
    /// Return to launch and land.
    ReturnToLaunch,
    /// Go on at item `target` (index in this list) `repeat` more times, for ever when -1
    /// (MAV_CMD_DO_JUMP; ArduPilot's count: the jump is taken while it has been taken fewer
    /// than `repeat` times, counts restarting with each run of the mission).
    Jump { target: u32, repeat: i32 },
    /// Hold back the do items after this one for `duration_s` (s).
    ConditionDelay { duration_s: f64 },
    /// Hold back the do items after this one until the vehicle is within `distance_m` (m) of
    /// the navigation item being flown.
    ConditionDistance { distance_m: f64 },
    /// Turn the nose to `angle_deg` (degrees from north, or from the current heading when
    /// `relative`, `clockwise` giving the sense) at `rate_deg_s` (deg/s; 0: the vehicle's
    /// yaw rate); holds back the do items after it until the nose is there.
    ConditionYaw { angle_deg: f64, rate_deg_s: f64, clockwise: bool, relative: bool },
    /// Point the nose at this place from now on; `None` stops (DO_SET_ROI_NONE, or a
    /// DO_SET_ROI at 0, 0).
    RegionOfInterest { point: Option<MissionPoint> },
    /// Where a landing sequence starts (MAV_CMD_DO_LAND_START): a jump to the landing
    /// sequence goes on from the one nearest the vehicle (measured to `point`; the first one
    /// when none has a point), as ArduCopter's AUTO RTL.
    LandStart { point: Option<MissionPoint> },
    /// A camera item (`CameraAction`).
    Camera { action: CameraAction },
    /// An item for an output this vehicle does not have (a servo, a relay, a gimbal): accepted
    /// and reported when it runs, as ArduCopter does without the output; nothing is driven.
    NoOutput { command: u16 },
}

/// What a camera item asks for.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CameraAction {
    /// A still every `distance_m` (m) flown; 0 stops (DO_SET_CAM_TRIGG_DIST).
    TriggerDistance { distance_m: f64 },
    /// `count` stills (0: until stopped) every `interval_s` (s) (IMAGE_START_CAPTURE).
    StartCapture { interval_s: f64, count: u32 },
    /// Stop taking stills (IMAGE_STOP_CAPTURE).
    StopCapture,
    /// One still now (DO_DIGICAM_CONTROL with its shoot field set).
    Shoot,
}

impl MissionItem {
    /// A navigation item: the one being flown (`MissionProgress::current`). ArduPilot's
    /// `is_nav_cmd` (command ids up to MAV_CMD_NAV_LAST).
    pub fn is_nav(&self) -> bool {
        matches!(
            self,
            MissionItem::Takeoff { .. }
                | MissionItem::Waypoint { .. }
                | MissionItem::SplineWaypoint { .. }
                | MissionItem::LoiterTime { .. }
                | MissionItem::LoiterTurns { .. }
                | MissionItem::LoiterUnlimited { .. }
                | MissionItem::Delay { .. }
                | MissionItem::Land { .. }
                | MissionItem::ReturnToLaunch
        )
    }

    /// The point flown to, if the item has one.
    pub fn point(&self) -> Option<MissionPoint> {
        match *self {
            MissionItem::Takeoff { point }
            | MissionItem::Waypoint { point, .. }
            | MissionItem::SplineWaypoint { point, .. }
            | MissionItem::Land { point } => Some(point),
            MissionItem::LoiterTime { point, .. }
            | MissionItem::LoiterTurns { point, .. }
            | MissionItem::LoiterUnlimited { point } => point,
            _ => None,
        }
    }
}

/// A whole mission. A new one replaces the old: on the ground its run starts at item 0; one
/// uploaded while the old is flown in AUTO is flown from the same item index.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Mission {
    pub time: Time,
    pub items: Vec<MissionItem>,
    /// Cruise speed between waypoints (m/s) unless an item changes it.
    pub cruise_speed_m_s: f64,
}
crate::impl_message!(Mission);

impl Mission {
    /// What can be checked without knowing where the vehicle is: the item count and that every
    /// number is one and in range. The one check for missions however they arrive: the link
    /// runs it before it acknowledges an upload (so the commander never refuses what was
    /// ACKed), the commander on a `.plan` file and on every mission it is given. The text names
    /// the item (counted from 1, home not being one) and what is wrong.
    pub fn check_fields(&self) -> Result<(), String> {
        let n = self.items.len();
        if n == 0 {
            return Err("mission refused: no items".into());
        }
        if n > MAX_MISSION_ITEMS {
            return Err(format!("mission refused: {n} items, at most {MAX_MISSION_ITEMS}"));
        }
        if !(self.cruise_speed_m_s.is_finite() && self.cruise_speed_m_s > 0.0) {
            return Err(format!("mission refused: cruise speed {} m/s", self.cruise_speed_m_s));
        }
        for (i, item) in self.items.iter().enumerate() {
            let bad = |what: &str| Err(format!("mission item {}: {what}", i + 1));
            let finite_point = |p: &MissionPoint| p.lat_deg.is_finite() && p.lon_deg.is_finite();
            match *item {
                MissionItem::Takeoff { point } if !point.alt_m.is_finite() => {
                    return bad("altitude is not a number");
                }
                MissionItem::Waypoint { point, .. } | MissionItem::Land { point }
                    if !finite_point(&point) =>
                {
                    return bad("latitude/longitude is not a number");
                }
                MissionItem::Waypoint { point, .. } if !point.alt_m.is_finite() => {
                    return bad("altitude is not a number");
                }
                MissionItem::Waypoint { acceptance_radius_m, hold_s, .. }
                    if !(acceptance_radius_m.is_finite()
                        && acceptance_radius_m > 0.0
                        && hold_s.is_finite()
                        && hold_s >= 0.0) =>
                {
                    return bad("acceptance radius or hold time out of range");
                }
                MissionItem::LoiterTime { duration_s, .. }
                    if !(duration_s.is_finite() && duration_s >= 0.0) =>
                {
                    return bad("loiter time out of range");
                }
                MissionItem::ChangeSpeed { speed_m_s } if !(speed_m_s.is_finite() && speed_m_s > 0.0) => {
                    return bad("speed out of range");
                }
                MissionItem::SplineWaypoint { point, hold_s }
                    if !(finite_point(&point)
                        && point.alt_m.is_finite()
                        && hold_s.is_finite()
                        && hold_s >= 0.0) =>
                {
                    return bad("spline waypoint position or hold time out of range");
                }
                MissionItem::LoiterTurns { turns, radius_m, .. }
                    if !(turns.is_finite() && turns > 0.0 && radius_m.is_finite()) =>
                {
                    return bad("loiter turns or radius out of range");
                }
                MissionItem::Delay { duration_s } | MissionItem::ConditionDelay { duration_s }
                    if !(duration_s.is_finite() && duration_s >= 0.0) =>
                {
                    return bad("delay out of range");
                }
                MissionItem::ConditionDistance { distance_m }
                    if !(distance_m.is_finite() && distance_m >= 0.0) =>
                {
                    return bad("distance out of range");
                }
                MissionItem::ConditionYaw { angle_deg, rate_deg_s, .. }
                    if !(angle_deg.is_finite() && rate_deg_s.is_finite() && rate_deg_s >= 0.0) =>
                {
                    return bad("yaw angle or rate out of range");
                }
                MissionItem::Jump { target, repeat } if target as usize >= n || repeat < -1 => {
                    return bad("jump target past the last item or repeat count below -1");
                }
                MissionItem::Jump { target, .. } if target as usize == i => {
                    return bad("jump to itself");
                }
                MissionItem::Camera { action: CameraAction::TriggerDistance { distance_m } }
                    if !(distance_m.is_finite() && distance_m >= 0.0) =>
                {
                    return bad("trigger distance out of range");
                }
                MissionItem::Camera { action: CameraAction::StartCapture { interval_s, .. } }
                    if !(interval_s.is_finite() && interval_s >= 0.0) =>
                {
                    return bad("capture interval out of range");
                }
                _ => {}
            }
            let point = match item {
                MissionItem::RegionOfInterest { point } => *point,
                other => other.point(),
            };
            if let Some(point) = point {
                if matches!(
                    item,
                    MissionItem::LoiterTime { .. }
                        | MissionItem::LoiterTurns { .. }
                        | MissionItem::LoiterUnlimited { .. }
                        | MissionItem::RegionOfInterest { .. }
                ) && !(finite_point(&point) && point.alt_m.is_finite())
                {
                    return bad("latitude/longitude/altitude is not a number");
                }
                if finite_point(&point) && !(point.lat_deg.abs() <= 90.0 && point.lon_deg.abs() <= 180.0) {
                    return bad("latitude/longitude out of range");
                }
            }
        }
        Ok(())
    }
}
