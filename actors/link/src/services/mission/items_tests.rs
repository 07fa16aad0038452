//! Each item's meaning, and the refusals measured against ArduCopter 4.7 SITL (an upload of
//! home, a waypoint and the item; the MISSION_ACK it answered is in each test's comment).

use kestrel_proto::Time;
use kestrel_proto::messages::{CameraAction, MissionItem};
use mavlink::dialects::ardupilotmega::{MISSION_ITEM_INT_DATA, MavCmd, MavFrame, MavMissionResult};

use super::{ItemRefused, to_mission};

fn at(seq: u16, command: MavCmd, params: [f32; 4], x: i32, y: i32, z: f32) -> MISSION_ITEM_INT_DATA {
    MISSION_ITEM_INT_DATA {
        seq,
        command,
        frame: if x == 0 && y == 0 {
            MavFrame::MAV_FRAME_MISSION
        } else {
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
        },
        param1: params[0],
        param2: params[1],
        param3: params[2],
        param4: params[3],
        x,
        y,
        z,
        autocontinue: 1,
        ..Default::default()
    }
}

fn plain(command: MavCmd, params: [f32; 4]) -> MISSION_ITEM_INT_DATA {
    at(2, command, params, 0, 0, 0.0)
}

/// Home, a waypoint, and `item` as item 2.
fn upload(item: MISSION_ITEM_INT_DATA) -> Result<MissionItem, ItemRefused> {
    let home = at(0, MavCmd::MAV_CMD_NAV_WAYPOINT, [0.0; 4], 67_971_000, 799_017_000, 0.0);
    let wp = at(1, MavCmd::MAV_CMD_NAV_WAYPOINT, [0.0; 4], 67_972_000, 799_017_000, 10.0);
    to_mission(&[home, wp, item], Time::ZERO).map(|m| m.items[1])
}

fn refused(item: MISSION_ITEM_INT_DATA) -> MavMissionResult {
    match upload(item) {
        Err(ItemRefused { seq: 2, result }) => result,
        other => panic!("not refused as item 2: {other:?}"),
    }
}

#[test]
fn survey_and_sdk_items_are_accepted_with_their_values() {
    use MavCmd::*;
    let loc = |command, params| at(2, command, params, 67_973_000, 799_018_000, 15.0);
    let ok = |item| upload(item).expect("accepted");
    assert_eq!(
        ok(plain(MAV_CMD_DO_JUMP, [1.0, -1.0, 0.0, 0.0])),
        MissionItem::Jump { target: 0, repeat: -1 }
    );
    assert_eq!(ok(plain(MAV_CMD_DO_JUMP, [2.0, 3.0, 0.0, 0.0])), MissionItem::Jump { target: 1, repeat: 3 });
    assert_eq!(ok(plain(MAV_CMD_NAV_DELAY, [5.0, -1.0, -1.0, -1.0])), MissionItem::Delay { duration_s: 5.0 });
    assert_eq!(
        ok(plain(MAV_CMD_CONDITION_DELAY, [4.0, 0.0, 0.0, 0.0])),
        MissionItem::ConditionDelay { duration_s: 4.0 }
    );
    assert_eq!(
        ok(plain(MAV_CMD_CONDITION_DISTANCE, [6.0, 0.0, 0.0, 0.0])),
        MissionItem::ConditionDistance { distance_m: 6.0 }
    );
    assert_eq!(
        ok(plain(MAV_CMD_CONDITION_YAW, [90.0, 10.0, -1.0, 1.0])),
        MissionItem::ConditionYaw { angle_deg: 90.0, rate_deg_s: 10.0, clockwise: false, relative: true }
    );
    assert_eq!(ok(plain(MAV_CMD_DO_SET_ROI_NONE, [0.0; 4])), MissionItem::RegionOfInterest { point: None });
    assert_eq!(
        ok(plain(MAV_CMD_DO_SET_ROI, [3.0, 0.0, 0.0, 0.0])),
        MissionItem::RegionOfInterest { point: None }
    );
    assert!(matches!(
        ok(loc(MAV_CMD_DO_SET_ROI_LOCATION, [0.0; 4])),
        MissionItem::RegionOfInterest { point: Some(p) } if (p.lat_deg - 6.7973).abs() < 1e-9
    ));
    assert_eq!(ok(plain(MAV_CMD_DO_LAND_START, [0.0; 4])), MissionItem::LandStart { point: None });
    assert!(matches!(
        ok(loc(MAV_CMD_NAV_SPLINE_WAYPOINT, [2.0, 0.0, 0.0, 0.0])),
        MissionItem::SplineWaypoint { hold_s: 2.0, .. }
    ));
    assert!(matches!(
        ok(loc(MAV_CMD_NAV_LOITER_TURNS, [2.0, 0.0, -5.0, 0.0])),
        MissionItem::LoiterTurns { point: Some(_), turns: 2.0, radius_m: -5.0 }
    ));
    // At 0, 0 a loiter is flown where the vehicle is.
    assert_eq!(ok(plain(MAV_CMD_NAV_LOITER_UNLIM, [0.0; 4])), MissionItem::LoiterUnlimited { point: None });
    assert!(matches!(
        ok(loc(MAV_CMD_NAV_LOITER_TIME, [7.0, 0.0, 0.0, 0.0])),
        MissionItem::LoiterTime { duration_s: 7.0, point: Some(_) }
    ));
    assert_eq!(
        ok(plain(MAV_CMD_DO_SET_CAM_TRIGG_DIST, [25.0, 0.0, 1.0, 0.0])),
        MissionItem::Camera { action: CameraAction::TriggerDistance { distance_m: 25.0 } }
    );
    assert_eq!(
        ok(plain(MAV_CMD_IMAGE_START_CAPTURE, [0.0, 2.0, 0.0, 0.0])),
        MissionItem::Camera { action: CameraAction::StartCapture { interval_s: 2.0, count: 0 } }
    );
    assert_eq!(
        ok(plain(MAV_CMD_IMAGE_STOP_CAPTURE, [0.0; 4])),
        MissionItem::Camera { action: CameraAction::StopCapture }
    );
    assert_eq!(
        ok(at(2, MAV_CMD_DO_DIGICAM_CONTROL, [0.0; 4], 1, 0, 0.0)),
        MissionItem::Camera { action: CameraAction::Shoot }
    );
    for (command, id) in [
        (MAV_CMD_DO_SET_SERVO, 183),
        (MAV_CMD_DO_SET_RELAY, 181),
        (MAV_CMD_DO_MOUNT_CONTROL, 205),
        (MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, 1000),
    ] {
        assert_eq!(ok(plain(command, [9.0, 1500.0, 0.0, 0.0])), MissionItem::NoOutput { command: id });
    }
}

#[test]
fn items_ardupilot_refuses_are_refused_with_its_result() {
    use MavCmd::*;
    use MavMissionResult::*;
    // ArduCopter: UNSUPPORTED.
    assert_eq!(refused(plain(MAV_CMD_CONDITION_GATE, [0.0, 1.0, 0.0, 0.0])), MAV_MISSION_UNSUPPORTED);
    // ArduCopter: ERROR for a jump to home (0) or past the last item.
    assert_eq!(refused(plain(MAV_CMD_DO_JUMP, [0.0, 2.0, 0.0, 0.0])), MAV_MISSION_ERROR);
    assert_eq!(refused(plain(MAV_CMD_DO_JUMP, [3.0, 2.0, 0.0, 0.0])), MAV_MISSION_ERROR);
    // ArduCopter: INVALID_PARAM3 for a NaN pitch rate.
    assert_eq!(
        refused(plain(MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, [-45.0, 0.0, f32::NAN, f32::NAN])),
        MAV_MISSION_INVALID_PARAM3
    );
    // Differs on purpose: ArduCopter waits for a time of day (param1 -1); the commander has
    // no UTC clock, so the item cannot be flown and is refused.
    assert_eq!(refused(plain(MAV_CMD_NAV_DELAY, [-1.0, 10.0, 0.0, 0.0])), MAV_MISSION_INVALID_PARAM1);
    assert_eq!(refused(plain(MAV_CMD_NAV_LOITER_TURNS, [0.0, 0.0, 5.0, 0.0])), MAV_MISSION_INVALID_PARAM1);
    assert_eq!(refused(plain(MAV_CMD_DO_JUMP, [1.0, -2.0, 0.0, 0.0])), MAV_MISSION_INVALID_PARAM2);
}

#[test]
fn a_jump_to_itself_is_refused_by_the_field_check() {
    let home = at(0, MavCmd::MAV_CMD_NAV_WAYPOINT, [0.0; 4], 67_971_000, 799_017_000, 0.0);
    let jump = plain(MavCmd::MAV_CMD_DO_JUMP, [2.0, 1.0, 0.0, 0.0]);
    let wp = at(1, MavCmd::MAV_CMD_NAV_WAYPOINT, [0.0; 4], 67_972_000, 799_017_000, 10.0);
    let mission = to_mission(&[home, wp, jump], Time::ZERO).expect("converted");
    let err = mission.check_fields().expect_err("refused");
    assert!(err.contains("mission item 2"), "{err}");
}
