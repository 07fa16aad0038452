//! The up- and downward rangefinders: take-off under a ceiling, landing off an obstacle's top.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    Command, FlightMode, LandedState, RangefinderOrientation, RangefinderSample, SetpointTarget,
    VerticalLimitKind,
};

use super::fixtures::{at, cmd, hovering, nav, ready};

fn rangefinder(t: u64, orientation: RangefinderOrientation, distance_m: Option<f64>) -> RangefinderSample {
    RangefinderSample { time: Time(t), orientation, distance_m, min_range_m: 0.1, max_range_m: 12.0 }
}

#[test]
fn a_takeoff_under_something_overhead_stops_the_margin_below_it_and_ends_there_in_guided() {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    cmd(&mut c, Command::Takeoff { altitude_m: 10.0 }).expect("takeoff");
    // Climbing through 2 m with a slab 6 m up: the target is 4 m, not 10 m, and the status says why.
    c.on_nav(&nav(Time(2000), -2.0, true));
    c.on_rangefinder(&rangefinder(2000, RangefinderOrientation::Up, Some(4.0)));
    let SetpointTarget::Trajectory(t) = c.update(Time(2000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m[2], Some(-4.0));
    let limit = c.status(Time(2000)).vertical_limit.expect("limited");
    assert_eq!(limit.kind, VerticalLimitKind::Overhead);
    assert!((limit.distance_m - 4.0).abs() < 1e-9);
    assert_eq!(c.mode(), FlightMode::Takeoff);
    // At 4 m under a slab seen for less than a second the take-off goes on (a passing return
    // only holds the climb); seen for a second, it is over and GUIDED holds there.
    let mut t = 2000;
    while t < 980_000 {
        t += 20_000;
        c.on_nav(&nav(Time(t), -4.0, true));
        c.on_rangefinder(&rangefinder(t, RangefinderOrientation::Up, Some(2.0)));
        c.update(Time(t));
        assert_eq!(c.mode(), FlightMode::Takeoff, "{t}");
    }
    t += 20_000;
    c.on_nav(&nav(Time(t), -4.0, true));
    c.on_rangefinder(&rangefinder(t, RangefinderOrientation::Up, Some(2.0)));
    c.update(Time(t));
    assert_eq!(c.mode(), FlightMode::Guided);
    // A GUIDED target above the slab is held below it too; a stale reading no longer limits.
    at(&mut c, t, Command::GotoNed { position_ned_m: [0.0, 0.0, -12.0] }).expect("goto");
    c.on_nav(&nav(Time(t), -4.0, true));
    let SetpointTarget::Trajectory(sp) = c.update(Time(t)).target else { panic!("trajectory expected") };
    assert_eq!(sp.position_ned_m[2], Some(-4.0));
    let later = t + 600_000;
    c.on_nav(&nav(Time(later), -4.0, true));
    let SetpointTarget::Trajectory(sp) = c.update(Time(later)).target else { panic!("trajectory expected") };
    assert_eq!(sp.position_ned_m[2], Some(-12.0));
    assert_eq!(c.status(Time(later)).vertical_limit, None);
}

#[test]
fn a_landing_over_an_obstacle_top_holds_above_it_and_moves_off_before_descending() {
    let mut c = hovering();
    // 10 m up, facing north, over a roof 4 m high.
    c.on_nav(&nav(Time(3000), -10.0, true));
    cmd(&mut c, Command::Land).expect("land");
    c.on_rangefinder(&rangefinder(3000, RangefinderOrientation::Down, Some(6.0)));
    let SetpointTarget::Trajectory(t) = c.update(Time(3000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m, [Some(-2.0), Some(0.0), Some(-10.0)], "{t:?}");
    assert_eq!(c.status(Time(3000)).vertical_limit.map(|l| l.kind), Some(VerticalLimitKind::ObstacleBelow));
    // Moved 2 m back, the ground 10 m below: one step more, then the descent.
    let mut over_ground = nav(Time(4000), -10.0, true);
    over_ground.position_ned_m = [-2.0, 0.0, -10.0];
    c.on_nav(&over_ground);
    c.on_rangefinder(&rangefinder(4000, RangefinderOrientation::Down, Some(10.0)));
    let SetpointTarget::Trajectory(t) = c.update(Time(4000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m, [Some(-4.0), Some(0.0), Some(-10.0)], "{t:?}");
    over_ground.time = Time(5000);
    over_ground.position_ned_m = [-4.0, 0.0, -10.0];
    c.on_nav(&over_ground);
    c.on_rangefinder(&rangefinder(5000, RangefinderOrientation::Down, Some(10.0)));
    let SetpointTarget::Trajectory(t) = c.update(Time(5000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m, [Some(-4.0), Some(0.0), None], "{t:?}");
    assert!(t.velocity_ned_m_s[2].is_some_and(|v| v > 0.0), "{t:?}");
    assert_eq!(c.status(Time(5000)).vertical_limit, None);
}

#[test]
fn without_a_fresh_rangefinder_reading_a_takeoff_climbs_as_before() {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    cmd(&mut c, Command::Takeoff { altitude_m: 10.0 }).expect("takeoff");
    // A reading older than timeout_s says nothing.
    c.on_rangefinder(&rangefinder(1000, RangefinderOrientation::Up, Some(1.0)));
    c.on_nav(&nav(Time(600_000), -2.0, true));
    let SetpointTarget::Trajectory(t) = c.update(Time(600_000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m[2], Some(-10.0));
}

#[test]
fn holding_over_a_top_is_no_touchdown_and_a_silent_sensor_then_lands_where_it_is() {
    let mut c = hovering();
    c.on_nav(&nav(Time(3000), -10.0, true));
    cmd(&mut c, Command::Land).expect("land");
    let mut t = 3000;
    // Still 10 m up over a 4 m top for 3 s (the detector needs 1 s of stillness): armed, holding.
    while t < 3_000_000 {
        t += 2500;
        c.on_nav(&nav(Time(t), -10.0, true));
        c.on_rangefinder(&rangefinder(t, RangefinderOrientation::Down, Some(6.0)));
        c.update(Time(t));
    }
    assert!(c.armed(), "disarmed while holding over the top");
    assert_eq!(c.landed(), LandedState::InAir);
    // The sensor falls silent: the search ends and the descent starts where the vehicle is.
    t += 600_000;
    c.on_nav(&nav(Time(t), -10.0, true));
    let SetpointTarget::Trajectory(sp) = c.update(Time(t)).target else { panic!("trajectory expected") };
    assert!(sp.velocity_ned_m_s[2].is_some_and(|v| v > 0.0), "{sp:?}");
    c.update(Time(t));
    assert_eq!(c.landed(), LandedState::Landing);
}

#[test]
fn a_takeoff_with_no_room_overhead_stays_on_the_ground() {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    cmd(&mut c, Command::Takeoff { altitude_m: 10.0 }).expect("takeoff");
    // A surface 2.5 m above the vehicle on the ground leaves 0.5 m under the margin.
    c.on_rangefinder(&rangefinder(1000, RangefinderOrientation::Up, Some(2.5)));
    assert_eq!(c.update(Time(1000)).target, SetpointTarget::MotorsOff);
    assert_eq!(c.mode(), FlightMode::Takeoff);
    assert_eq!(c.status(Time(1000)).vertical_limit.map(|l| l.kind), Some(VerticalLimitKind::Overhead));
}
