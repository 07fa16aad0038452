//! GUIDED targets: a velocity's timeout, CONDITION_YAW and a region of interest, position
//! targets with their yaw, attitude targets.

use kestrel_proto::Time;
use kestrel_proto::messages::{AttitudeTarget, Command, FlightMode, PositionTarget};
use nalgebra::UnitQuaternion;

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

fn guided() -> Commander {
    let mut c = hovering();
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    c
}

#[test]
fn a_position_target_flies_its_parts_and_turns_at_its_yaw_rate() {
    let mut c = guided();
    let t = PositionTarget {
        velocity_ned_m_s: Some([1.0, 2.0, 0.0]),
        acceleration_ned_m_s2: Some([0.5, 0.0, 0.0]),
        yaw_rate_rad_s: Some(0.5),
        ..PositionTarget::default()
    };
    at(&mut c, 10_000, Command::PositionTarget(t)).expect("velocity and yaw rate");
    let first = trajectory(hover_at(&mut c, 10_000, [0.0, 0.0, -5.0]));
    let later = trajectory(hover_at(&mut c, 110_000, [0.0, 0.0, -5.0]));
    assert_eq!(velocity(&later), [1.0, 2.0, 0.0]);
    assert_eq!(later.position_ned_m, [None; 3], "no position asked for");
    assert_eq!(later.acceleration_ned_m_s2, [0.5, 0.0, 0.0]);
    assert_eq!(later.yaw_rate_rad_s, 0.5, "the rate is the feed-forward");
    let turned = later.yaw_rad.expect("yaw") - first.yaw_rad.expect("yaw");
    assert!((turned - 0.05).abs() < 1e-9, "0.5 rad/s for 0.1 s: {turned}");
    // A rate beyond the vehicle's yaw-rate limit (90 °/s) turns at the limit.
    at(&mut c, 110_000, Command::PositionTarget(PositionTarget { yaw_rate_rad_s: Some(10.0), ..t }))
        .expect("fast");
    let fast = trajectory(hover_at(&mut c, 210_000, [0.0, 0.0, -5.0]));
    assert!((fast.yaw_rate_rad_s - 90f64.to_radians()).abs() < 1e-12);
    // A yaw turns the nose there at once; position with velocity moves along the velocity.
    let p = PositionTarget {
        position_ned_m: Some([3.0, 0.0, -5.0]),
        velocity_ned_m_s: Some([1.0, 0.0, 0.0]),
        yaw_rad: Some(-1.0),
        ..PositionTarget::default()
    };
    at(&mut c, 210_000, Command::PositionTarget(p)).expect("position, velocity, yaw");
    hover_at(&mut c, 210_000, [0.0, 0.0, -5.0]);
    let sp = trajectory(hover_at(&mut c, 310_000, [0.0, 0.0, -5.0]));
    assert_eq!(sp.yaw_rad, Some(-1.0));
    let north = sp.position_ned_m[0].expect("north");
    assert!((north - 3.1).abs() < 1e-9, "advanced 0.1 s at 1 m/s: {north}");
    assert_eq!(velocity(&sp), [1.0, 0.0, 0.0], "the velocity is the feed-forward");
}

#[test]
fn position_targets_are_checked_as_gotos_and_velocities_are() {
    let mut c = hovering();
    let v = PositionTarget { velocity_ned_m_s: Some([1.0, 0.0, 0.0]), ..PositionTarget::default() };
    assert!(at(&mut c, 2000, Command::PositionTarget(v)).is_err(), "not in GUIDED");
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    let bad = [
        PositionTarget::default(),
        PositionTarget {
            position_ned_m: Some([1.0, 0.0, -5.0]),
            velocity_ned_m_s: None,
            acceleration_ned_m_s2: Some([1.0; 3]),
            ..v
        },
        PositionTarget { velocity_ned_m_s: Some([f64::NAN, 0.0, 0.0]), ..v },
        PositionTarget { yaw_rad: Some(f64::INFINITY), ..v },
        PositionTarget { yaw_rate_rad_s: Some(f64::NAN), ..v },
        PositionTarget { velocity_ned_m_s: Some([30.0, 0.0, 0.0]), ..v },
        PositionTarget { acceleration_ned_m_s2: Some([100.0, 0.0, 0.0]), ..v },
        PositionTarget { position_ned_m: Some([0.0, 0.0, 5.0]), velocity_ned_m_s: None, ..v },
    ];
    for t in bad {
        assert!(at(&mut c, 3000, Command::PositionTarget(t)).is_err(), "{t:?}");
    }
    at(&mut c, 3000, Command::PositionTarget(v)).expect("a plain velocity");
    at(&mut c, 3000, Command::GuidedStop).expect("stop");
    let held = trajectory(hover_at(&mut c, 4000, [1.0, 0.0, -5.0]));
    assert_eq!(held.position_ned_m, [Some(1.0), Some(0.0), Some(-5.0)], "stopped where it is");
}

#[test]
fn an_attitude_target_tilts_towards_its_lean_and_climbs() {
    let mut c = guided();
    // Nose 10° down, heading east: forward is east.
    let q = UnitQuaternion::from_euler_angles(0.0, -10f64.to_radians(), 90f64.to_radians());
    let t = AttitudeTarget { attitude: [q.w, q.i, q.j, q.k], yaw_rate_rad_s: 0.0, climb: 0.5 };
    at(&mut c, 10_000, Command::AttitudeTarget(t)).expect("attitude");
    let sp = trajectory(hover_at(&mut c, 20_000, [0.0, 0.0, -5.0]));
    let a = sp.acceleration_ned_m_s2;
    let expected = kestrel_proto::units::GRAVITY_M_S2 * 10f64.to_radians().tan();
    assert!(a[0].abs() < 1e-9 && (a[1] - expected).abs() < 1e-9, "{a:?}");
    assert!((sp.yaw_rad.expect("yaw") - 90f64.to_radians()).abs() < 1e-9);
    assert_eq!(sp.velocity_ned_m_s[2], Some(-1.25), "half the full climb of 2.5 m/s, up");
    for bad in [
        AttitudeTarget { attitude: [0.9, 0.0, 0.0, 0.0], ..t },
        AttitudeTarget { climb: 1.5, ..t },
        AttitudeTarget { yaw_rate_rad_s: f64::NAN, ..t },
    ] {
        assert!(at(&mut c, 20_000, Command::AttitudeTarget(bad)).is_err(), "{bad:?}");
    }
    // Not repeated within GUIDED_TIMEOUT: held where it is.
    let held = trajectory(hover_at(&mut c, 3_100_000, [2.0, 0.0, -6.0]));
    assert_eq!(held.position_ned_m, [Some(2.0), Some(0.0), Some(-6.0)]);
}
