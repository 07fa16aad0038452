//! The avoider in the loop in POSHOLD: the pilot's forward sticks blended and capped.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    AvoidanceCommand, ClearRange, ClearRangeReason, Command, FlightMode, LandedState, SpeedCapStatus,
    TrajectorySetpoint,
};

use super::fixtures::{avoidance, cmd, fly_sticks, nav_heading, ready, sticks, trajectory, velocity};
use crate::commander::Commander;

// The avoider in POSHOLD: the pilot's stick velocity is the leg.

/// Armed in POSHOLD 5 m up, facing `yaw_rad`, at t = 2 ms.
fn poshold_facing(yaw_rad: f64) -> Commander {
    let mut c = ready(true);
    c.on_nav(&nav_heading(1000, 0.0, yaw_rad));
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    c.on_nav(&nav_heading(2000, -5.0, yaw_rad));
    c.update(Time(2000));
    assert_eq!(c.landed(), LandedState::InAir);
    c
}

#[test]
fn poshold_forward_stick_blends_the_rotated_correction_and_the_pilot_keeps_heading_and_throttle() {
    let east = std::f64::consts::FRAC_PI_2;
    let mut c = poshold_facing(east);
    let mut t = 2000;
    // Full forward stick facing east (5 m/s east); the avoider asks for 1 m/s to the right
    // (south) and nothing vertical.
    let sp = fly_sticks(&mut c, &mut t, 3_000_000, east, [0.0, 1.0, 0.0, 0.5], Some([0.0, 1.0, 0.0]));
    let v = velocity(&sp);
    assert!((v[0] + 1.0).abs() < 1e-6 && (v[1] - 5.0).abs() < 1e-6, "{v:?}");
    // Throttle centred: the height is held (the demand settles to zero, the setpoint at 5 m).
    assert!(v[2].abs() < 1e-3, "{v:?}");
    assert!((sp.position_ned_m[2].expect("down") + 5.0).abs() < 0.01, "{:?}", sp.position_ned_m);
    // V_in is the pilot's demanded speed, not the blended one.
    assert_eq!(sp.desired_speed_m_s, Some(5.0));
    let facing = |sp: &TrajectorySetpoint| (sp.yaw_rad.expect("yaw") - east).abs() < 1e-9;
    assert!(facing(&sp), "the nose stays where the pilot put it: {:?}", sp.yaw_rad);
    // Forward and right together: the leg points south-east of the heading, the nose stays.
    let sp = fly_sticks(&mut c, &mut t, 2_000_000, east, [0.5, 1.0, 0.0, 0.5], Some([0.0, 1.0, 0.0]));
    let v = velocity(&sp);
    assert!((v[0] + 2.5 + 1.0).abs() < 1e-6 && (v[1] - 5.0).abs() < 1e-6, "{v:?}");
    assert!(facing(&sp), "{:?}", sp.yaw_rad);
    assert_eq!(sp.desired_speed_m_s, Some(5.0), "the forward part, towards what the camera sees");
    // The throttle still climbs (2.5 m/s at full stick) ...
    let sp = fly_sticks(&mut c, &mut t, 2_000_000, east, [0.0, 1.0, 0.0, 1.0], Some([0.0, 1.0, 0.0]));
    assert!((velocity(&sp)[2] + 2.5).abs() < 1e-6, "{:?}", velocity(&sp));
    // ... unless the avoider asks for a vertical correction: then it has the vertical.
    let sp = fly_sticks(&mut c, &mut t, 2_000_000, east, [0.0, 1.0, 0.0, 0.0], Some([0.0, 0.0, -0.5]));
    assert!((velocity(&sp)[2] + 0.5).abs() < 1e-6, "{:?}", velocity(&sp));
    // The yaw stick turns the nose at its rate (90 °/s at full stick), fed forward.
    let before = sp.yaw_rad.expect("yaw");
    let sp = fly_sticks(&mut c, &mut t, 500_000, east, [0.0, 1.0, 0.5, 0.5], Some([0.0; 3]));
    let turned = sp.yaw_rad.expect("yaw") - before;
    assert!((turned - 45f64.to_radians() * 0.5).abs() < 1e-3, "{turned}");
    assert!((sp.yaw_rate_rad_s - 45f64.to_radians()).abs() < 1e-12);
    assert_eq!(c.status(Time(t)).last_refusal, None);
    assert_eq!(c.mode(), FlightMode::PosHold);
}

#[test]
fn poshold_ramps_the_avoiders_brake_with_feed_forward_and_never_leads_the_vehicle() {
    let mut c = poshold_facing(0.0);
    let mut t = 2000;
    let sp = fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [0.0, 1.0, 0.0, 0.5], Some([0.0; 3]));
    assert!((velocity(&sp)[0] - 5.0).abs() < 1e-6, "{:?}", velocity(&sp));
    assert_eq!(sp.acceleration_ned_m_s2, [0.0; 3], "steady: nothing to feed forward");
    // Moving, the horizontal setpoint is where the vehicle is plus one step of the demand:
    // no lead for a lagging vehicle to catch up on.
    let p = sp.position_ned_m.map(|p| p.expect("position"));
    assert!((p[0] - 5.0 * 0.0025).abs() < 1e-9 && p[1].abs() < 1e-9, "{p:?}");
    // The avoider brakes to 1 m/s forward: ramped at 2.5 m/s² as in every mode, with the
    // ramp's deceleration fed forward to the controller.
    let sp = fly_sticks(&mut c, &mut t, 2500, 0.0, [0.0, 1.0, 0.0, 0.5], Some([-4.0, 0.0, 0.0]));
    assert!((velocity(&sp)[0] - (5.0 - 2.5 * 0.0025)).abs() < 1e-6, "{:?}", velocity(&sp));
    assert!((sp.acceleration_ned_m_s2[0] + 2.5).abs() < 1e-6, "{:?}", sp.acceleration_ned_m_s2);
    let sp = fly_sticks(&mut c, &mut t, 1_600_000, 0.0, [0.0, 1.0, 0.0, 0.5], Some([-4.0, 0.0, 0.0]));
    assert!((velocity(&sp)[0] - 1.0).abs() < 1e-6, "{:?}", velocity(&sp));
}

/// Steps `c` as [`fly_sticks`] with no correction and a grid 0.1 s old at every step whose view
/// vouches for `range_m` ahead; returns the last setpoint.
fn fly_capped(
    c: &mut Commander,
    t: &mut u64,
    duration_us: u64,
    yaw_rad: f64,
    manual: [f64; 4],
    clear_range: ClearRange,
) -> TrajectorySetpoint {
    let [roll, pitch, yaw, throttle] = manual;
    let mut sp = TrajectorySetpoint::default();
    let until = *t + duration_us;
    while *t < until {
        *t += 2500;
        c.on_nav(&nav_heading(*t, -5.0, yaw_rad));
        c.on_manual(&sticks(*t, roll, pitch, yaw, throttle));
        let grid_time = Some(Time(t.saturating_sub(100_000)));
        c.on_avoidance(&AvoidanceCommand { grid_time, clear_range, ..avoidance(*t, [0.0; 3], false) });
        sp = trajectory(c.update(Time(*t)).target);
    }
    sp
}

#[test]
fn poshold_forward_speed_is_capped_to_stop_inside_the_clear_range_and_the_status_says_so() {
    let east = std::f64::consts::FRAC_PI_2;
    let mut c = poshold_facing(east);
    let mut t = 2000;
    let range = |range_m, reason| ClearRange { range_m, reason };
    // Full forward (5 m/s east) and half right (2.5 m/s south) stick; the view vouches for 4 m
    // ahead. By hand: a = 2 m/s², t = 0.1 s of grid age + 0.3 s, margin 1 m:
    // v²/4 + 0.4·v = 3 → v = −0.8 + √(0.64 + 12) = 2.7553 m/s.
    let cap = -0.8 + 12.64f64.sqrt();
    let untextured = range(4.0, ClearRangeReason::Untextured);
    let sp = fly_capped(&mut c, &mut t, 3_000_000, east, [0.5, 1.0, 0.0, 0.5], untextured);
    let v = velocity(&sp);
    assert!((v[1] - cap).abs() < 1e-6 && (v[0] + 2.5).abs() < 1e-6, "only the forward part is capped: {v:?}");
    let status = c.status(Time(t)).speed_cap.expect("a speed cap while the avoider has a say");
    assert!((status.cap_m_s - cap).abs() < 1e-9, "{status:?}");
    assert_eq!((status.range_m, status.reason, status.limiting), (4.0, ClearRangeReason::Untextured, true));
    // Room for more than the stick asks: the full stick, and the cap does not limit.
    let sp = fly_capped(
        &mut c,
        &mut t,
        2_000_000,
        east,
        [0.0, 1.0, 0.0, 0.5],
        range(20.0, ClearRangeReason::StereoRange),
    );
    assert!((velocity(&sp)[1] - 5.0).abs() < 1e-6, "{:?}", velocity(&sp));
    let status = c.status(Time(t)).speed_cap.expect("cap");
    assert!(!status.limiting && status.cap_m_s > 5.0, "{status:?}");
    // The view ahead unknown: no forward speed at all; the pilot can still slide sideways.
    let unknown = range(0.0, ClearRangeReason::UnknownAhead);
    let sp = fly_capped(&mut c, &mut t, 3_000_000, east, [0.5, 1.0, 0.0, 0.5], unknown);
    let v = velocity(&sp);
    assert!(v[1].abs() < 1e-6 && (v[0] + 2.5).abs() < 1e-6, "{v:?}");
    assert_eq!(
        c.status(Time(t)).speed_cap,
        Some(SpeedCapStatus {
            cap_m_s: 0.0,
            range_m: 0.0,
            reason: ClearRangeReason::UnknownAhead,
            limiting: true
        })
    );
    // A clear range that is no distance is ignored like a non-finite correction: the cap
    // stays that of the last good command.
    let bad = range(f64::NAN, ClearRangeReason::Obstacle);
    let sp = fly_capped(&mut c, &mut t, 200_000, east, [0.0, 1.0, 0.0, 0.5], bad);
    assert!(velocity(&sp)[1].abs() < 1e-6, "{:?}", velocity(&sp));
    // Centred sticks hold: no leg, no cap.
    fly_sticks(&mut c, &mut t, 100_000, east, [0.0, 0.0, 0.0, 0.5], Some([0.0; 3]));
    assert_eq!(c.status(Time(t)).speed_cap, None);
}

#[test]
fn poshold_sideways_or_backwards_sticks_get_no_correction_and_no_stale_hold() {
    // The camera looks ahead only: what it sees is not on a sideways or backward path.
    let mut c = poshold_facing(0.0);
    let mut t = 2000;
    let sp = fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [1.0, 0.0, 0.0, 0.5], Some([-3.0, 1.0, 0.0]));
    let v = velocity(&sp);
    assert!(v[0].abs() < 1e-6 && (v[1] - 5.0).abs() < 1e-6, "{v:?}");
    assert_eq!(sp.desired_speed_m_s, Some(0.0));
    let sp = fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [0.0, -1.0, 0.0, 0.5], None);
    assert!((velocity(&sp)[0] + 5.0).abs() < 1e-6, "{:?}", velocity(&sp));
    assert!(!c.avoidance_holding());
    assert_eq!(c.status(Time(t)).last_refusal, None);
}

#[test]
fn poshold_centred_sticks_hold_position_whatever_the_avoider_says() {
    for stream in [Some([0.0, 1.0, -0.5]), None] {
        let mut c = poshold_facing(0.0);
        let mut t = 2000;
        // One command makes the avoider active; then fresh corrections, or a stale stream.
        c.on_avoidance(&avoidance(t, [0.0; 3], false));
        let sp = fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [0.0, 0.0, 0.0, 0.5], stream);
        assert_eq!(sp.position_ned_m, [Some(0.0), Some(0.0), Some(-5.0)], "{stream:?}");
        assert_eq!(sp.velocity_ned_m_s, [None; 3]);
        assert_eq!(sp.desired_speed_m_s, None);
        assert!(!c.avoidance_holding());
        assert_eq!(c.status(Time(t)).last_refusal, None, "holding is no refusal");
    }
}

#[test]
fn poshold_stale_avoidance_while_pushing_forward_slows_holds_and_says_why() {
    let mut c = poshold_facing(0.0);
    let mut t = 2000;
    fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [0.0, 1.0, 0.0, 0.5], Some([0.0; 3]));
    // The depth stream stops while the pilot keeps pushing.
    let mut speeds = Vec::new();
    let mut last = TrajectorySetpoint::default();
    while t < 7_000_000 {
        last = fly_sticks(&mut c, &mut t, 2500, 0.0, [0.0, 1.0, 0.0, 0.5], None);
        let v = velocity(&last);
        speeds.push(v[0].hypot(v[1]));
    }
    assert!(speeds.windows(2).all(|w| w[1] <= w[0] + 1e-9), "speeds rise");
    assert!(speeds[0] > 4.9, "slows down, does not stop dead: {}", speeds[0]);
    assert_eq!(*speeds.last().unwrap(), 0.0);
    assert!(c.avoidance_holding());
    let why = c.status(Time(t)).last_refusal.expect("says why");
    assert!(why.contains("avoidance stale"), "{why}");
    let held = last.position_ned_m;
    let next = fly_sticks(&mut c, &mut t, 2500, 0.0, [0.0, 1.0, 0.0, 0.5], None);
    assert_eq!(next.position_ned_m, held, "holds position");
    // The throttle still climbs while held.
    let sp = fly_sticks(&mut c, &mut t, 2_000_000, 0.0, [0.0, 1.0, 0.0, 1.0], None);
    let v = velocity(&sp);
    assert!(v[0].hypot(v[1]) == 0.0 && (v[2] + 2.5).abs() < 1e-6, "{v:?}");
    assert_eq!(c.mode(), FlightMode::PosHold);
    // Sticks centred: an ordinary position hold.
    let sp = fly_sticks(&mut c, &mut t, 2500, 0.0, [0.0, 0.0, 0.0, 0.5], None);
    assert_eq!(sp.position_ned_m, [Some(0.0), Some(0.0), Some(-5.0)]);
    assert!(!c.avoidance_holding());
}

#[test]
fn poshold_without_an_avoider_flies_the_sticks_as_before() {
    let east = std::f64::consts::FRAC_PI_2;
    let mut c = poshold_facing(east);
    let mut t = 2000;
    let sp = fly_sticks(&mut c, &mut t, 1_000_000, east, [0.0, 1.0, 0.0, 0.5], None);
    let [vn, ve, vd] = sp.velocity_ned_m_s;
    assert!(vn.expect("north").abs() < 1e-9 && (ve.expect("east") - 5.0).abs() < 1e-9 && vd.is_none());
    assert_eq!(sp.position_ned_m, [None, None, Some(-5.0)]);
    assert_eq!((sp.desired_speed_m_s, sp.max_horizontal_speed_m_s), (None, None));
    assert!((sp.yaw_rad.expect("yaw") - east).abs() < 1e-9, "{:?}", sp.yaw_rad);
    assert_eq!(c.status(Time(t)).last_refusal, None);
}
