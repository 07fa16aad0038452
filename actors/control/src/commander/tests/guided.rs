//! GUIDED targets: a velocity's timeout, CONDITION_YAW and a region of interest.

use kestrel_proto::Time;
use kestrel_proto::messages::{Command, FlightMode};

use super::fixtures::{at, hover_at, hovering, nav, trajectory, velocity};
use crate::commander::Commander;

#[test]
fn a_guided_velocity_not_repeated_within_the_timeout_is_dropped_for_a_hold() {
    let mut c = hovering();
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    at(&mut c, 2000, Command::VelocityNed { velocity_ned_m_s: [3.0, 0.0, 0.0] }).expect("velocity");
    let flies = |c: &mut Commander, t: u64| {
        c.on_nav(&nav(Time(t), -5.0, true));
        trajectory(c.update(Time(t)).target)
    };
    assert_eq!(velocity(&flies(&mut c, 2_900_000))[0], 3.0, "within GUIDED_TIMEOUT (3 s)");
    let refusals = c.status(Time(2_900_000)).refusals;
    let held = flies(&mut c, 3_100_000);
    assert_eq!(held.velocity_ned_m_s, [None; 3], "the stream stopped: no velocity flown");
    assert_eq!(held.position_ned_m, [Some(0.0), Some(0.0), Some(-5.0)], "held where it was");
    let status = c.status(Time(3_100_000));
    assert_eq!(status.refusals, refusals + 1);
    assert!(status.last_refusal.as_deref().is_some_and(|r| r.contains("holding")), "{status:?}");
}

#[test]
fn condition_yaw_and_a_region_of_interest_point_the_nose_in_guided() {
    let mut c = hovering();
    assert!(
        at(&mut c, 2000, Command::Yaw { heading_deg: Some(90.0), relative_deg: None }).is_err(),
        "LOITER"
    );
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    at(&mut c, 2000, Command::Yaw { heading_deg: Some(90.0), relative_deg: None }).expect("yaw");
    let yaw = |c: &mut Commander, t| trajectory(hover_at(c, t, [0.0, 0.0, -5.0])).yaw_rad.expect("yaw");
    assert!((yaw(&mut c, 3000) - 90f64.to_radians()).abs() < 1e-9);
    // A point to the south-west: the nose turns there (atan2(east, north)).
    at(&mut c, 3000, Command::RegionOfInterest { position_ned_m: Some([-10.0, -10.0, 0.0]) }).expect("roi");
    assert!((yaw(&mut c, 4000) - (-135f64).to_radians()).abs() < 1e-9);
    for bad in [
        Command::Yaw { heading_deg: Some(f64::NAN), relative_deg: None },
        Command::Yaw { heading_deg: Some(10.0), relative_deg: Some(10.0) },
        Command::RegionOfInterest { position_ned_m: Some([f64::INFINITY, 0.0, 0.0]) },
    ] {
        assert!(at(&mut c, 4000, bad).is_err(), "{bad:?}");
    }
    at(&mut c, 4000, Command::RegionOfInterest { position_ned_m: None }).expect("roi none");
    let kept = yaw(&mut c, 5000);
    assert!((kept - (-135f64).to_radians()).abs() < 1e-9, "the last heading is held: {kept}");
}
