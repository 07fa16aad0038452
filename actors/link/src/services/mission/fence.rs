//! What an uploaded fence (MISSION_TYPE_FENCE) means: polygon vertices and circles, inclusion
//! and exclusion, and the return point, turned into the commander's [`FencePlan`] and checked
//! whole as ArduPilot's `AC_PolyFence_loader::validate_fence` checks it before storing it. The
//! first item that breaks a rule is refused with its number and the reason; nothing of the
//! upload is kept then.
//!
//! Per item, as ArduPilot's `MissionItemProtocol_Fence`: a global frame (else
//! UNSUPPORTED_FRAME), one of the five fence commands (else UNSUPPORTED), a vertex count of
//! at most 255 (else INVALID_PARAM1). Over the whole fence (each refusal an ERROR, as
//! ArduPilot's failed `write_fence`): a polygon has at least 3 vertices, every vertex of a
//! polygon gives the same count and kind, a polygon is complete before anything else starts,
//! a circle's radius is positive, there is at most one return point, and every point is a
//! latitude and longitude. Tests: `mission::tests::fence_*`.

use kestrel_proto::Time;
use kestrel_proto::geo::deg_from_e7;
use kestrel_proto::messages::{FenceKind, FencePlan, FenceZone};
use mavlink::dialects::ardupilotmega::{MISSION_ITEM_INT_DATA, MavCmd, MavMissionResult};

use super::items::is_global;

/// Why an uploaded fence is refused: the item (its `seq`), the MISSION_ACK result and the
/// words of the STATUSTEXT beside it.
#[derive(Clone, Debug, PartialEq)]
pub struct FenceRefused {
    pub seq: u16,
    pub result: MavMissionResult,
    pub reason: String,
}

/// The polygon being read: its kind, the count its vertices give, and the vertices so far.
struct Open {
    kind: FenceKind,
    count: u16,
    vertices: Vec<[f64; 2]>,
}

/// The commander's fence from the uploaded items, or the first refusal.
pub fn to_fence(items: &[MISSION_ITEM_INT_DATA], now: Time) -> Result<FencePlan, FenceRefused> {
    let mut zones = Vec::new();
    let mut open: Option<Open> = None;
    let mut return_point = false;
    for m in items {
        let refuse = |result, reason: String| FenceRefused { seq: m.seq, result, reason };
        let error = |reason: String| refuse(MavMissionResult::MAV_MISSION_ERROR, reason);
        if !is_global(m.frame) {
            return Err(refuse(
                MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME,
                "frame not supported".into(),
            ));
        }
        let latlon = [deg_from_e7(f64::from(m.x)), deg_from_e7(f64::from(m.y))];
        let polygon = match m.command {
            MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION => Some(FenceKind::Inclusion),
            MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION => Some(FenceKind::Exclusion),
            MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
            | MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
            | MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT => None,
            _ => {
                return Err(refuse(
                    MavMissionResult::MAV_MISSION_UNSUPPORTED,
                    "command not supported".into(),
                ));
            }
        };
        if !(latlon[0].abs() <= 90.0 && latlon[1].abs() <= 180.0) {
            return Err(error("bad latitude or longitude".into()));
        }
        match polygon {
            Some(kind) => {
                let given = m.param1;
                if !(given.is_finite() && (0.0..=255.0).contains(&given)) {
                    return Err(refuse(
                        MavMissionResult::MAV_MISSION_INVALID_PARAM1,
                        "vertex count out of range".into(),
                    ));
                }
                let count = given as u16;
                if count < 3 {
                    return Err(error(format!("polygon of {count} vertices, at least 3")));
                }
                let poly = open.get_or_insert_with(|| Open { kind, count, vertices: Vec::new() });
                if poly.kind != kind {
                    return Err(error("vertex of the other kind inside a polygon".into()));
                }
                if poly.count != count {
                    return Err(error(format!("vertex count {count}, its polygon's is {}", poly.count)));
                }
                poly.vertices.push(latlon);
                if let Some(done) = open.take_if(|p| p.vertices.len() == usize::from(p.count)) {
                    zones.push(FenceZone::Polygon { kind: done.kind, vertices_deg: done.vertices });
                }
            }
            None if open.is_some() => {
                return Err(error("polygon incomplete".into()));
            }
            None if m.command == MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT => {
                if return_point {
                    return Err(error("a second return point".into()));
                }
                return_point = true;
            }
            None => {
                let radius_m = f64::from(m.param1);
                if !(radius_m.is_finite() && radius_m > 0.0) {
                    return Err(error("circle radius not positive".into()));
                }
                let kind = if m.command == MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION {
                    FenceKind::Inclusion
                } else {
                    FenceKind::Exclusion
                };
                zones.push(FenceZone::Circle { kind, center_deg: latlon, radius_m });
            }
        }
    }
    if open.is_some() {
        let seq = items.last().map_or(0, |m| m.seq);
        return Err(FenceRefused {
            seq,
            result: MavMissionResult::MAV_MISSION_ERROR,
            reason: "polygon incomplete".into(),
        });
    }
    Ok(FencePlan { time: now, zones })
}
