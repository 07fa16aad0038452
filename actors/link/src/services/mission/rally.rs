//! What an uploaded rally item means: MAV_CMD_NAV_RALLY_POINT items (MISSION_TYPE_RALLY) turned
//! into the commander's [`RallyPoints`], checked as ArduPilot checks them
//! (`MissionItemProtocol_Rally::convert_MISSION_ITEM_INT_to_RallyLocation`): the command must be
//! a rally point, the frame relative to home, latitude and longitude on the globe and the
//! altitude a whole number of metres that fits ArduPilot's 16-bit field. A refusal names the item.
#![allow(
    deprecated,
    reason = "the legacy MAV_FRAME_GLOBAL_RELATIVE_ALT frame is still sent by ground stations"
)]

use kestrel_proto::Time;
use kestrel_proto::messages::{MAX_RALLY_POINTS, RallyPoints};
use mavlink::dialects::ardupilotmega::{MISSION_ITEM_INT_DATA, MavCmd, MavFrame, MavMissionResult};

use super::items::{ItemRefused, point};

/// The rally points of an uploaded plan (every item is one; rally plans have no home item).
pub fn to_rally(items: &[MISSION_ITEM_INT_DATA], now: Time) -> Result<RallyPoints, ItemRefused> {
    let mut points = Vec::with_capacity(items.len());
    for m in items {
        let refused = |result| ItemRefused { seq: m.seq, result };
        if m.command != MavCmd::MAV_CMD_NAV_RALLY_POINT {
            return Err(refused(MavMissionResult::MAV_MISSION_UNSUPPORTED));
        }
        if !matches!(
            m.frame,
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
        ) {
            return Err(refused(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME));
        }
        if !(m.z.is_finite() && f32::from(i16::MIN) <= m.z && m.z <= f32::from(i16::MAX)) {
            return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM7));
        }
        points.push(point(m).map_err(refused)?);
    }
    if points.len() > MAX_RALLY_POINTS {
        return Err(ItemRefused {
            seq: u16::try_from(MAX_RALLY_POINTS).unwrap_or(u16::MAX),
            result: MavMissionResult::MAV_MISSION_NO_SPACE,
        });
    }
    Ok(RallyPoints { time: now, points })
}

#[cfg(test)]
mod tests {
    use kestrel_proto::geo::deg_e7;
    use kestrel_proto::messages::AltitudeFrame;
    use mavlink::dialects::ardupilotmega::MavMissionType;

    use super::*;

    fn rally(seq: u16, lat_deg: f64, lon_deg: f64, alt_m: f32) -> MISSION_ITEM_INT_DATA {
        MISSION_ITEM_INT_DATA {
            seq,
            command: MavCmd::MAV_CMD_NAV_RALLY_POINT,
            frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            x: deg_e7(lat_deg),
            y: deg_e7(lon_deg),
            z: alt_m,
            mission_type: MavMissionType::MAV_MISSION_TYPE_RALLY,
            ..MISSION_ITEM_INT_DATA::default()
        }
    }

    #[test]
    fn rally_items_become_points_above_home() {
        let r = to_rally(&[rally(0, 6.798, 79.902, 20.0), rally(1, -6.5, -79.5, 0.0)], Time::ZERO)
            .expect("rally");
        assert_eq!(r.points.len(), 2);
        assert!((r.points[0].lat_deg - 6.798).abs() < 1e-7 && (r.points[0].lon_deg - 79.902).abs() < 1e-7);
        assert_eq!(r.points[0].alt_m, 20.0);
        assert!(r.points.iter().all(|p| p.frame == AltitudeFrame::RelativeHome));
        r.check_fields().expect("checked");
    }

    #[test]
    fn a_malformed_rally_item_is_refused_with_its_number_and_reason() {
        let good = rally(0, 6.798, 79.902, 20.0);
        let cases = [
            (
                MISSION_ITEM_INT_DATA { command: MavCmd::MAV_CMD_NAV_WAYPOINT, ..rally(1, 6.8, 79.9, 10.0) },
                MavMissionResult::MAV_MISSION_UNSUPPORTED,
            ),
            (
                MISSION_ITEM_INT_DATA { frame: MavFrame::MAV_FRAME_GLOBAL_INT, ..rally(1, 6.8, 79.9, 10.0) },
                MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME,
            ),
            (
                MISSION_ITEM_INT_DATA { x: 910_000_000, ..rally(1, 6.8, 79.9, 10.0) },
                MavMissionResult::MAV_MISSION_INVALID_PARAM5_X,
            ),
            (
                MISSION_ITEM_INT_DATA { y: -1_810_000_000, ..rally(1, 6.8, 79.9, 10.0) },
                MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y,
            ),
            (rally(1, 6.8, 79.9, f32::NAN), MavMissionResult::MAV_MISSION_INVALID_PARAM7),
            (rally(1, 6.8, 79.9, 40_000.0), MavMissionResult::MAV_MISSION_INVALID_PARAM7),
        ];
        for (bad, result) in cases {
            assert_eq!(to_rally(&[good.clone(), bad], Time::ZERO), Err(ItemRefused { seq: 1, result }));
        }
    }
}
