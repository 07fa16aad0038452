//! The geofence: the polygon, its breach in flight, and its switch.

use kestrel_proto::Time;
use kestrel_proto::messages::{Command, FailsafeCause, FlightMode};

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
