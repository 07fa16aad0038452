//! Missions: completion, the current item, uploads while flown, pause, continue and speed.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    AltitudeFrame, Command, FlightMode, Mission, MissionItem, MissionPoint, SetpointTarget,
};

use super::fixtures::{at, cmd, hover_at, nav, point_north, ready, three_waypoints, trajectory};
use crate::commander::Commander;

#[test]
fn a_mission_ending_in_a_land_item_completes_on_touchdown() {
    let mut c = ready(true);
    let point =
        MissionPoint { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 5.0, frame: AltitudeFrame::RelativeHome };
    let mission = Mission {
        time: Time::ZERO,
        items: vec![MissionItem::Takeoff { point }, MissionItem::Land { point }],
        cruise_speed_m_s: 5.0,
    };
    c.on_mission(mission).expect("mission");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    c.on_nav(&nav(Time(2000), -5.0, true));
    c.update(Time(2000));
    let mut t = 2000;
    while c.armed() && t < 5_000_000 {
        t += 2500;
        c.on_nav(&nav(Time(t), 0.0, true));
        c.update(Time(t));
    }
    let progress = c.status(Time(t)).mission;
    assert!(!c.armed());
    assert!(progress.completed && progress.reached == 2, "{progress:?}");
}

fn north_target(target: SetpointTarget) -> f64 {
    trajectory(target).position_ned_m[0].expect("north target")
}

#[test]
fn a_running_mission_jumps_to_the_current_item_and_completes_from_there() {
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    let first = north_target(hover_at(&mut c, 2000, [0.0, 0.0, -10.0]));
    assert!((first - 20.0).abs() < 0.5, "{first}");
    at(&mut c, 2000, Command::SetMissionCurrent { index: 2 }).expect("jump");
    assert_eq!(c.mode(), FlightMode::Auto);
    let jumped = north_target(hover_at(&mut c, 3000, [0.0, 0.0, -10.0]));
    assert!((jumped - 60.0).abs() < 0.5, "{jumped}");
    assert_eq!(c.status(Time(3000)).mission.current, 2);
    // Reaching the last item completes the mission although two were skipped.
    hover_at(&mut c, 4000, [jumped, 0.0, -10.0]);
    let progress = c.status(Time(4000)).mission;
    assert!(progress.completed, "{progress:?}");
    assert_eq!((progress.reached, progress.last_reached), (1, Some(2)));
}

#[test]
fn outside_auto_the_current_item_is_where_the_next_run_starts() {
    let mut c = ready(true);
    assert!(cmd(&mut c, Command::SetMissionCurrent { index: 0 }).expect_err("none").contains("no mission"));
    c.on_mission(three_waypoints()).expect("mission");
    let why = cmd(&mut c, Command::SetMissionCurrent { index: 3 }).expect_err("out of range");
    assert!(why.contains("past the last"), "{why}");
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::SetMissionCurrent { index: 1 }).expect("current");
    assert_eq!(c.mode(), FlightMode::PosHold, "setting the item must not start the mission");
    assert_eq!(c.status(Time(1000)).mission.current, 1);
    // AUTO then arming (what `--auto` does) both start a run: it still begins at item 1.
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    let target = north_target(hover_at(&mut c, 2000, [0.0, 0.0, -10.0]));
    assert!((target - 40.0).abs() < 0.5, "{target}");
    // Once that run has started, a later one starts over from the first item.
    at(&mut c, 2000, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    at(&mut c, 2000, Command::SetMode(FlightMode::Auto)).expect("auto again");
    let target = north_target(hover_at(&mut c, 3000, [0.0, 0.0, -10.0]));
    assert!((target - 20.0).abs() < 0.5, "{target}");
}

/// Waypoints at 10 m, `north_m` north of home each.
fn waypoints_north(north_m: &[f64]) -> Mission {
    let items = north_m
        .iter()
        .map(|&n| MissionItem::Waypoint {
            point: point_north(n, 10.0, AltitudeFrame::RelativeHome),
            acceptance_radius_m: 1.0,
            hold_s: 0.0,
        })
        .collect();
    Mission { time: Time::ZERO, items, cruise_speed_m_s: 5.0 }
}

/// three_waypoints() in AUTO, item 0 (20 m north) reached at t = 3 ms: item 1 is flown.
fn flying_item_1() -> Commander {
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    hover_at(&mut c, 2000, [0.0, 0.0, -10.0]);
    hover_at(&mut c, 3000, [20.0, 0.0, -10.0]);
    let progress = c.status(Time(3000)).mission;
    assert_eq!((progress.current, progress.reached, progress.last_reached), (1, 1, Some(0)));
    c
}

#[test]
fn a_mission_uploaded_in_auto_is_flown_from_the_same_item() {
    let mut c = flying_item_1();
    // A longer mission: item 1 is now 50 m north, and is flown at once (ArduCopter restarts its
    // current command from the new mission: tests/gcs_mission_change.rs shows it in SITL).
    c.on_mission(waypoints_north(&[25.0, 50.0, 75.0, 100.0])).expect("replaced in flight");
    assert_eq!(c.mode(), FlightMode::Auto);
    let progress = c.status(Time(3000)).mission;
    assert_eq!((progress.current, progress.total, progress.reached), (1, 4, 1), "{progress:?}");
    assert!(!progress.completed);
    let target = north_target(hover_at(&mut c, 4000, [20.0, 0.0, -10.0]));
    assert!((target - 50.0).abs() < 0.5, "{target}");
    // Reaching it counts on from the items reached before (MISSION_ITEM_REACHED seq 2).
    hover_at(&mut c, 5000, [target, 0.0, -10.0]);
    let progress = c.status(Time(5000)).mission;
    assert_eq!((progress.current, progress.reached, progress.last_reached), (2, 2, Some(1)));
    let target = north_target(hover_at(&mut c, 6000, [target, 0.0, -10.0]));
    assert!((target - 75.0).abs() < 0.5, "{target}");
}

#[test]
fn a_shorter_mission_uploaded_in_auto_is_flown_from_its_last_item() {
    let mut c = flying_item_1();
    c.on_mission(waypoints_north(&[35.0])).expect("replaced in flight");
    let progress = c.status(Time(3000)).mission;
    assert_eq!((progress.current, progress.total), (0, 1), "{progress:?}");
    let target = north_target(hover_at(&mut c, 4000, [20.0, 0.0, -10.0]));
    assert!((target - 35.0).abs() < 0.5, "{target}");
    hover_at(&mut c, 5000, [35.0, 0.0, -10.0]);
    let progress = c.status(Time(5000)).mission;
    assert!(progress.completed, "{progress:?}");
    assert_eq!((progress.reached, progress.last_reached), (2, Some(0)));
    assert_eq!(c.mode(), FlightMode::Auto, "a finished mission holds in AUTO");
}

#[test]
fn a_mission_refused_in_auto_leaves_the_old_one_flown_and_one_that_cannot_be_flown_pauses() {
    let mut c = flying_item_1();
    let mut bad = waypoints_north(&[25.0, 50.0]);
    bad.cruise_speed_m_s = f64::NAN;
    let why = c.on_mission(bad).expect_err("not a number").0;
    assert!(why.contains("cruise speed"), "{why}");
    let target = north_target(hover_at(&mut c, 4000, [20.0, 0.0, -10.0]));
    assert!((target - 40.0).abs() < 0.5, "the old mission's item 1 is still flown: {target}");
    assert_eq!(c.status(Time(4000)).mission.total, 3);
    // Well-formed but below home: kept (what the ground station holds), said, and not flown.
    let mut below = waypoints_north(&[25.0, 50.0]);
    below.items[1] = MissionItem::Waypoint {
        point: point_north(50.0, -5.0, AltitudeFrame::RelativeHome),
        acceptance_radius_m: 1.0,
        hold_s: 0.0,
    };
    c.on_mission(below).expect("kept");
    let status = c.status(Time(4000));
    assert!(status.last_refusal.as_deref().is_some_and(|r| r.contains("mission item 2")), "{status:?}");
    assert_eq!((status.mission.current, status.mission.total), (1, 2));
    let held = trajectory(hover_at(&mut c, 5000, [22.0, 0.0, -10.0]));
    assert_eq!(held.position_ned_m, [Some(22.0), Some(0.0), Some(-10.0)], "paused where it was");
    assert_eq!(c.mode(), FlightMode::Auto);
}

#[test]
fn an_empty_mission_clears_on_the_ground_and_is_refused_while_flown() {
    let empty = || Mission { time: Time::ZERO, items: Vec::new(), cruise_speed_m_s: 5.0 };
    let mut c = flying_item_1();
    let why = c.on_mission(empty()).expect_err("flying it").0;
    assert!(why.contains("clear refused"), "{why}");
    assert_eq!(c.status(Time(3000)).mission.total, 3, "the flown mission stays");
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    c.on_mission(empty()).expect("cleared");
    assert_eq!(c.status(Time(1000)).mission.total, 0);
    let why = cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect_err("nothing to fly");
    assert!(why.contains("mission"), "{why}");
}

#[test]
fn a_paused_mission_holds_where_it_stopped_and_continues_to_the_same_item() {
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    assert!(at(&mut c, 1000, Command::PauseMission).is_err(), "nothing to pause outside AUTO");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    assert!((north_target(hover_at(&mut c, 2000, [0.0, 0.0, -10.0])) - 20.0).abs() < 0.5);
    at(&mut c, 2000, Command::PauseMission).expect("pause");
    let held = trajectory(hover_at(&mut c, 3000, [5.0, 0.0, -10.0]));
    assert_eq!(held.position_ned_m, [Some(5.0), Some(0.0), Some(-10.0)], "holds where it was paused");
    assert_eq!(c.mode(), FlightMode::Auto, "still AUTO, as ArduCopter's pause");
    at(&mut c, 3000, Command::ContinueMission).expect("continue");
    let resumed = north_target(hover_at(&mut c, 4000, [5.0, 0.0, -10.0]));
    assert!((resumed - 20.0).abs() < 0.5, "the same item: {resumed}");
}

#[test]
fn change_speed_sets_the_missions_leg_speed_within_the_limit() {
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    assert!(at(&mut c, 1000, Command::ChangeSpeed { speed_m_s: 3.0 }).is_err(), "AUTO only");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    let speed = |c: &mut Commander, t| trajectory(hover_at(c, t, [0.0, 0.0, -10.0])).max_horizontal_speed_m_s;
    assert_eq!(speed(&mut c, 2000), Some(5.0), "the mission's cruise speed");
    at(&mut c, 2000, Command::ChangeSpeed { speed_m_s: 2.5 }).expect("change");
    assert_eq!(speed(&mut c, 3000), Some(2.5));
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 50.0] {
        assert!(at(&mut c, 3000, Command::ChangeSpeed { speed_m_s: bad }).is_err(), "{bad}");
    }
    assert_eq!(speed(&mut c, 4000), Some(2.5), "a refused change keeps the speed");
}

#[test]
fn do_land_start_flies_the_nearest_landing_sequence_in_auto() {
    let mut c = super::fixtures::hovering();
    let why = at(&mut c, 2100, Command::LandStart).expect_err("no mission");
    assert!(why.contains("mission"), "{why}");
    c.on_mission(three_waypoints()).expect("uploaded");
    let why = at(&mut c, 2200, Command::LandStart).expect_err("no DO_LAND_START");
    assert_eq!(why, "Mode change to AUTO RTL failed: No landing sequence found");
    assert_eq!(c.mode(), FlightMode::PosHold, "nothing changed");
    let wp = |north_m| MissionItem::Waypoint {
        point: point_north(north_m, 10.0, AltitudeFrame::RelativeHome),
        acceptance_radius_m: 1.0,
        hold_s: 0.0,
    };
    let landing = point_north(10.0, 0.0, AltitudeFrame::RelativeHome);
    let mission = Mission {
        time: Time::ZERO,
        items: vec![
            wp(20.0),
            wp(40.0),
            MissionItem::LandStart { point: None },
            wp(10.0),
            MissionItem::Land { point: landing },
        ],
        cruise_speed_m_s: 5.0,
    };
    c.on_mission(mission).expect("uploaded");
    at(&mut c, 2300, Command::LandStart).expect("a landing sequence");
    assert_eq!(c.mode(), FlightMode::Auto);
    hover_at(&mut c, 2400, [0.0, 0.0, -5.0]);
    let current = c.status(kestrel_proto::Time(2400)).mission.current;
    assert!(current >= 3, "flying the sequence after DO_LAND_START, at {current}");
}
