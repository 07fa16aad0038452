//! QGroundControl `.plan` files (JSON) → [`Mission`].
//!
//! The format is QGC's (`fileType: "Plan"`, `mission.items[]` of `SimpleItem`s with a MAVLink
//! `command`, `frame` and seven `params`, `mission.plannedHomePosition`,
//! `mission.cruiseSpeed`). QGC writes NaN parameters as `null`. A survey or corridor scan
//! (`ComplexItem` with a `TransectStyleComplexItem`) is flown as the `Items` QGC saved in it, in
//! order, as QGC uploads it. The commands are those a MAVLink upload takes (the link's
//! `services/mission/items.rs`, the same meanings); frames `GLOBAL` (0, AMSL) and
//! `GLOBAL_RELATIVE_ALT` (3), `MISSION` (2) for items without a place. A DO_JUMP's target is
//! the `doJumpId` of the item it jumps to. Anything else — a structure scan, terrain frames,
//! other commands — is refused with the item's index (counted over the flattened items),
//! never skipped silently.

use std::path::Path;

use kestrel_proto::Time;
use kestrel_proto::messages::{AltitudeFrame, CameraAction, Mission, MissionItem, MissionPoint};
use serde::Deserialize;

use crate::error::PlanError;

/// Acceptance radius when an item leaves it at 0 (m), like PX4's `NAV_ACC_RAD` default.
pub const DEFAULT_ACCEPTANCE_RADIUS_M: f64 = 2.0;
/// Cruise speed when the plan does not give one (m/s).
pub const DEFAULT_CRUISE_SPEED_M_S: f64 = 5.0;

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct PlanFile {
    file_type: String,
    mission: PlanMission,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct PlanMission {
    #[serde(default)]
    cruise_speed: Option<f64>,
    items: Vec<PlanItem>,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct PlanItem {
    #[serde(rename = "type")]
    kind: String,
    #[serde(default)]
    command: Option<u16>,
    #[serde(default)]
    frame: Option<u8>,
    #[serde(default)]
    params: Vec<Option<f64>>,
    #[serde(default)]
    do_jump_id: Option<u32>,
    #[serde(default, rename = "TransectStyleComplexItem")]
    transect: Option<Transect>,
}

/// What QGC saves of a survey or corridor scan that matters to the flight: its items.
#[derive(Deserialize)]
struct Transect {
    #[serde(rename = "Items")]
    items: Vec<PlanItem>,
}

/// Reads and converts a `.plan` file.
pub fn load_plan(path: &Path) -> Result<Mission, PlanError> {
    let text = std::fs::read_to_string(path)
        .map_err(|source| PlanError::Read { path: path.to_path_buf(), source })?;
    parse_plan(&text).map_err(|e| PlanError::InFile { path: path.to_path_buf(), source: Box::new(e) })
}

/// Converts the text of a `.plan` file.
pub fn parse_plan(json: &str) -> Result<Mission, PlanError> {
    let plan: PlanFile = serde_json::from_str(json)?;
    if plan.file_type != "Plan" {
        return Err(PlanError::NotAPlan(plan.file_type));
    }
    let cruise = match plan.mission.cruise_speed {
        Some(s) if s.is_finite() && s > 0.0 => s,
        _ => DEFAULT_CRUISE_SPEED_M_S,
    };
    let mut flat = Vec::new();
    for (index, item) in plan.mission.items.iter().enumerate() {
        match &item.transect {
            Some(t) if item.kind == "ComplexItem" => flat.extend(t.items.iter()),
            _ if item.kind == "ComplexItem" => {
                return Err(PlanError::Item {
                    index,
                    reason: "complex items other than surveys and corridor scans are not supported".into(),
                });
            }
            _ => flat.push(item),
        }
    }
    let jump_ids: Vec<Option<u32>> = flat.iter().map(|i| i.do_jump_id).collect();
    let items =
        flat.iter().enumerate().map(|(i, item)| convert(i, item, &jump_ids)).collect::<Result<_, _>>()?;
    Ok(Mission { time: Time::ZERO, items, cruise_speed_m_s: cruise })
}

/// A place left at 0, 0 (or without one) means "where the vehicle is" or "none", as ArduPilot
/// reads a loiter's or a region of interest's location.
fn optional_point(p: MissionPoint) -> Option<MissionPoint> {
    let unset = |v: f64| !v.is_finite() || v == 0.0;
    (!(unset(p.lat_deg) && unset(p.lon_deg))).then_some(p)
}

fn convert(index: usize, item: &PlanItem, jump_ids: &[Option<u32>]) -> Result<MissionItem, PlanError> {
    let err = |reason: String| PlanError::Item { index, reason };
    if item.kind != "SimpleItem" {
        return Err(err(format!("`{}` items are not supported (only SimpleItem)", item.kind)));
    }
    let command = item.command.ok_or_else(|| err("has no command".into()))?;
    let param = |i: usize| item.params.get(i).copied().flatten();
    let point = || -> Result<MissionPoint, PlanError> {
        let frame = match item.frame {
            Some(0) => AltitudeFrame::Amsl,
            Some(3) => AltitudeFrame::RelativeHome,
            other => return Err(err(format!("altitude frame {other:?} is not supported (0 or 3)"))),
        };
        let (lat, lon, alt) = (param(4), param(5), param(6));
        let alt = alt.filter(|a| a.is_finite()).ok_or_else(|| err("has no altitude (param 7)".into()))?;
        let check = |v: Option<f64>, lim: f64, name: &str| match v {
            Some(x) if x.is_finite() && x.abs() <= lim => Ok(x),
            None => Ok(f64::NAN),
            Some(x) => Err(err(format!("{name} {x} is out of range"))),
        };
        Ok(MissionPoint {
            lat_deg: check(lat, 90.0, "latitude")?,
            lon_deg: check(lon, 180.0, "longitude")?,
            alt_m: alt,
            frame,
        })
    };
    let needs_position = |p: MissionPoint| {
        if p.lat_deg.is_finite() && p.lon_deg.is_finite() {
            Ok(p)
        } else {
            Err(err("has no latitude/longitude".into()))
        }
    };
    match command {
        16 => {
            let hold_s = param(0).unwrap_or(0.0);
            let radius = param(1).filter(|r| *r > 0.0).unwrap_or(DEFAULT_ACCEPTANCE_RADIUS_M);
            if !hold_s.is_finite() || hold_s < 0.0 || !radius.is_finite() {
                return Err(err(format!("bad hold time {hold_s} or acceptance radius {radius}")));
            }
            Ok(MissionItem::Waypoint {
                point: needs_position(point()?)?,
                acceptance_radius_m: radius,
                hold_s,
            })
        }
        19 => match param(0) {
            Some(t) if t.is_finite() && t >= 0.0 => {
                Ok(MissionItem::LoiterTime { duration_s: t, point: optional_point(point()?) })
            }
            other => Err(err(format!("bad loiter time {other:?}"))),
        },
        20 => Ok(MissionItem::ReturnToLaunch),
        21 => Ok(MissionItem::Land { point: point()? }),
        22 => Ok(MissionItem::Takeoff { point: point()? }),
        178 => match param(1) {
            Some(s) if s.is_finite() && s > 0.0 => Ok(MissionItem::ChangeSpeed { speed_m_s: s }),
            other => Err(err(format!("bad speed {other:?}"))),
        },
        17 => Ok(MissionItem::LoiterUnlimited { point: optional_point(point()?) }),
        18 => match (param(0), param(2).unwrap_or(0.0)) {
            (Some(turns), radius_m) if turns.is_finite() && turns > 0.0 && radius_m.is_finite() => {
                Ok(MissionItem::LoiterTurns { point: optional_point(point()?), turns, radius_m })
            }
            other => Err(err(format!("bad loiter turns or radius {other:?}"))),
        },
        82 => match param(0).unwrap_or(0.0) {
            hold_s if hold_s.is_finite() && hold_s >= 0.0 => {
                Ok(MissionItem::SplineWaypoint { point: needs_position(point()?)?, hold_s })
            }
            other => Err(err(format!("bad hold time {other}"))),
        },
        93 => match param(0) {
            Some(t) if t.is_finite() && t >= 0.0 => Ok(MissionItem::Delay { duration_s: t }),
            other => Err(err(format!("bad delay {other:?} (a time of day is not supported)"))),
        },
        112 => match param(0) {
            Some(t) if t.is_finite() && t >= 0.0 => Ok(MissionItem::ConditionDelay { duration_s: t }),
            other => Err(err(format!("bad delay {other:?}"))),
        },
        114 => match param(0) {
            Some(d) if d.is_finite() && d >= 0.0 => Ok(MissionItem::ConditionDistance { distance_m: d }),
            other => Err(err(format!("bad distance {other:?}"))),
        },
        115 => match (param(0), param(1).unwrap_or(0.0)) {
            (Some(angle_deg), rate_deg_s)
                if angle_deg.is_finite() && rate_deg_s.is_finite() && rate_deg_s >= 0.0 =>
            {
                Ok(MissionItem::ConditionYaw {
                    angle_deg,
                    rate_deg_s,
                    clockwise: param(2).unwrap_or(1.0) >= 0.0,
                    relative: param(3).unwrap_or(0.0) != 0.0,
                })
            }
            other => Err(err(format!("bad yaw angle or rate {other:?}"))),
        },
        177 => {
            let target_id = param(0).filter(|t| t.is_finite() && *t >= 1.0 && t.fract() == 0.0);
            let target = target_id.and_then(|id| jump_ids.iter().position(|j| j.map(f64::from) == Some(id)));
            let repeat =
                param(1).filter(|r| r.is_finite() && *r >= -1.0 && r.fract() == 0.0 && *r <= 32767.0);
            match (target, repeat) {
                (Some(target), Some(repeat)) => Ok(MissionItem::Jump {
                    target: u32::try_from(target).map_err(|_| err("jump target too far".into()))?,
                    repeat: repeat as i32,
                }),
                _ => Err(err(format!("bad jump target {:?} or repeat count {:?}", param(0), param(1)))),
            }
        }
        189 => Ok(MissionItem::LandStart { point: point().ok().and_then(optional_point) }),
        195 => Ok(MissionItem::RegionOfInterest { point: optional_point(point()?) }),
        197 => Ok(MissionItem::RegionOfInterest { point: None }),
        201 if param(0) == Some(0.0) => Ok(MissionItem::RegionOfInterest { point: None }),
        201 => Ok(MissionItem::RegionOfInterest { point: optional_point(point()?) }),
        206 => match param(0) {
            Some(d) if d.is_finite() && d >= 0.0 => {
                Ok(MissionItem::Camera { action: CameraAction::TriggerDistance { distance_m: d } })
            }
            other => Err(err(format!("bad trigger distance {other:?}"))),
        },
        2000 => match (param(1).unwrap_or(0.0), param(2).unwrap_or(0.0)) {
            (interval_s, count)
                if interval_s.is_finite() && interval_s >= 0.0 && count.is_finite() && count >= 0.0 =>
            {
                Ok(MissionItem::Camera {
                    action: CameraAction::StartCapture {
                        interval_s,
                        count: count.min(f64::from(u32::MAX)) as u32,
                    },
                })
            }
            other => Err(err(format!("bad capture interval or count {other:?}"))),
        },
        2001 => Ok(MissionItem::Camera { action: CameraAction::StopCapture }),
        203 if param(4).is_some_and(|x| x != 0.0) => Ok(MissionItem::Camera { action: CameraAction::Shoot }),
        181 | 182 | 183 | 184 | 203 | 205 | 1000 => Ok(MissionItem::NoOutput { command }),
        other => Err(err(format!("MAVLink command {other} is not supported"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_square_loads() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/missions/square.plan");
        let mission = load_plan(&path).expect("loads");
        assert_eq!(mission.items.len(), 6);
        assert!(matches!(mission.items[0], MissionItem::Takeoff { .. }));
        assert!(matches!(mission.items[5], MissionItem::ReturnToLaunch));
        assert_eq!(mission.cruise_speed_m_s, 5.0);
    }

    #[test]
    fn the_shipped_survey_loads_its_transects_and_camera_triggers() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/missions/survey.plan");
        let mission = load_plan(&path).expect("loads");
        assert_eq!(mission.items.len(), 12, "take-off, the survey's 10 items, RTL");
        assert!(matches!(mission.items[0], MissionItem::Takeoff { .. }));
        assert_eq!(
            mission.items[2],
            MissionItem::Camera { action: CameraAction::TriggerDistance { distance_m: 8.0 } }
        );
        assert_eq!(
            mission.items[10],
            MissionItem::Camera { action: CameraAction::TriggerDistance { distance_m: 0.0 } }
        );
        assert_eq!(mission.items.iter().filter(|i| matches!(i, MissionItem::Waypoint { .. })).count(), 8);
        assert!(mission.check_fields().is_ok());
    }

    #[test]
    fn a_jump_targets_the_item_with_its_do_jump_id() {
        let plan = r#"{"fileType": "Plan", "mission": {"items": [
            {"type": "SimpleItem", "command": 22, "doJumpId": 1, "frame": 3, "params": [0,0,0,null,6.8,79.9,10]},
            {"type": "SimpleItem", "command": 16, "doJumpId": 2, "frame": 3, "params": [0,0,0,null,6.8001,79.9,10]},
            {"type": "SimpleItem", "command": 177, "doJumpId": 3, "frame": 2, "params": [2,3,0,0,0,0,0]},
            {"type": "SimpleItem", "command": 177, "doJumpId": 4, "frame": 2, "params": [9,3,0,0,0,0,0]}]}}"#;
        let e = parse_plan(plan).unwrap_err();
        assert!(matches!(e, PlanError::Item { index: 3, .. }), "no item has doJumpId 9: {e}");
        let ok = plan.replace("[9,3,", "[1,-1,");
        let mission = parse_plan(&ok).expect("loads");
        assert_eq!(mission.items[2], MissionItem::Jump { target: 1, repeat: 3 });
        assert_eq!(mission.items[3], MissionItem::Jump { target: 0, repeat: -1 });
    }

    #[test]
    fn bad_items_are_refused_with_their_index() {
        let plan = r#"{"fileType": "Plan", "mission": {"items": [
            {"type": "SimpleItem", "command": 22, "frame": 3, "params": [0,0,0,null,null,null,10]},
            {"type": "SimpleItem", "command": 16, "frame": 10, "params": [0,0,0,null,6.8,79.9,10]}]}}"#;
        let e = parse_plan(plan).unwrap_err();
        assert!(matches!(e, PlanError::Item { index: 1, .. }), "{e}");
        let survey = r#"{"fileType": "Plan", "mission": {"items": [{"type": "ComplexItem"}]}}"#;
        assert!(matches!(parse_plan(survey), Err(PlanError::Item { index: 0, .. })));
        assert!(matches!(parse_plan("{}"), Err(PlanError::Json(_))));
    }
}
