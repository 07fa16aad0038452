//! RTL to a rally point: the target chosen when RTL starts (by a ground station or a failsafe),
//! the return altitude it raises, and the landing there.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    AltitudeFrame, BatteryStatus, Command, FlightMode, LandedState, NavState, RallyPoints,
};

use super::fixtures::{at, full_battery, hover_at, hovering, nav, point_north, trajectory};
use crate::commander::Commander;

/// A hovering commander holding one rally point `north_m` north of home, `alt_m` above it.
fn with_rally(north_m: f64, alt_m: f64) -> Commander {
    let mut c = hovering();
    let points = vec![point_north(north_m, alt_m, AltitudeFrame::RelativeHome)];
    c.on_rally(RallyPoints { time: Time(2000), points }).expect("rally");
    c
}

/// The position setpoint (NED, m) flown at `at_ned`, at `t` µs.
fn target(c: &mut Commander, t: u64, at_ned: [f64; 3]) -> [f64; 3] {
    let sp = trajectory(hover_at(c, t, at_ned));
    sp.position_ned_m.map(|v| v.expect("a position setpoint"))
}

/// The return leg's setpoint: the climb, already at its altitude at `at_ned`, ends at `t` µs and
/// the leg is flown from the next step.
fn returning(c: &mut Commander, t: u64, at_ned: [f64; 3]) -> [f64; 3] {
    hover_at(c, t, at_ned);
    target(c, t + 1000, at_ned)
}

#[test]
fn rtl_climbs_to_the_rally_points_altitude_flies_there_loiters_and_lands_there() {
    // Rally point 100 m north at 25 m (above the 15 m RTL altitude); the vehicle 90 m north at
    // 5 m: the rally point is 10 m away, home 90 m.
    let mut c = with_rally(100.0, 25.0);
    hover_at(&mut c, 3000, [90.0, 0.0, -5.0]);
    at(&mut c, 3000, Command::ReturnToLaunch).expect("rtl");
    let climb = target(&mut c, 4000, [90.0, 0.0, -5.0]);
    assert_eq!((climb[0], climb[1]), (90.0, 0.0), "climbs where it is");
    assert!((climb[2] + 25.0).abs() < 1e-9, "to the rally point's 25 m: {climb:?}");
    let ret = returning(&mut c, 5000, [90.0, 0.0, -25.0]);
    assert!((ret[0] - 100.0).abs() < 0.1 && ret[1].abs() < 0.01 && (ret[2] + 25.0).abs() < 1e-9, "{ret:?}");
    // Over the rally point and still: loiter 2 s (RTL_LOIT_TIME_S), then land there.
    let over = [ret[0], ret[1], -25.0];
    target(&mut c, 7000, over);
    let mut t = 7000;
    let mut last = c.update(Time(t)).target;
    while t < 3_000_000 {
        t += 100_000;
        last = hover_at(&mut c, t, over);
    }
    let sp = trajectory(last);
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
    assert_eq!((sp.position_ned_m[0], sp.position_ned_m[1]), (Some(over[0]), Some(over[1])));
    assert!(
        sp.position_ned_m[2].is_none() && sp.velocity_ned_m_s[2].is_some_and(|v| v > 0.0),
        "descends: {sp:?}"
    );
}

#[test]
fn rtl_returns_home_when_home_is_nearer_or_the_rally_point_is_beyond_the_limit() {
    // Home included (the default): from 30 m north, home (30 m) beats the point 70 m away.
    let mut c = with_rally(100.0, 10.0);
    hover_at(&mut c, 3000, [30.0, 0.0, -15.0]);
    at(&mut c, 3000, Command::ReturnToLaunch).expect("rtl");
    let ret = returning(&mut c, 4000, [30.0, 0.0, -15.0]);
    assert_eq!(ret, [0.0, 0.0, -15.0]);
    // Home left out: the rally point, however far home is not.
    let mut c = with_rally(100.0, 10.0);
    c.on_param("RALLY_INCL_HOME", 0.0).expect("set");
    hover_at(&mut c, 3000, [30.0, 0.0, -15.0]);
    at(&mut c, 3000, Command::ReturnToLaunch).expect("rtl");
    let ret = returning(&mut c, 4000, [30.0, 0.0, -15.0]);
    assert!((ret[0] - 100.0).abs() < 0.1, "{ret:?}");
    // 500 m away with the 0.3 km limit: home; the limit off (0): the rally point.
    for (limit_km, north_m) in [(0.3, 0.0), (0.0, 600.0)] {
        let mut c = with_rally(600.0, 10.0);
        c.on_param("RALLY_INCL_HOME", 0.0).expect("set");
        c.on_param("RALLY_LIMIT_KM", limit_km).expect("set");
        hover_at(&mut c, 3000, [100.0, 0.0, -15.0]);
        at(&mut c, 3000, Command::ReturnToLaunch).expect("rtl");
        let ret = returning(&mut c, 4000, [100.0, 0.0, -15.0]);
        assert!((ret[0] - north_m).abs() < 0.5, "limit {limit_km} km: {ret:?}");
    }
}

#[test]
fn a_battery_failsafe_rtl_flies_to_the_rally_point_too() {
    // Battery low → RTL (the default action), 90 m north: the rally point 10 m away.
    let mut c = with_rally(100.0, 10.0);
    let low = |t: u64| BatteryStatus { remaining: 0.1, ..full_battery(Time(t)) };
    c.on_nav(&NavState { position_ned_m: [90.0, 0.0, -15.0], ..nav(Time(3000), -15.0, true) });
    c.on_battery(&low(3000));
    c.update(Time(3000));
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
    let ret = returning(&mut c, 4000, [90.0, 0.0, -15.0]);
    assert!((ret[0] - 100.0).abs() < 0.1 && (ret[2] + 15.0).abs() < 1e-9, "{ret:?}");
    assert_eq!(c.landed(), LandedState::InAir);
}

#[test]
fn rally_points_cleared_or_refused_leave_rtl_going_home() {
    let mut c = with_rally(100.0, 10.0);
    let bad = vec![kestrel_proto::messages::MissionPoint {
        lat_deg: 95.0,
        ..point_north(0.0, 5.0, AltitudeFrame::RelativeHome)
    }];
    let why = c.on_rally(RallyPoints { time: Time(2500), points: bad }).expect_err("off the globe");
    assert!(why.0.contains("rally point 0"), "{why}");
    assert_eq!(c.rally_points().len(), 1, "the refused upload changed nothing");
    c.on_rally(RallyPoints { time: Time(2600), points: Vec::new() }).expect("clear");
    c.on_param("RALLY_INCL_HOME", 0.0).expect("set");
    hover_at(&mut c, 3000, [90.0, 0.0, -15.0]);
    at(&mut c, 3000, Command::ReturnToLaunch).expect("rtl");
    assert_eq!(returning(&mut c, 4000, [90.0, 0.0, -15.0]), [0.0, 0.0, -15.0]);
}
