//! QGroundControl `.plan` files (JSON) → [`Mission`].
//!
//! The format is QGC's (`fileType: "Plan"`, `mission.items[]` of `SimpleItem`s with a MAVLink
//! `command`, `frame` and seven `params`, `mission.plannedHomePosition`,
//! `mission.cruiseSpeed`). QGC writes NaN parameters as `null`. Supported commands:
//! `NAV_WAYPOINT` (16), `NAV_LOITER_TIME` (19), `NAV_RETURN_TO_LAUNCH` (20), `NAV_LAND` (21),
//! `NAV_TAKEOFF` (22), `DO_CHANGE_SPEED` (178); frames `GLOBAL` (0, AMSL) and
//! `GLOBAL_RELATIVE_ALT` (3). Anything else — complex items (surveys), terrain frames, other
//! commands — is refused with the item's index, never skipped silently.

use std::path::Path;

use kestrel_proto::Time;
use kestrel_proto::messages::{AltitudeFrame, Mission, MissionItem, MissionPoint};
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
    let items =
        plan.mission.items.iter().enumerate().map(|(i, item)| convert(i, item)).collect::<Result<_, _>>()?;
    Ok(Mission { time: Time::ZERO, items, cruise_speed_m_s: cruise })
}

fn convert(index: usize, item: &PlanItem) -> Result<MissionItem, PlanError> {
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
                Ok(MissionItem::LoiterTime { duration_s: t, point: None })
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
