//! The geofence: the polygon, uploaded zones, breach, action and recovery, the floor, the
//! parameters and the switch.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    Command, FENCE_ALT_MAX, FENCE_ALT_MIN, FENCE_CIRCLE, FENCE_POLYGON, FailsafeCause, FenceKind, FencePlan,
    FenceZone, FlightMode,
};

use super::fixtures::{at, cmd, full_battery, hover_at, hovering, nav};
use crate::commander::{Commander, CommanderParams};

#[test]
fn polygon_fence_inclusion() {
    let square = [[-10.0, -10.0], [-10.0, 10.0], [10.0, 10.0], [10.0, -10.0]];
    assert!(crate::commander::fence_zones::inside_polygon(&square, 0.0, 0.0));
    assert!(crate::commander::fence_zones::inside_polygon(&square, 9.9, -9.9));
    assert!(!crate::commander::fence_zones::inside_polygon(&square, 10.1, 0.0));
    assert!(!crate::commander::fence_zones::inside_polygon(&square, 0.0, -30.0));
    assert!(crate::commander::fence_zones::inside_polygon(&[], 1e6, 1e6), "no polygon, no limit");
}

#[test]
fn leaving_the_polygon_fence_in_flight_triggers_its_failsafe() {
    let params = CommanderParams {
        geofence: crate::commander::GeofenceParams {
            polygon: vec![[6.7970, 79.9016], [6.7970, 79.9018], [6.7972, 79.9018], [6.7972, 79.9016]],
            ..crate::commander::GeofenceParams::default()
        },
        ..CommanderParams::default()
    };
    let mut c = Commander::new(params).expect("valid");
    c.on_nav(&nav(Time(1000), 0.0, true));
    c.on_battery(&full_battery(Time(1000)));
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("inside the fence");
    let mut outside = nav(Time(2000), -5.0, true);
    outside.position_ned_m = [30.0, 0.0, -5.0];
    c.on_nav(&outside);
    c.update(Time(2000));
    let status = c.status(Time(2000));
    assert_eq!(
        status.failsafe.map(|f| f.cause),
        Some(kestrel_proto::messages::FailsafeCause::GeofenceBreach)
    );
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
}

#[test]
fn the_geofence_switch_is_honoured_in_flight() {
    let mut c = hovering();
    assert!(c.status(Time(2000)).geofence_enabled);
    at(&mut c, 2000, Command::SetGeofence { enabled: false }).expect("fence off");
    hover_at(&mut c, 3000, [400.0, 0.0, -5.0]);
    let status = c.status(Time(3000));
    assert!(!status.geofence_enabled);
    assert_eq!(status.failsafe, None, "a disabled fence is not breached");
    assert_eq!(c.mode(), FlightMode::PosHold);
    // Switched on again outside it: the breach fires at once.
    at(&mut c, 3000, Command::SetGeofence { enabled: true }).expect("fence on");
    hover_at(&mut c, 4000, [400.0, 0.0, -5.0]);
    assert_eq!(c.status(Time(4000)).failsafe.map(|f| f.cause), Some(FailsafeCause::GeofenceBreach));
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
}

/// A zone placed from NED metres around the fixtures' origin, for readable tests.
fn deg(north_m: f64, east_m: f64) -> [f64; 2] {
    let frame = kestrel_proto::geo::LocalFrame::new(super::fixtures::ORIGIN);
    let g = frame.to_geodetic([north_m, east_m, 0.0]);
    [g.lat_deg, g.lon_deg]
}

/// An inclusion square 100 m about the origin and an exclusion circle of 10 m at 40 m north.
fn uploaded() -> FencePlan {
    FencePlan {
        time: Time(1000),
        zones: vec![
            FenceZone::Polygon {
                kind: FenceKind::Inclusion,
                vertices_deg: vec![
                    deg(-100.0, -100.0),
                    deg(100.0, -100.0),
                    deg(100.0, 100.0),
                    deg(-100.0, 100.0),
                ],
            },
            FenceZone::Circle { kind: FenceKind::Exclusion, center_deg: deg(40.0, 0.0), radius_m: 10.0 },
        ],
    }
}

fn guided_hover() -> Commander {
    let mut c = hovering();
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    c
}

#[test]
fn an_uploaded_fence_refuses_targets_beyond_it_and_a_cleared_one_does_not() {
    let mut c = guided_hover();
    c.on_fence(uploaded());
    let goto =
        |c: &mut Commander, n: f64, e: f64| at(c, 2100, Command::GotoNed { position_ned_m: [n, e, -10.0] });
    goto(&mut c, 60.0, 60.0).expect("inside the square, outside the circle");
    let why = goto(&mut c, 150.0, 0.0).expect_err("outside the square");
    assert!(why.contains("geofence polygon"), "{why}");
    let why = goto(&mut c, 42.0, 3.0).expect_err("inside the exclusion circle");
    assert!(why.contains("geofence polygon"), "{why}");
    // Within 300 m (the circle) but above the 120 m ceiling.
    let why =
        at(&mut c, 2100, Command::GotoNed { position_ned_m: [10.0, 0.0, -150.0] }).expect_err("ceiling");
    assert!(why.contains("above the 120 m geofence"), "{why}");
    // FENCE_TYPE without the polygon bit: the zones no longer bound targets.
    c.on_param("FENCE_TYPE", 3.0).expect("ceiling and circle");
    goto(&mut c, 150.0, 0.0).expect("polygons not enforced");
    c.on_param("FENCE_TYPE", 7.0).expect("back");
    c.on_fence(FencePlan { time: Time(2200), zones: Vec::new() });
    goto(&mut c, 150.0, 0.0).expect("cleared");
}

#[test]
fn an_exclusion_zone_breach_returns_counts_once_and_clears_back_outside_it() {
    let mut c = hovering();
    c.on_fence(uploaded());
    hover_at(&mut c, 3000, [20.0, 0.0, -10.0]);
    assert_eq!(c.status(Time(3000)).fence.breach_count, 0);
    hover_at(&mut c, 4000, [35.0, 0.0, -10.0]);
    let s = c.status(Time(4000));
    assert_eq!(s.failsafe.map(|f| f.cause), Some(FailsafeCause::GeofenceBreach));
    assert_eq!(
        (s.fence.breaches, s.fence.breach_count, s.fence.breach_time),
        (FENCE_POLYGON, 1, Some(Time(4000)))
    );
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch, "FENCE_ACTION 1: RTL");
    // Still inside a moment later: the same breach, not a new one.
    hover_at(&mut c, 5000, [36.0, 0.0, -10.0]);
    assert_eq!(c.status(Time(5000)).fence.breach_count, 1);
    // Back out of the circle (RTL flies home) during the 10 s manual recovery the RTL's mode
    // change started: nothing changes, as ArduCopter's FENCE_STATUS stays breached.
    hover_at(&mut c, 6000, [25.0, 0.0, -10.0]);
    assert_eq!(c.status(Time(6000)).fence.breaches, FENCE_POLYGON);
    // After it: cleared, announced, the count kept.
    fly_at(&mut c, 10.1, [25.0, 0.0, -10.0]);
    let s = c.status(Time(10_100_000));
    assert_eq!(s.failsafe, None);
    assert_eq!((s.fence.breaches, s.fence.breach_count), (0, 1));
    assert_eq!(s.last_refusal.as_deref(), Some("Fence breach cleared"));
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch, "the RTL it started goes on, as ArduCopter's");
    // A second entry is a second breach.
    fly_at(&mut c, 10.2, [40.0, 0.0, -10.0]);
    assert_eq!(c.status(Time(10_200_000)).fence.breach_count, 2);
}

#[test]
fn each_fence_action_does_what_arducopter_does() {
    // 4: brake, then hold position; 2: land; 0: report only.
    for (code, mode) in [(4.0, FlightMode::PosHold), (2.0, FlightMode::Land), (0.0, FlightMode::Guided)] {
        let mut c = guided_hover();
        c.on_param("FENCE_ACTION", code).expect("taken");
        hover_at(&mut c, 3000, [0.0, 0.0, -125.0]);
        assert_eq!(c.status(Time(3000)).fence.breaches, FENCE_ALT_MAX, "action {code}");
        assert_eq!(c.mode(), mode, "action {code}");
    }
    // 3 and 5 (SmartRTL) are refused: there is no SmartRTL to try.
    assert!(guided_hover().on_param("FENCE_ACTION", 3.0).is_err());
    // More than 100 m beyond the ceiling or the circle, RTL gives way to a landing.
    let mut c = guided_hover();
    hover_at(&mut c, 3000, [0.0, 0.0, -221.0]);
    assert_eq!(c.mode(), FlightMode::Land, "101 m above the ceiling");
    let mut c = guided_hover();
    hover_at(&mut c, 3000, [0.0, 0.0, -219.0]);
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch, "99 m above it");
}

#[test]
fn the_floor_counts_once_climbed_above_and_never_while_landing() {
    let mut c = Commander::new(CommanderParams {
        geofence: crate::commander::GeofenceParams {
            types: FENCE_ALT_MAX | FENCE_CIRCLE | FENCE_POLYGON | FENCE_ALT_MIN,
            min_altitude_m: 8.0,
            ..crate::commander::GeofenceParams::default()
        },
        ..CommanderParams::default()
    })
    .expect("valid");
    c.on_nav(&nav(Time(1000), 0.0, true));
    c.on_battery(&full_battery(Time(1000)));
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arms below the floor");
    hover_at(&mut c, 2000, [0.0, 0.0, -5.0]);
    assert_eq!(c.status(Time(2000)).fence.breaches, 0, "not yet above the floor");
    hover_at(&mut c, 3000, [0.0, 0.0, -12.0]);
    hover_at(&mut c, 4000, [0.0, 0.0, -6.0]);
    assert_eq!(c.status(Time(4000)).fence.breaches, FENCE_ALT_MIN);
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
    at(&mut c, 4000, Command::SetMode(FlightMode::Land)).expect("land");
    // Once the manual recovery the mode changes started is over (10 s).
    fly_at(&mut c, 10.1, [0.0, 0.0, -3.0]);
    assert_eq!(c.status(Time(10_100_000)).fence.breaches, 0, "landing: the floor is not judged");
}

#[test]
fn fence_enable_is_the_switch_and_the_pre_arm_checks_are_arducopters() {
    let mut c = super::fixtures::ready(true);
    c.on_param("FENCE_ENABLE", 0.0).expect("off");
    assert!(!c.status(Time(1000)).geofence_enabled);
    c.on_param("FENCE_ENABLE", 1.0).expect("on");
    assert!(c.status(Time(1000)).geofence_enabled);
    c.on_param("FENCE_MARGIN", 20.0).expect("in range");
    c.on_param("FENCE_TYPE", 15.0).expect("all four");
    c.on_param("FENCE_ALT_MIN", 0.0).expect("in range");
    c.on_param("FENCE_ALT_MAX", 30.0).expect("in range");
    let why = cmd(&mut c, Command::Arm).expect_err("margin too big for the band");
    assert!(why.contains("FENCE_MARGIN too big"), "{why}");
    c.on_param("FENCE_MARGIN", 2.0).expect("in range");
    assert!(c.on_param("FENCE_TYPE", 16.0).is_err(), "no such bit");
    assert!(c.on_param("FENCE_TYPE", 2.5).is_err(), "not a bit mask");
    cmd(&mut c, Command::Arm).expect("arms");
}

#[test]
fn a_fence_uploaded_before_the_origin_is_placed_when_it_is_known() {
    let mut c = Commander::new(CommanderParams::default()).expect("valid");
    c.on_fence(uploaded());
    c.on_nav(&nav(Time(1000), 0.0, true));
    c.on_battery(&full_battery(Time(1000)));
    hover_at(&mut c, 1500, [150.0, 0.0, 0.0]);
    let why = cmd(&mut c, Command::Arm).expect_err("outside the square");
    assert!(why.contains("outside the geofence"), "{why}");
}

/// The vehicle at `pos` (NED, m) at `t_s` seconds, the battery fresh.
fn fly_at(c: &mut Commander, t_s: f64, pos: [f64; 3]) {
    let t = (t_s * 1e6) as u64;
    c.on_battery(&full_battery(Time(t)));
    hover_at(c, t, pos);
}

#[test]
fn a_vehicle_staying_outside_is_breached_again_20_m_further() {
    // FENCE_ACTION 4 (brake and hold): the vehicle stays where the breach found it.
    let mut c = guided_hover();
    c.on_param("FENCE_ACTION", 4.0).expect("taken");
    fly_at(&mut c, 1.0, [0.0, 0.0, -125.0]);
    assert_eq!((c.status(Time(1_000_000)).fence.breach_count, c.mode()), (1, FlightMode::PosHold));
    // The hold's mode change started a 10 s manual recovery: nothing new counts in it.
    fly_at(&mut c, 5.0, [0.0, 0.0, -150.0]);
    assert_eq!(c.status(Time(5_000_000)).fence.breach_count, 1);
    // After it, still within 20 m of where the breach was counted: the same breach.
    fly_at(&mut c, 11.5, [0.0, 0.0, -144.0]);
    assert_eq!(c.status(Time(11_500_000)).fence.breach_count, 1);
    // 20 m above it: a new breach, counted, and the action taken again (the same mode: no
    // new recovery).
    fly_at(&mut c, 12.0, [0.0, 0.0, -145.5]);
    assert_eq!(c.status(Time(12_000_000)).fence.breach_count, 2);
    // The backup moved up with it: the next one is 20 m above 145.5 m.
    fly_at(&mut c, 13.0, [0.0, 0.0, -160.0]);
    assert_eq!(c.status(Time(13_000_000)).fence.breach_count, 2);
    // Beyond the circle too: a new breach of another fence counts on its own.
    fly_at(&mut c, 14.0, [310.0, 0.0, -160.0]);
    assert_eq!(c.status(Time(14_000_000)).fence.breach_count, 3);
    fly_at(&mut c, 15.0, [329.0, 0.0, -160.0]);
    assert_eq!(c.status(Time(15_000_000)).fence.breach_count, 3);
    fly_at(&mut c, 16.0, [331.0, 0.0, -160.0]);
    assert_eq!(c.status(Time(16_000_000)).fence.breach_count, 4);
    assert_eq!(c.mode(), FlightMode::PosHold);
}

#[test]
fn a_pilot_taking_control_in_breach_has_ten_seconds() {
    let mut c = guided_hover();
    fly_at(&mut c, 1.0, [0.0, 0.0, -125.0]);
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch, "FENCE_ACTION 1");
    // The pilot takes the vehicle back while still above the ceiling: allowed, as ArduCopter.
    fly_at(&mut c, 1.5, [0.0, 0.0, -125.0]);
    at(&mut c, 1_500_000, Command::SetMode(FlightMode::Guided)).expect("manual recovery");
    // For 10 s no new breach counts, even 30 m further up.
    fly_at(&mut c, 5.0, [0.0, 0.0, -155.0]);
    fly_at(&mut c, 11.4, [0.0, 0.0, -155.0]);
    assert_eq!((c.status(Time(11_400_000)).fence.breach_count, c.mode()), (1, FlightMode::Guided));
    // After them, beyond the backup fence: breached anew, the action taken again.
    fly_at(&mut c, 11.6, [0.0, 0.0, -155.0]);
    assert_eq!(c.status(Time(11_600_000)).fence.breach_count, 2);
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
}

#[test]
fn rtl_returns_under_the_ceiling_and_never_descends_to_it() {
    let mut c = hovering();
    c.on_param("FENCE_ALT_MAX", 14.0).expect("in range");
    let home = c.home_ned().expect("home");
    // From 5 m: RTL_ALT 15 m capped at 14 - 2 (FENCE_MARGIN) = 12 m above home.
    let low = nalgebra::Vector3::new(30.0, 0.0, home.z - 5.0);
    assert!((c.rtl_down_m(&low, &home, &home) - (home.z - 12.0)).abs() < 1e-9);
    // From 20 m, above the ceiling: home at 20 m, no descent on the way.
    let high = nalgebra::Vector3::new(30.0, 0.0, home.z - 20.0);
    assert!((c.rtl_down_m(&high, &home, &home) - high.z).abs() < 1e-9);
    // The ceiling not enforced (FENCE_TYPE without bit 1, or the fence off): RTL_ALT.
    c.on_param("FENCE_TYPE", 6.0).expect("circle and polygons");
    assert!((c.rtl_down_m(&low, &home, &home) - (home.z - 15.0)).abs() < 1e-9);
    c.on_param("FENCE_TYPE", 7.0).expect("back");
    c.on_param("FENCE_ENABLE", 0.0).expect("off");
    assert!((c.rtl_down_m(&low, &home, &home) - (home.z - 15.0)).abs() < 1e-9);
}

#[test]
fn fence_total_counts_vertices_and_circles_as_arducopter() {
    use crate::commander::geofence::fence_total;
    assert_eq!(fence_total(None), 0);
    assert_eq!(fence_total(Some(&uploaded())), 4 + 1 + 2, "a square and a circle");
    let circle = FenceZone::Circle { kind: FenceKind::Inclusion, center_deg: deg(0.0, 0.0), radius_m: 50.0 };
    let circles = |n| FencePlan { time: Time(1000), zones: vec![circle.clone(); n] };
    assert_eq!(fence_total(Some(&circles(2))), 0, "fewer than 3 items");
    assert_eq!(fence_total(Some(&circles(3))), 5);
    let mut c = hovering();
    c.on_fence(uploaded());
    let decl = c.param_decl("commander", false, Time(3000));
    let total = decl.params.iter().find(|p| p.name == "FENCE_TOTAL").expect("declared");
    assert_eq!((total.value, total.min, total.max), (7.0, 7.0, 7.0), "only its own value");
    c.on_fence(FencePlan { time: Time(4000), zones: Vec::new() });
    let decl = c.param_decl("commander", false, Time(4000));
    assert_eq!(decl.params.iter().find(|p| p.name == "FENCE_TOTAL").map(|p| p.value), Some(0.0));
}
