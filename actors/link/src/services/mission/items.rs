//! What an uploaded mission item means: MAVLink's items (INT and legacy float forms, their
//! frames) turned into the commander's [`Mission`], each item checked and a refusal naming the
//! item and what was wrong.
#![allow(
    deprecated,
    reason = "legacy MISSION_ITEM and the non-INT global frames are still spoken by ground stations and must be accepted"
)]

use kestrel_proto::Time;
use kestrel_proto::geo::deg_from_e7;
use kestrel_proto::messages::{AltitudeFrame, Mission, MissionItem, MissionPoint};
use mavlink::dialects::ardupilotmega::{
    MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA, MavCmd, MavFrame, MavMissionResult,
};

use super::DEFAULT_CRUISE_M_S;

/// Acceptance radius of a waypoint that gives none (m).
const DEFAULT_ACCEPTANCE_M: f64 = 2.0;

pub(super) fn is_global(f: MavFrame) -> bool {
    matches!(
        f,
        MavFrame::MAV_FRAME_GLOBAL
            | MavFrame::MAV_FRAME_GLOBAL_INT
            | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
            | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
            | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT
            | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT
    )
}

pub(super) fn int_frame(f: MavFrame) -> MavFrame {
    match f {
        MavFrame::MAV_FRAME_GLOBAL => MavFrame::MAV_FRAME_GLOBAL_INT,
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT => MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT => MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
        other => other,
    }
}

pub(super) fn to_float(m: &MISSION_ITEM_INT_DATA) -> MISSION_ITEM_DATA {
    let global = is_global(m.frame);
    let unscale = |v: i32| if global { deg_from_e7(f64::from(v)) as f32 } else { v as f32 };
    MISSION_ITEM_DATA {
        param1: m.param1,
        param2: m.param2,
        param3: m.param3,
        param4: m.param4,
        x: unscale(m.x),
        y: unscale(m.y),
        z: m.z,
        seq: m.seq,
        command: m.command,
        target_system: m.target_system,
        target_component: m.target_component,
        frame: m.frame,
        current: m.current,
        autocontinue: m.autocontinue,
        mission_type: m.mission_type,
    }
}

pub(super) fn point(m: &MISSION_ITEM_INT_DATA) -> Result<MissionPoint, MavMissionResult> {
    let frame = match m.frame {
        MavFrame::MAV_FRAME_GLOBAL | MavFrame::MAV_FRAME_GLOBAL_INT => AltitudeFrame::Amsl,
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => {
            AltitudeFrame::RelativeHome
        }
        _ => return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME),
    };
    let (lat_deg, lon_deg) = (deg_from_e7(f64::from(m.x)), deg_from_e7(f64::from(m.y)));
    if lat_deg.abs() > 90.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X);
    }
    if lon_deg.abs() > 180.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y);
    }
    if !m.z.is_finite() {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM7);
    }
    Ok(MissionPoint { lat_deg, lon_deg, alt_m: f64::from(m.z), frame })
}

/// An uploaded item that cannot be flown: its sequence number and the MISSION_ACK result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ItemRefused {
    pub seq: u16,
    pub result: MavMissionResult,
}

/// What a refused item's MISSION_ACK result means, for the STATUSTEXT beside it (short: a
/// STATUSTEXT holds 50 characters, the prefix "Mission item 65535: " takes 20).
pub(super) fn refusal_text(result: MavMissionResult) -> &'static str {
    match result {
        MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME => "frame not supported",
        MavMissionResult::MAV_MISSION_UNSUPPORTED => "command not supported",
        MavMissionResult::MAV_MISSION_INVALID_PARAM1 => "param1 out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM2 => "param2 out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM5_X => "latitude out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y => "longitude out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM7 => "altitude out of range",
        MavMissionResult::MAV_MISSION_NO_SPACE => "too many items",
        _ => "invalid",
    }
}

/// The commander's mission from uploaded items (item 0, home, skipped).
pub fn to_mission(items: &[MISSION_ITEM_INT_DATA], now: Time) -> Result<Mission, ItemRefused> {
    let mut out = Vec::with_capacity(items.len().saturating_sub(1));
    for m in items.iter().skip(1) {
        let refused = |result| ItemRefused { seq: m.seq, result };
        let item = match m.command {
            MavCmd::MAV_CMD_NAV_WAYPOINT => {
                let hold_s = f64::from(m.param1);
                let radius = f64::from(m.param2);
                if !(hold_s.is_finite() && hold_s >= 0.0) {
                    return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM1));
                }
                if !(radius.is_finite() && radius >= 0.0) {
                    return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM2));
                }
                let acceptance_radius_m = if radius > 0.0 { radius } else { DEFAULT_ACCEPTANCE_M };
                MissionItem::Waypoint { point: point(m).map_err(refused)?, acceptance_radius_m, hold_s }
            }
            MavCmd::MAV_CMD_NAV_TAKEOFF => MissionItem::Takeoff { point: point(m).map_err(refused)? },
            MavCmd::MAV_CMD_NAV_LAND => MissionItem::Land { point: point(m).map_err(refused)? },
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => MissionItem::ReturnToLaunch,
            MavCmd::MAV_CMD_NAV_LOITER_TIME => {
                let duration_s = f64::from(m.param1);
                if !(duration_s.is_finite() && duration_s >= 0.0) {
                    return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM1));
                }
                MissionItem::LoiterTime { duration_s }
            }
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => {
                let speed_m_s = f64::from(m.param2);
                if !(speed_m_s.is_finite() && speed_m_s > 0.0) {
                    return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM2));
                }
                MissionItem::ChangeSpeed { speed_m_s }
            }
            _ => return Err(refused(MavMissionResult::MAV_MISSION_UNSUPPORTED)),
        };
        out.push(item);
    }
    Ok(Mission { time: now, items: out, cruise_speed_m_s: DEFAULT_CRUISE_M_S })
}
