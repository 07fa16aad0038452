//! The geofence: ArduCopter's fences (`FENCE_TYPE` bits) around home — the altitude ceiling
//! (`max_altitude_m`, `FENCE_ALT_MAX`), the floor (`min_altitude_m`, `FENCE_ALT_MIN`), the
//! circle (`max_radius_m`, `FENCE_RADIUS`) — and the polygons: the configured inclusion polygon
//! and the zones a ground station uploaded (`fence_zones`), all placed in the estimator's NED
//! frame once it has an origin. The switch is `FENCE_ENABLE` at boot and
//! MAV_CMD_DO_FENCE_ENABLE after. A breach while armed is the `GeofenceBreach` failsafe; outside
//! it the vehicle does not arm, and `feasibility` refuses targets beyond it.
//!
//! As ArduCopter's `AC_Fence`: each fence newly breached counts one breach (FENCE_STATUS); the
//! floor counts only once the vehicle has climbed above it this flight and never while landing;
//! a breach more than [`GIVE_UP_M`] beyond the ceiling or the circle lands instead of returning.
//! A vehicle that stays outside is breached anew, and its action taken again, once it goes
//! [`BACKUP_M`] further above the ceiling, below the floor or beyond the circle than where the
//! last breach was counted (a polygon has no such backup fence); a pilot who changes mode while
//! breached has [`MANUAL_RECOVERY`] in which no new breach is counted.
//! `FENCE_TOTAL` is the count of stored fence items as ArduCopter derives it ([`fence_total`]).

use kestrel_proto::Time;
use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{
    FENCE_ALT_MAX, FENCE_ALT_MIN, FENCE_CIRCLE, FENCE_POLYGON, FencePlan, FenceStatus, FenceZone, NavState,
};
use nalgebra::Vector3;

use super::fence_zones::{ZoneNed, breached, inside_polygon};
use super::params::GeofenceParams;

/// Beyond this distance outside the ceiling or the circle (m), ArduCopter's breach action lands
/// rather than returning (`AC_FENCE_GIVE_UP_DISTANCE`).
pub(crate) const GIVE_UP_M: f64 = 100.0;

/// How much further (m) above the ceiling, below the floor or beyond the circle a vehicle still
/// outside must go for a new breach (`AC_FENCE_ALT_MAX_BACKUP_DISTANCE`,
/// `AC_FENCE_ALT_MIN_BACKUP_DISTANCE`, `AC_FENCE_CIRCLE_RADIUS_BACKUP_DISTANCE`: 20 m for a
/// copter). Held by `tests::fence::a_vehicle_staying_outside_is_breached_again_20_m_further`.
pub(crate) const BACKUP_M: f64 = 20.0;

/// After a mode change asked for while breached, no new breach is counted for this long
/// (`AC_FENCE_MANUAL_RECOVERY_TIME_MIN`, 10 s): the pilot flies back in without the breach
/// action taking the vehicle from them again. Held by
/// `tests::fence::a_pilot_taking_control_in_breach_has_ten_seconds`.
pub(crate) const MANUAL_RECOVERY: std::time::Duration = std::time::Duration::from_secs(10);

/// ArduCopter's `FENCE_TOTAL` for an uploaded fence (`AC_PolyFence_loader::write_fence`): every
/// polygon vertex and every circle counted, plus 2 (the old FENCE_POINT protocol's return and
/// closing points) when that makes at least 3; 0 otherwise. A return point is not counted.
pub(crate) fn fence_total(plan: Option<&FencePlan>) -> u16 {
    let items: usize = plan.map_or(0, |p| {
        p.zones
            .iter()
            .map(|z| match z {
                FenceZone::Polygon { vertices_deg, .. } => vertices_deg.len(),
                FenceZone::Circle { .. } => 1,
            })
            .sum()
    });
    if items >= 3 { u16::try_from(items + 2).unwrap_or(u16::MAX) } else { 0 }
}

/// One check's outcome: the fences breached now and those newly breached (the action's cue).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct FenceCheck {
    pub breaches: u8,
    pub new: u8,
}

/// Whether the fence is on, its shapes in the local frame, and its breaches.
#[derive(Debug)]
pub(crate) struct Geofence {
    /// A breach triggers its failsafe (MAV_CMD_DO_FENCE_ENABLE switches it).
    enabled: bool,
    /// The configured inclusion polygon's vertices, north/east (m) from the estimator's origin;
    /// empty before the origin is known, or for no polygon.
    polygon_ned: Vec<[f64; 2]>,
    /// The uploaded fence as it came (WGS-84), kept to place again when the origin is known.
    plan: Option<FencePlan>,
    /// The uploaded zones in the local frame; empty before the origin is known.
    zones: Vec<ZoneNed>,
    frame: Option<LocalFrame>,
    /// The vehicle has been above the floor this flight (ArduCopter's auto-enabled floor).
    floor_reached: bool,
    /// Heights above home (m) and distance from home (m) past which a vehicle still outside
    /// the ceiling, the floor and the circle is breached anew; `None` while inside.
    backup: Backup,
    /// When a mode change was asked for while breached ([`MANUAL_RECOVERY`]).
    manual_recovery_since: Option<Time>,
    status: FenceStatus,
}

/// The backup fences of a vehicle still outside ([`BACKUP_M`] past the last breach).
#[derive(Clone, Copy, Debug, Default)]
struct Backup {
    /// Height above home (m).
    ceiling_m: Option<f64>,
    /// Height above home (m).
    floor_m: Option<f64>,
    /// Distance from home (m).
    radius_m: Option<f64>,
}

impl Default for Geofence {
    fn default() -> Geofence {
        Geofence {
            enabled: true,
            polygon_ned: Vec::new(),
            plan: None,
            zones: Vec::new(),
            frame: None,
            floor_reached: false,
            backup: Backup::default(),
            manual_recovery_since: None,
            status: FenceStatus::default(),
        }
    }
}

impl Geofence {
    /// The fence with its boot switch (`FENCE_ENABLE`).
    pub fn new(enabled: bool) -> Geofence {
        Geofence { enabled, ..Geofence::default() }
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// MAV_CMD_DO_FENCE_ENABLE. Accepted in flight, as ArduPilot does: switching it off clears
    /// a breach's failsafe cause but not the RTL it started; switching it on while outside
    /// breaches at once.
    pub fn set_enabled(&mut self, enabled: bool) {
        if enabled != self.enabled {
            tracing::info!(enabled, "geofence");
        }
        self.enabled = enabled;
    }

    /// Places the configured polygon (`[lat_deg, lon_deg]` vertices) and any uploaded zones in
    /// `frame`, at the origin's altitude.
    pub fn place(&mut self, frame: &LocalFrame, polygon_deg: &[[f64; 2]]) {
        let alt_m = frame.home().alt_m;
        self.polygon_ned = polygon_deg
            .iter()
            .map(|&[lat_deg, lon_deg]| {
                let ned = frame.to_ned(kestrel_proto::geo::Geodetic { lat_deg, lon_deg, alt_m });
                [ned[0], ned[1]]
            })
            .collect();
        self.frame = Some(*frame);
        self.place_zones();
    }

    fn place_zones(&mut self) {
        self.zones = match (&self.plan, &self.frame) {
            (Some(plan), Some(frame)) => plan.zones.iter().map(|z| ZoneNed::place(z, frame)).collect(),
            _ => Vec::new(),
        };
    }

    /// An uploaded fence replaces the one before (no zones clears it). The link checked it
    /// whole before acknowledging it.
    pub fn set_plan(&mut self, plan: FencePlan) {
        tracing::info!(zones = plan.zones.len(), "uploaded geofence");
        self.plan = (!plan.zones.is_empty()).then_some(plan);
        self.place_zones();
    }

    /// The configured polygon's vertices, north/east (m); empty for none.
    #[cfg(test)]
    pub fn polygon_ned(&self) -> &[[f64; 2]] {
        &self.polygon_ned
    }

    /// The breach bookkeeping for FENCE_STATUS.
    pub fn status(&self) -> FenceStatus {
        self.status
    }

    /// The fences (`FENCE_TYPE` bits) the NED point (m) is beyond, whether or not the fence is
    /// on. `floor` false leaves the floor out.
    fn breaches_at(&self, p: &Vector3<f64>, home: &Vector3<f64>, limits: &GeofenceParams, floor: bool) -> u8 {
        let types = limits.types;
        let height = home.z - p.z;
        let radius = (p.x - home.x).hypot(p.y - home.y);
        let mut bits = 0;
        if types & FENCE_ALT_MAX != 0 && height > limits.max_altitude_m {
            bits |= FENCE_ALT_MAX;
        }
        if floor && types & FENCE_ALT_MIN != 0 && height < limits.min_altitude_m {
            bits |= FENCE_ALT_MIN;
        }
        if types & FENCE_CIRCLE != 0 && radius > limits.max_radius_m {
            bits |= FENCE_CIRCLE;
        }
        if types & FENCE_POLYGON != 0
            && (!inside_polygon(&self.polygon_ned, p.x, p.y) || breached(&self.zones, p.x, p.y))
        {
            bits |= FENCE_POLYGON;
        }
        bits
    }

    /// The vehicle at `nav` is outside the fence around `home` (NED, m), whether or not the
    /// fence is on; never without a horizontal and vertical position. The floor counts once
    /// reached (`update`).
    pub fn outside(&self, nav: &NavState, home: &Vector3<f64>, limits: &GeofenceParams) -> bool {
        if !(nav.valid.horizontal_position && nav.valid.vertical_position) {
            return false;
        }
        let p = Vector3::from(nav.position_ned_m);
        self.breaches_at(&p, home, limits, self.floor_reached) != 0
    }

    /// Judges the vehicle at `nav` at `now` and keeps the breach bookkeeping (ArduCopter's
    /// `AC_Fence::check`, once per commander update): the fences breached now (none when off,
    /// disarmed or without a position) and those newly breached, each new one counted: a fence
    /// entered from inside, or a backup fence ([`BACKUP_M`] further out) crossed by a vehicle
    /// still outside. During a manual recovery nothing changes. `landing` leaves the floor out.
    pub fn update(
        &mut self,
        now: Time,
        nav: Option<&NavState>,
        home: &Vector3<f64>,
        limits: &GeofenceParams,
        armed: bool,
        landing: bool,
    ) -> FenceCheck {
        let placed = nav.filter(|n| n.valid.horizontal_position && n.valid.vertical_position);
        if !armed {
            self.floor_reached = false;
            self.manual_recovery_since = None;
        }
        if let Some(since) = self.manual_recovery_since {
            if now.saturating_since(since) < MANUAL_RECOVERY {
                return FenceCheck { breaches: self.status.breaches, new: 0 };
            }
            self.manual_recovery_since = None;
        }
        let (bits, height, radius) = match placed {
            Some(n) if self.enabled && armed => {
                let p = Vector3::from(n.position_ned_m);
                let height = home.z - p.z;
                if height > limits.min_altitude_m {
                    self.floor_reached = true;
                }
                let radius = (p.x - home.x).hypot(p.y - home.y);
                (self.breaches_at(&p, home, limits, self.floor_reached && !landing), height, radius)
            }
            _ => (0, 0.0, 0.0),
        };
        let before = self.status.breaches;
        let mut new = bits & !before;
        // A vehicle still outside: past its backup fence it is breached anew, and the backup
        // moves out again from where it is now; back inside, the backup goes.
        let b = &mut self.backup;
        if bits & FENCE_ALT_MAX == 0 {
            b.ceiling_m = None;
        } else if new & FENCE_ALT_MAX != 0 || b.ceiling_m.is_some_and(|c| height >= c) {
            new |= FENCE_ALT_MAX;
            b.ceiling_m = Some(height + BACKUP_M);
        }
        if bits & FENCE_ALT_MIN == 0 {
            b.floor_m = None;
        } else if new & FENCE_ALT_MIN != 0 || b.floor_m.is_some_and(|f| height <= f) {
            new |= FENCE_ALT_MIN;
            b.floor_m = Some(height - BACKUP_M);
        }
        if bits & FENCE_CIRCLE == 0 {
            b.radius_m = None;
        } else if new & FENCE_CIRCLE != 0 || b.radius_m.is_some_and(|r| radius >= r) {
            new |= FENCE_CIRCLE;
            b.radius_m = Some(radius + BACKUP_M);
        }
        if new != 0 {
            self.status.breach_count = self.status.breach_count.saturating_add(new.count_ones() as u16);
            self.status.breach_time = Some(now);
        }
        self.status.breaches = bits;
        FenceCheck { breaches: bits, new }
    }

    /// A mode change was asked for (by the pilot or a ground station) at `now`: while breached,
    /// no new breach is counted for [`MANUAL_RECOVERY`] (ArduCopter's `manual_recovery_start`).
    /// Inside the fence it does nothing.
    pub fn manual_recovery_start(&mut self, now: Time) {
        if self.status.breaches != 0 {
            self.manual_recovery_since = Some(now);
        }
    }

    /// `FENCE_TOTAL`: the count of uploaded fence items ([`fence_total`]).
    pub fn total(&self) -> u16 {
        fence_total(self.plan.as_ref())
    }

    /// How far (m) the NED point is beyond the ceiling and the circle it breaches, the larger;
    /// 0 inside them (ArduCopter measures no distance for a polygon).
    pub fn breach_distance(&self, p: &Vector3<f64>, home: &Vector3<f64>, limits: &GeofenceParams) -> f64 {
        let above = (home.z - p.z) - limits.max_altitude_m;
        let beyond = (p.x - home.x).hypot(p.y - home.y) - limits.max_radius_m;
        let mut d: f64 = 0.0;
        if self.status.breaches & FENCE_ALT_MAX != 0 {
            d = d.max(above);
        }
        if self.status.breaches & FENCE_CIRCLE != 0 {
            d = d.max(beyond);
        }
        d
    }

    /// Why a NED target (m) is outside the fence (ArduCopter's
    /// `AC_Fence::check_destination_within_fence`), `None` inside; `flown_height` false for a
    /// landing point, whose height is the ground's.
    pub fn target_refused(
        &self,
        ned: &Vector3<f64>,
        home: &Vector3<f64>,
        limits: &GeofenceParams,
        flown_height: bool,
    ) -> Option<String> {
        let bits = self.breaches_at(ned, home, limits, flown_height);
        let height = home.z - ned.z;
        let distance = (ned.x - home.x).hypot(ned.y - home.y);
        if bits & FENCE_CIRCLE != 0 {
            return Some(format!(
                "{distance:.0} m from home, outside the {:.0} m geofence",
                limits.max_radius_m
            ));
        }
        if flown_height && bits & FENCE_ALT_MAX != 0 {
            return Some(format!(
                "{height:.0} m above home, above the {:.0} m geofence",
                limits.max_altitude_m
            ));
        }
        if bits & FENCE_ALT_MIN != 0 {
            return Some(format!(
                "{height:.0} m above home, below the {:.0} m geofence floor",
                limits.min_altitude_m
            ));
        }
        if bits & FENCE_POLYGON != 0 {
            return Some("outside the geofence polygon".into());
        }
        None
    }

    /// ArduCopter's fence pre-arm checks on the parameters (its own words), `None` when they
    /// hold or the fence is off.
    pub fn pre_arm(&self, limits: &GeofenceParams) -> Option<&'static str> {
        if !self.enabled {
            return None;
        }
        if limits.types == 0 {
            return Some("Fences enabled, but none selected");
        }
        if limits.types & FENCE_CIRCLE != 0 && limits.max_radius_m < limits.margin_m {
            return Some("Circle FENCE_MARGIN is greater than FENCE_RADIUS");
        }
        let alt_both = FENCE_ALT_MAX | FENCE_ALT_MIN;
        if limits.types & alt_both == alt_both {
            if limits.max_altitude_m < limits.min_altitude_m {
                return Some("FENCE_ALT_MAX < FENCE_ALT_MIN");
            }
            if limits.max_altitude_m - limits.min_altitude_m <= 2.0 * limits.margin_m {
                return Some("FENCE_MARGIN too big");
            }
        }
        None
    }
}

impl super::Commander {
    /// The geofence a ground station uploaded (or cleared, with no zones): enforced from the
    /// next update, in every mode, and judged against every target and mission from now on.
    pub fn on_fence(&mut self, plan: FencePlan) {
        self.geofence.set_plan(plan);
        self.params.geofence.total = self.geofence.total();
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::geo::Geodetic;

    use super::*;
    use crate::commander::tests::nav;

    const ORIGIN: Geodetic = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };

    fn at(north_m: f64, east_m: f64, down_m: f64) -> NavState {
        let mut n = nav(Time(1000), down_m, true);
        n.position_ned_m[0] = north_m;
        n.position_ned_m[1] = east_m;
        n
    }

    #[test]
    fn the_polygon_is_placed_in_the_frame_it_is_given() {
        let frame = LocalFrame::new(ORIGIN);
        let mut fence = Geofence::default();
        // About 111 m a degree of latitude: 0.001° north is about 111 m north.
        fence.place(&frame, &[[ORIGIN.lat_deg + 0.001, ORIGIN.lon_deg], [ORIGIN.lat_deg, ORIGIN.lon_deg]]);
        let [[n0, e0], [n1, e1]] = [fence.polygon_ned()[0], fence.polygon_ned()[1]];
        assert!((n0 - 110.6).abs() < 0.5 && e0.abs() < 1e-6, "{n0} {e0}");
        assert!(n1.abs() < 1e-6 && e1.abs() < 1e-6);
    }

    #[test]
    fn the_cylinder_and_the_polygon_each_bound_and_no_position_never_breaches() {
        let frame = LocalFrame::new(ORIGIN);
        let (d, limits) = (0.001, GeofenceParams::default());
        let mut fence = Geofence::default();
        let home = Vector3::zeros();
        assert!(!fence.outside(&at(299.0, 0.0, -119.0), &home, &limits));
        assert!(fence.outside(&at(301.0, 0.0, -10.0), &home, &limits), "radius");
        assert!(fence.outside(&at(0.0, 0.0, -121.0), &home, &limits), "altitude");
        let square =
            [[-d, -d], [d, -d], [d, d], [-d, d]].map(|[n, e]| [ORIGIN.lat_deg + n, ORIGIN.lon_deg + e]);
        fence.place(&frame, &square);
        assert!(!fence.outside(&at(100.0, 0.0, -10.0), &home, &limits));
        assert!(fence.outside(&at(120.0, 0.0, -10.0), &home, &limits), "polygon");
        let mut lost = at(500.0, 0.0, -10.0);
        lost.valid.horizontal_position = false;
        assert!(!fence.outside(&lost, &home, &limits), "no position: no breach");
    }

    #[test]
    fn the_switch_is_on_at_boot_and_follows_the_command() {
        let mut fence = Geofence::default();
        assert!(fence.enabled());
        fence.set_enabled(false);
        assert!(!fence.enabled());
        fence.set_enabled(true);
        assert!(fence.enabled());
    }
}
