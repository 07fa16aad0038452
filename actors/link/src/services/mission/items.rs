//! What an uploaded mission item means: MAVLink's items (INT and legacy float forms, their
//! frames) turned into the commander's [`Mission`], each item checked and a refusal naming the
//! item and what was wrong.
#![allow(
    deprecated,
    reason = "legacy MISSION_ITEM and the non-INT global frames are still spoken by ground stations and must be accepted"
)]

use kestrel_proto::Time;
use kestrel_proto::geo::deg_from_e7;
use kestrel_proto::messages::{AltitudeFrame, CameraAction, Mission, MissionItem, MissionPoint};
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
        MavMissionResult::MAV_MISSION_INVALID_PARAM3 => "param3 out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM4 => "param4 out of range",
        MavMissionResult::MAV_MISSION_ERROR => "jump target out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM5_X => "latitude out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y => "longitude out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM7 => "altitude out of range",
        MavMissionResult::MAV_MISSION_NO_SPACE => "too many items",
        _ => "invalid",
    }
}

/// A location that may be left at 0, 0 to mean "where the vehicle is" (loiter items) or "none"
/// (a region of interest, a landing sequence's start), as ArduPilot reads them.
fn optional_point(m: &MISSION_ITEM_INT_DATA) -> Result<Option<MissionPoint>, MavMissionResult> {
    if m.x == 0 && m.y == 0 { Ok(None) } else { point(m).map(Some) }
}

/// `param` as a finite number at least `min`, or the MISSION_ACK result naming it.
fn param_at_least(value: f32, min: f64, bad: MavMissionResult) -> Result<f64, MavMissionResult> {
    let v = f64::from(value);
    if v.is_finite() && v >= min { Ok(v) } else { Err(bad) }
}

/// One uploaded item (not home) as the commander's, checked; `count` is the whole upload's
/// item count (home included), for a jump's target.
fn to_item(m: &MISSION_ITEM_INT_DATA, count: usize) -> Result<MissionItem, MavMissionResult> {
    use MavMissionResult::{
        MAV_MISSION_ERROR, MAV_MISSION_INVALID_PARAM1, MAV_MISSION_INVALID_PARAM2,
        MAV_MISSION_INVALID_PARAM3, MAV_MISSION_INVALID_PARAM4,
    };
    Ok(match m.command {
        MavCmd::MAV_CMD_NAV_WAYPOINT => {
            let hold_s = param_at_least(m.param1, 0.0, MAV_MISSION_INVALID_PARAM1)?;
            let radius = param_at_least(m.param2, 0.0, MAV_MISSION_INVALID_PARAM2)?;
            let acceptance_radius_m = if radius > 0.0 { radius } else { DEFAULT_ACCEPTANCE_M };
            MissionItem::Waypoint { point: point(m)?, acceptance_radius_m, hold_s }
        }
        MavCmd::MAV_CMD_NAV_SPLINE_WAYPOINT => {
            let hold_s = param_at_least(m.param1, 0.0, MAV_MISSION_INVALID_PARAM1)?;
            MissionItem::SplineWaypoint { point: point(m)?, hold_s }
        }
        MavCmd::MAV_CMD_NAV_TAKEOFF => MissionItem::Takeoff { point: point(m)? },
        MavCmd::MAV_CMD_NAV_LAND => MissionItem::Land { point: point(m)? },
        MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => MissionItem::ReturnToLaunch,
        MavCmd::MAV_CMD_NAV_LOITER_TIME => MissionItem::LoiterTime {
            duration_s: param_at_least(m.param1, 0.0, MAV_MISSION_INVALID_PARAM1)?,
            point: optional_point(m)?,
        },
        MavCmd::MAV_CMD_NAV_LOITER_TURNS => {
            let turns = param_at_least(m.param1, 0.0, MAV_MISSION_INVALID_PARAM1)?;
            if turns <= 0.0 {
                return Err(MAV_MISSION_INVALID_PARAM1);
            }
            let radius_m = f64::from(m.param3);
            if !radius_m.is_finite() {
                return Err(MAV_MISSION_INVALID_PARAM3);
            }
            MissionItem::LoiterTurns { point: optional_point(m)?, turns, radius_m }
        }
        MavCmd::MAV_CMD_NAV_LOITER_UNLIM => MissionItem::LoiterUnlimited { point: optional_point(m)? },
        // param1 -1 asks for a time of day (params 2-4, UTC): the commander has no UTC clock,
        // so such a delay cannot be flown and is refused.
        MavCmd::MAV_CMD_NAV_DELAY => {
            MissionItem::Delay { duration_s: param_at_least(m.param1, 0.0, MAV_MISSION_INVALID_PARAM1)? }
        }
        MavCmd::MAV_CMD_DO_CHANGE_SPEED => {
            let speed_m_s = f64::from(m.param2);
            if !(speed_m_s.is_finite() && speed_m_s > 0.0) {
                return Err(MAV_MISSION_INVALID_PARAM2);
            }
            MissionItem::ChangeSpeed { speed_m_s }
        }
        // ArduCopter refuses a jump to item 0 (home) or past the last item with ERROR.
        MavCmd::MAV_CMD_DO_JUMP => {
            let target = f64::from(m.param1);
            if !(target.is_finite() && target >= 1.0 && target < count as f64 && target.fract() == 0.0) {
                return Err(MAV_MISSION_ERROR);
            }
            let repeat = f64::from(m.param2);
            if !(repeat.is_finite()
                && repeat >= -1.0
                && repeat <= f64::from(i16::MAX)
                && repeat.fract() == 0.0)
            {
                return Err(MAV_MISSION_INVALID_PARAM2);
            }
            // The commander's items start after home: its index is the sequence number - 1.
            MissionItem::Jump { target: target as u32 - 1, repeat: repeat as i32 }
        }
        MavCmd::MAV_CMD_CONDITION_DELAY => MissionItem::ConditionDelay {
            duration_s: param_at_least(m.param1, 0.0, MAV_MISSION_INVALID_PARAM1)?,
        },
        MavCmd::MAV_CMD_CONDITION_DISTANCE => MissionItem::ConditionDistance {
            distance_m: param_at_least(m.param1, 0.0, MAV_MISSION_INVALID_PARAM1)?,
        },
        MavCmd::MAV_CMD_CONDITION_YAW => {
            let angle_deg = f64::from(m.param1);
            if !angle_deg.is_finite() {
                return Err(MAV_MISSION_INVALID_PARAM1);
            }
            MissionItem::ConditionYaw {
                angle_deg,
                rate_deg_s: param_at_least(m.param2, 0.0, MAV_MISSION_INVALID_PARAM2)?,
                // -1 counter-clockwise, 1 (or 0) clockwise.
                clockwise: m.param3 >= 0.0,
                relative: m.param4 != 0.0,
            }
        }
        // MAV_ROI_NONE (0) or a location at 0, 0 stops pointing, as ArduCopter reads it.
        MavCmd::MAV_CMD_DO_SET_ROI => {
            MissionItem::RegionOfInterest { point: if m.param1 == 0.0 { None } else { optional_point(m)? } }
        }
        MavCmd::MAV_CMD_DO_SET_ROI_LOCATION => MissionItem::RegionOfInterest { point: optional_point(m)? },
        MavCmd::MAV_CMD_DO_SET_ROI_NONE => MissionItem::RegionOfInterest { point: None },
        MavCmd::MAV_CMD_DO_LAND_START => MissionItem::LandStart { point: optional_point(m)? },
        MavCmd::MAV_CMD_DO_SET_CAM_TRIGG_DIST => MissionItem::Camera {
            action: CameraAction::TriggerDistance {
                distance_m: param_at_least(m.param1, 0.0, MAV_MISSION_INVALID_PARAM1)?,
            },
        },
        MavCmd::MAV_CMD_IMAGE_START_CAPTURE => {
            let interval_s = param_at_least(m.param2, 0.0, MAV_MISSION_INVALID_PARAM2)?;
            let count = param_at_least(m.param3, 0.0, MAV_MISSION_INVALID_PARAM3)?;
            MissionItem::Camera {
                action: CameraAction::StartCapture {
                    interval_s,
                    count: count.min(f64::from(u32::MAX)) as u32,
                },
            }
        }
        MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE => MissionItem::Camera { action: CameraAction::StopCapture },
        // DIGICAM_CONTROL's shoot field is param5 (x, not scaled in the mission frame).
        MavCmd::MAV_CMD_DO_DIGICAM_CONTROL if m.x != 0 => MissionItem::Camera { action: CameraAction::Shoot },
        MavCmd::MAV_CMD_DO_DIGICAM_CONTROL => MissionItem::NoOutput { command: m.command as u16 },
        MavCmd::MAV_CMD_DO_SET_SERVO
        | MavCmd::MAV_CMD_DO_SET_RELAY
        | MavCmd::MAV_CMD_DO_REPEAT_SERVO
        | MavCmd::MAV_CMD_DO_REPEAT_RELAY
        | MavCmd::MAV_CMD_DO_MOUNT_CONTROL => MissionItem::NoOutput { command: m.command as u16 },
        // ArduCopter refuses NaN angles and rates here (INVALID_PARAM3 for a NaN pitch rate).
        MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW => {
            let results = [
                MAV_MISSION_INVALID_PARAM1,
                MAV_MISSION_INVALID_PARAM2,
                MAV_MISSION_INVALID_PARAM3,
                MAV_MISSION_INVALID_PARAM4,
            ];
            for (v, bad) in [m.param1, m.param2, m.param3, m.param4].into_iter().zip(results) {
                if !v.is_finite() {
                    return Err(bad);
                }
            }
            MissionItem::NoOutput { command: m.command as u16 }
        }
        // CONDITION_GATE and everything else: ArduCopter refuses them too (UNSUPPORTED).
        _ => return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED),
    })
}

/// The commander's mission from uploaded items (item 0, home, skipped).
pub fn to_mission(items: &[MISSION_ITEM_INT_DATA], now: Time) -> Result<Mission, ItemRefused> {
    let out = items
        .iter()
        .skip(1)
        .map(|m| to_item(m, items.len()).map_err(|result| ItemRefused { seq: m.seq, result }))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Mission { time: now, items: out, cruise_speed_m_s: DEFAULT_CRUISE_M_S })
}

#[cfg(test)]
#[path = "items_tests.rs"]
mod tests;
