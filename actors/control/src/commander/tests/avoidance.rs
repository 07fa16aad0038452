//! The avoider in the loop on GUIDED and AUTO legs: blending, holding on a stale stream.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    AltitudeFrame, Command, FailsafeAction, FailsafeCause, FlightMode, Mission, MissionItem, MissionPoint,
    NavState, TrajectorySetpoint,
};

use super::fixtures::{at, avoidance, cmd, hovering, nav_heading, ready, trajectory, velocity};
use crate::commander::{Commander, CommanderParams};

#[test]
fn frd_rotates_into_ned_with_the_heading() {
    let close = |a: nalgebra::Vector3<f64>, b: [f64; 3]| (a - nalgebra::Vector3::from(b)).norm() < 1e-12;
    assert!(close(crate::commander::frd_to_ned([1.0, 2.0, 3.0], 0.0), [1.0, 2.0, 3.0]));
    // Facing east: forward is east, right is south.
    let east = std::f64::consts::FRAC_PI_2;
    assert!(close(crate::commander::frd_to_ned([1.0, 0.0, 0.0], east), [0.0, 1.0, 0.0]));
    assert!(close(crate::commander::frd_to_ned([0.0, 1.0, -0.5], east), [-1.0, 0.0, -0.5]));
}

#[test]
fn guided_velocity_blends_the_rotated_correction_and_honours_the_climb() {
    let mut c = hovering();
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    at(&mut c, 2000, Command::VelocityNed { velocity_ned_m_s: [3.0, 0.0, 0.0] }).expect("velocity");
    // Facing east at first; the avoider asks for 1 m/s to the right and 0.5 m/s up. The nose
    // turns north (the vehicle's heading follows the commanded one) before the vehicle flies.
    let mut yaw = std::f64::consts::FRAC_PI_2;
    let mut t = 2000;
    let mut sp = TrajectorySetpoint::default();
    while t < 4_000_000 {
        t += 2500;
        if (t - 2000) % 500_000 == 0 {
            // Repeated at 2 Hz, as a ground station streams it (GUIDED_TIMEOUT is 3 s).
            at(&mut c, t, Command::VelocityNed { velocity_ned_m_s: [3.0, 0.0, 0.0] }).expect("velocity");
        }
        c.on_nav(&nav_heading(t, -5.0, yaw));
        c.on_avoidance(&avoidance(t, [0.0, 1.0, -0.5], false));
        let before = sp;
        sp = trajectory(c.update(Time(t)).target);
        yaw = sp.yaw_rad.expect("yaw");
        // The demand changes at most at the acceleration limit.
        if t > 4500 {
            let dv = nalgebra::Vector3::from(velocity(&sp)) - nalgebra::Vector3::from(velocity(&before));
            assert!(dv.norm() <= 2.5 * 0.0025 + 1e-9, "{dv:?}");
        }
    }
    // Facing north, right is east.
    let v = velocity(&sp);
    assert!((v[0] - 3.0).abs() < 1e-6 && (v[1] - 1.0).abs() < 1e-6 && (v[2] + 0.5).abs() < 1e-6, "{v:?}");
    // A moving demand is flown as a velocity: the horizontal position setpoint is the
    // vehicle's (still at the origin here) plus one step of the demand, with no lead to catch
    // up on; the vertical one climbs ahead, within the 0.3 m leash.
    let p = sp.position_ned_m.map(|p| p.expect("position"));
    assert!((p[0] - 3.0 * 0.0025).abs() < 1e-4 && (p[1] - 0.0025).abs() < 1e-4, "{p:?}");
    assert!(p[2] + 5.0 < 0.0 && p[2] + 5.0 >= -0.3 - 1e-9, "{p:?}");
    // The nose turned towards the demanded direction (north).
    assert!(sp.yaw_rad.expect("yaw").abs() < 1e-6, "{:?}", sp.yaw_rad);
    assert_eq!(c.status(Time(t)).last_refusal, None);
}

#[test]
fn a_leg_descends_no_steeper_than_the_camera_sees_ahead_and_straight_down_over_its_target() {
    // From 17 m up, facing north: a GUIDED target 40 m north at 5 m, then one straight below.
    for (north_m, slope_limited) in [(40.0, true), (0.0, false)] {
        let mut c = hovering();
        at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
        at(&mut c, 2000, Command::GotoNed { position_ned_m: [north_m, 0.0, -5.0] }).expect("goto");
        let mut v = [0.0; 3];
        for k in 1..=1600 {
            let t = 2000 + k * 2500;
            // Flying the demand, so that the ground-contact check does not take a vehicle
            // that holds still under a descent demand for one on the ground.
            c.on_nav(&NavState { velocity_ned_m_s: v, ..nav_heading(t, -17.0, 0.0) });
            c.on_avoidance(&avoidance(t, [0.0; 3], false));
            v = velocity(&trajectory(c.update(Time(t)).target));
            if slope_limited {
                assert!(v[2] <= crate::commander::avoidance::DESCENT_SLOPE * v[0] + 1e-9, "{v:?} at {t} µs");
            }
        }
        // Settled: 5 m/s north and a quarter of it down; or the leg's 2 m/s straight down.
        let expected = if slope_limited { [5.0, 0.0, 1.25] } else { [0.0, 0.0, 2.0] };
        assert!(v.iter().zip(expected).all(|(v, e)| (v - e).abs() < 1e-6), "{v:?}, not {expected:?}");
    }
}

#[test]
fn a_target_a_few_decimetres_away_does_not_turn_the_nose() {
    // Facing north; a GUIDED target 0.5 m east (the drift of a take-off spot) is flown to
    // without swinging the forward camera towards it; one 10 m east turns it.
    for (east_m, turns) in [(0.5, false), (10.0, true)] {
        let mut c = hovering();
        at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
        at(&mut c, 2000, Command::GotoNed { position_ned_m: [0.0, east_m, -5.0] }).expect("goto");
        let mut sp = TrajectorySetpoint::default();
        for k in 1..=400 {
            let t = 2000 + k * 2500;
            c.on_nav(&nav_heading(t, -5.0, 0.0));
            c.on_avoidance(&avoidance(t, [0.0; 3], false));
            sp = trajectory(c.update(Time(t)).target);
        }
        let yaw = sp.yaw_rad.expect("yaw");
        assert_eq!(yaw.abs() > 0.5, turns, "{east_m} m east: yaw {yaw}");
    }
}

/// Armed in AUTO at 10 m, flying towards a waypoint about 11 m north with the avoider in the
/// loop; returns the commander and the time.
fn auto_leg() -> (Commander, u64) {
    let mut c = ready(true);
    let home =
        MissionPoint { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 10.0, frame: AltitudeFrame::RelativeHome };
    let north = MissionPoint { lat_deg: 6.79720, ..home };
    let items = vec![
        MissionItem::Takeoff { point: home },
        MissionItem::Waypoint { point: north, acceptance_radius_m: 1.0, hold_s: 0.0 },
    ];
    c.on_mission(Mission { time: Time::ZERO, items, cruise_speed_m_s: 4.0 }).expect("mission");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    (c, 1000)
}

#[test]
fn auto_leg_flies_at_cruise_towards_the_waypoint_with_a_zero_correction() {
    let (mut c, mut t) = auto_leg();
    let mut sp = TrajectorySetpoint::default();
    while t < 3_000_000 {
        t += 2500;
        c.on_nav(&nav_heading(t, -10.0, 0.0));
        c.on_avoidance(&avoidance(t, [0.0; 3], false));
        sp = trajectory(c.update(Time(t)).target);
    }
    let v = velocity(&sp);
    assert!((v[0] - 4.0).abs() < 1e-6 && v[1].abs() < 1e-6 && v[2].abs() < 1e-6, "{v:?}");
    assert!(sp.yaw_rad.expect("yaw").abs() < 1e-9, "{:?}", sp.yaw_rad);
}

#[test]
fn a_landing_item_away_from_the_vehicle_is_approached_with_the_avoider_in_the_loop() {
    // AUTO at 10 m over home, the mission's LAND item about 11 m north: the level approach is
    // a leg the avoider steers (1 m/s to the right, east while facing north), at the GUIDED
    // speed; without the avoider it is a plain position setpoint.
    for with_avoider in [true, false] {
        let mut c = ready(true);
        let home = MissionPoint {
            lat_deg: 6.79710,
            lon_deg: 79.90170,
            alt_m: 10.0,
            frame: AltitudeFrame::RelativeHome,
        };
        let north = MissionPoint { lat_deg: 6.79720, ..home };
        let items = vec![MissionItem::Takeoff { point: home }, MissionItem::Land { point: north }];
        c.on_mission(Mission { time: Time::ZERO, items, cruise_speed_m_s: 4.0 }).expect("mission");
        cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
        cmd(&mut c, Command::Arm).expect("arm");
        let (mut t, mut sp) = (1000, TrajectorySetpoint::default());
        while t < 3_000_000 {
            t += 2500;
            c.on_nav(&nav_heading(t, -10.0, 0.0));
            if with_avoider {
                c.on_avoidance(&avoidance(t, [0.0, 1.0, 0.0], false));
            }
            sp = trajectory(c.update(Time(t)).target);
        }
        if with_avoider {
            let v = velocity(&sp);
            let guided = CommanderParams::default().guided_speed_m_s;
            assert!((v[0] - guided).abs() < 1e-2 && (v[1] - 1.0).abs() < 1e-2, "{v:?}");
        } else {
            assert_eq!(sp.velocity_ned_m_s, [None; 3], "{sp:?}");
            let p = sp.position_ned_m.map(|p| p.expect("position"));
            assert!((p[0] - 11.1).abs() < 0.2 && p[1].abs() < 1e-6 && (p[2] + 10.0).abs() < 1e-6, "{p:?}");
        }
    }
}

#[test]
fn a_stale_avoidance_stream_in_auto_slows_holds_and_says_why() {
    for stale_by_flag in [true, false] {
        let (mut c, mut t) = auto_leg();
        let step = |c: &mut Commander, t: u64, send: Option<bool>| {
            c.on_nav(&nav_heading(t, -10.0, 0.0));
            if let Some(stale) = send {
                c.on_avoidance(&avoidance(t, [0.0; 3], stale));
            }
            trajectory(c.update(Time(t)).target)
        };
        while t < 3_000_000 {
            t += 2500;
            step(&mut c, t, Some(false));
        }
        assert!(!c.avoidance_holding());
        // The stream goes stale: flagged by the avoider, or silent past avoidance_timeout_s.
        let send = if stale_by_flag { Some(true) } else { None };
        let mut speeds = Vec::new();
        let mut last = TrajectorySetpoint::default();
        while t < 6_000_000 {
            t += 2500;
            last = step(&mut c, t, send);
            let v = velocity(&last);
            speeds.push(v[0].hypot(v[1]));
        }
        // Slows (never faster than the limit allows), then holds still.
        assert!(speeds.windows(2).all(|w| w[1] <= w[0] + 1e-9), "speeds rise");
        assert!(speeds[0] > 3.9, "slows down, does not stop dead: {}", speeds[0]);
        assert_eq!(*speeds.last().unwrap(), 0.0);
        assert!(c.avoidance_holding(), "stale by flag: {stale_by_flag}");
        let why = c.status(Time(t)).last_refusal.expect("says why");
        assert!(why.contains("avoidance stale"), "{why}");
        let held = last.position_ned_m;
        assert_eq!(step(&mut c, t + 2500, send).position_ned_m, held, "holds position");
        assert_eq!(c.mode(), FlightMode::Auto);
        // Fresh again: the leg resumes.
        t += 2500;
        while t < 8_000_000 {
            t += 2500;
            last = step(&mut c, t, Some(false));
        }
        assert!(!c.avoidance_holding());
        assert!(velocity(&last)[0] > 3.9, "{:?}", velocity(&last));
    }
}

#[test]
fn avoidance_stale_past_avoidance_lost_s_lands_and_a_shorter_gap_only_holds() {
    let lost_s = CommanderParams::default().failsafe.avoidance_lost_s;
    // Stale for `gap_s` (flagged by the avoider on its staleness timer), then fresh again.
    for (gap_s, lands) in [(lost_s - 1.0, false), (lost_s + 1.0, true)] {
        let (mut c, mut t) = auto_leg();
        let mut cause = None;
        let gap = (3.0 * 1e6) as u64..((3.0 + gap_s) * 1e6) as u64;
        while t < ((5.0 + lost_s) * 1e6) as u64 {
            t += 2500;
            c.on_nav(&nav_heading(t, -10.0, 0.0));
            c.on_avoidance(&avoidance(t, [0.0; 3], gap.contains(&t)));
            c.update(Time(t));
            cause = cause.or(c.status(Time(t)).failsafe.map(|f| (f.cause, f.action, f.since)));
        }
        if lands {
            let (cause, action, since) = cause.expect("the failsafe fired");
            assert_eq!((cause, action), (FailsafeCause::AvoidanceLost, FailsafeAction::Land));
            // The last fresh command was 2.5 ms before the gap; it fires at the first update past it.
            let after_s = since.as_secs_f64() - (gap.start as f64 / 1e6 - 0.0025);
            assert!(
                after_s > lost_s && after_s < lost_s + 0.01,
                "fired {after_s} s after the last fresh command"
            );
            assert_eq!(c.mode(), FlightMode::Land);
        } else {
            assert_eq!(cause, None, "a gap shorter than avoidance_lost_s only holds");
            assert_eq!(c.mode(), FlightMode::Auto);
        }
    }
}

#[test]
fn without_avoidance_commands_auto_flies_point_to_point_as_before() {
    let (mut c, mut t) = auto_leg();
    let mut sp = TrajectorySetpoint::default();
    while t < 1_000_000 {
        t += 2500;
        c.on_nav(&nav_heading(t, -10.0, 0.0));
        sp = trajectory(c.update(Time(t)).target);
    }
    assert_eq!(sp.velocity_ned_m_s, [None; 3]);
    assert_eq!(sp.max_horizontal_speed_m_s, Some(4.0));
    assert!(sp.position_ned_m[0].expect("north") > 10.0);
}
