//! MAV_CMD_DO_SET_HOME: home moved in flight or to a point, and what cannot be placed.

use kestrel_proto::Time;
use kestrel_proto::messages::{AltitudeFrame, Command, FlightMode, MissionPoint, VehicleCommand};

use super::fixtures::{at, cmd, hover_at, hovering, point_north, ready, trajectory};

#[test]
fn set_home_here_in_flight_moves_home_and_rtl_returns_there() {
    let mut c = hovering();
    let armed_home = c.status(Time(2000)).home.expect("home set at arming");
    assert_eq!(armed_home.position_ned_m, [0.0, 0.0, 0.0]);
    hover_at(&mut c, 3000, [20.0, 10.0, -5.0]);
    assert_eq!(at(&mut c, 3000, Command::SetHome { point: None }), Ok(()));
    let home = c.status(Time(3000)).home.expect("home");
    assert_eq!(home.position_ned_m, [20.0, 10.0, -5.0]);
    assert!(home.revision > armed_home.revision);
    // RTL from 50 m north of the new home climbs to 15 m above it, then heads for it.
    hover_at(&mut c, 4000, [70.0, 10.0, -5.0]);
    at(&mut c, 4000, Command::ReturnToLaunch).expect("rtl");
    hover_at(&mut c, 5000, [70.0, 10.0, -20.0]);
    let sp = trajectory(hover_at(&mut c, 6000, [70.0, 10.0, -20.0]));
    assert_eq!(sp.position_ned_m, [Some(20.0), Some(10.0), Some(-20.0)]);
}

#[test]
fn set_home_to_a_point_places_the_geofence_around_it_and_survives_arming() {
    let mut c = ready(true);
    let far = point_north(400.0, 20.0, AltitudeFrame::Amsl);
    assert_eq!(cmd(&mut c, Command::SetHome { point: Some(far) }), Ok(()));
    let home = c.home_ned().expect("home");
    assert!((home.x - 400.0).abs() < 1.0 && home.y.abs() < 0.01 && home.z.abs() < 1e-6, "{home:?}");
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    // The 300 m fence is around the new home: the vehicle, 400 m from it, is outside.
    let why = cmd(&mut c, Command::Arm).expect_err("outside the fence");
    assert!(why.contains("geofence"), "{why}");
    // Closer in, arming does not move the home the ground station set.
    let near = point_north(100.0, 20.0, AltitudeFrame::Amsl);
    cmd(&mut c, Command::SetHome { point: Some(near) }).expect("near home");
    let home = c.home_ned().expect("home");
    cmd(&mut c, Command::Arm).expect("arm");
    assert_eq!(c.home_ned(), Some(home));
    // An altitude relative to home is measured from the home now set.
    let above = point_north(100.0, 30.0, AltitudeFrame::RelativeHome);
    assert_eq!(cmd(&mut c, Command::SetHome { point: Some(above) }), Ok(()));
    assert!((c.home_ned().expect("home").z + 30.0).abs() < 1e-6);
}

#[test]
fn set_home_refuses_what_it_cannot_place_and_says_why() {
    let relative = point_north(0.0, 5.0, AltitudeFrame::RelativeHome);
    let mut no_origin = ready(false);
    let why = cmd(&mut no_origin, Command::SetHome { point: None }).expect_err("no origin");
    assert!(why.contains("origin"), "{why}");
    let mut c = ready(true);
    let cases = [
        (Some(MissionPoint { lat_deg: 95.0, ..relative }), "not a position"),
        (Some(MissionPoint { alt_m: f64::NAN, ..relative }), "not a position"),
        (Some(point_north(60_000.0, 20.0, AltitudeFrame::Amsl)), "from the origin"),
        (Some(relative), "not yet set"),
    ];
    for (point, reason) in cases {
        let why = cmd(&mut c, Command::SetHome { point }).expect_err(reason);
        assert!(why.contains(reason), "{point:?}: {why}");
        assert_eq!(c.status(Time(1000)).last_refusal.as_deref(), Some(why.as_str()));
        assert_eq!(c.home_ned(), None);
    }
    // "Here" needs a fresh position.
    let stale = c.on_command(&VehicleCommand {
        id: 0,
        time: Time(1_000_000),
        command: Command::SetHome { point: None },
    });
    assert!(stale.expect_err("stale").0.contains("position estimate"));
}
