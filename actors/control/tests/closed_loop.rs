//! Closed-loop flights of the control cascade against the simulator core at 400 Hz.
//!
//! NavState comes from the simulator's ground truth (see `common`): the estimator is not in
//! this loop. Bounds are the acceptance figures or tighter; measured values are
//! printed (`cargo test -p kestrel-control --test closed_loop -- --nocapture`).

mod common;

use common::{Loop, hold};
use kestrel_control::Flip;
use kestrel_proto::messages::{Setpoint, SetpointTarget};
use kestrel_sim::{WindParams, World};
use nalgebra::{UnitQuaternion, Vector3};

#[test]
fn hover_holds_position_in_still_air() {
    let mut l = Loop::new(World::default(), [0.0, 0.0, -10.0], UnitQuaternion::identity());
    let mut worst: f64 = 0.0;
    l.fly(hold([0.0, 0.0, -10.0], 0.0), 20.0, |s| {
        worst = worst.max((s.state().position_ned_m - Vector3::new(0.0, 0.0, -10.0)).norm());
    });
    println!("hover, still air: worst position error {worst:.4} m");
    assert!(worst < 0.05, "worst error {worst} m");
}

#[test]
fn hover_in_five_metre_per_second_wind_with_gusts_holds_within_the_acceptance_bounds() {
    let world = World {
        wind: WindParams {
            steady_ned_m_s: [5.0, 0.0, 0.0],
            gust_std_m_s: 1.5,
            gust_time_constant_s: 2.0,
            ..WindParams::default()
        },
        ..World::default()
    };
    let mut l = Loop::new(world, [0.0, 0.0, -10.0], UnitQuaternion::identity());
    // Let the integrator take up the steady wind first.
    l.fly(hold([0.0, 0.0, -10.0], 0.0), 10.0, |_| {});
    let (mut h2, mut v2, mut n) = (0.0, 0.0, 0.0);
    l.fly(hold([0.0, 0.0, -10.0], 0.0), 60.0, |s| {
        let p = s.state().position_ned_m;
        h2 += p.x * p.x + p.y * p.y;
        v2 += (p.z + 10.0).powi(2);
        n += 1.0;
    });
    let (h_rms, v_rms) = ((h2 / n).sqrt(), (v2 / n).sqrt());
    println!("hover, 5 m/s wind, 1.5 m/s gusts: horizontal RMS {h_rms:.3} m, vertical RMS {v_rms:.3} m");
    assert!(h_rms < 0.5 && v_rms < 0.3, "horizontal {h_rms} m, vertical {v_rms} m");
}

#[test]
fn a_ten_metre_step_settles_without_overshoot() {
    let mut l = Loop::new(World::default(), [0.0, 0.0, -10.0], UnitQuaternion::identity());
    let mut overshoot: f64 = 0.0;
    let mut settled_at = None;
    let mut t = 0.0;
    l.fly(hold([10.0, 0.0, -10.0], 0.0), 15.0, |s| {
        t += 0.0025;
        let p = s.state().position_ned_m;
        overshoot = overshoot.max(p.x - 10.0);
        let close = (p - Vector3::new(10.0, 0.0, -10.0)).norm() < 0.2;
        match (close, settled_at) {
            (true, None) => settled_at = Some(t),
            (false, Some(_)) => settled_at = None,
            _ => {}
        }
    });
    let settled = settled_at.unwrap_or(f64::INFINITY);
    println!("10 m step north: overshoot {overshoot:.3} m, settled within 0.2 m after {settled:.2} s");
    assert!(overshoot < 0.3, "overshoot {overshoot} m");
    assert!(settled < 8.0, "settled after {settled} s");
}

#[test]
fn recovers_from_upside_down_and_from_a_large_tilt() {
    for (roll_deg, max_loss_m) in [(170.0, 8.0), (150.0, 6.0)] {
        let q = UnitQuaternion::from_euler_angles(f64::to_radians(roll_deg), 0.1, 0.3);
        let mut l = Loop::new(World::default(), [0.0, 0.0, -20.0], q);
        let mut level_at = None;
        let mut lowest: f64 = -20.0;
        let mut t = 0.0;
        l.fly(hold([0.0, 0.0, -20.0], 0.3), 10.0, |s| {
            t += 0.0025;
            let tilt = (s.state().attitude * Vector3::z()).angle(&Vector3::z());
            if tilt < 10f64.to_radians() && level_at.is_none() {
                level_at = Some(t);
            }
            lowest = lowest.max(s.state().position_ned_m.z);
        });
        let loss = lowest + 20.0;
        let level = level_at.unwrap_or(f64::INFINITY);
        println!("{roll_deg}° initial roll: level (< 10°) after {level:.2} s, altitude loss {loss:.2} m");
        assert!(level < 1.5, "{roll_deg}°: level after {level} s");
        assert!(loss < max_loss_m, "{roll_deg}°: lost {loss} m");
        assert!(l.tilt() < 0.05 && (l.position() - Vector3::new(0.0, 0.0, -20.0)).norm() < 0.3);
        assert!(!l.sim.crashed());
    }
}

#[test]
fn a_ninety_degree_yaw_step_settles_and_keeps_altitude() {
    let mut l = Loop::new(World::default(), [0.0, 0.0, -10.0], UnitQuaternion::identity());
    let target = std::f64::consts::FRAC_PI_2;
    let mut worst_alt: f64 = 0.0;
    let mut yaw = 0.0;
    l.fly(hold([0.0, 0.0, -10.0], target), 5.0, |s| {
        worst_alt = worst_alt.max((s.state().position_ned_m.z + 10.0).abs());
        yaw = s.state().attitude.euler_angles().2;
    });
    println!("90° yaw step: yaw after 5 s {:.2}°, worst altitude error {worst_alt:.3} m", yaw.to_degrees());
    assert!((yaw - target).abs() < 2f64.to_radians(), "yaw {yaw}");
    // Yaw outranks thrust in the mixer, so a saturated yaw demand may move the altitude a little.
    assert!(worst_alt < 0.25, "altitude error {worst_alt} m");
}

#[test]
fn the_flip_rolls_a_full_turn_and_recovers_level_losing_little_height() {
    let mut l = Loop::new(World::default(), [0.0, 0.0, -20.0], UnitQuaternion::identity());
    let hover = l.ctl.params().hover_thrust();
    let mut flip = Flip::start(&common::truth_nav(&l.sim), hover);
    let (mut lowest, mut rolled, mut steps): (f64, f64, u32) = (-20.0, 0.0, 0);
    while !flip.done() && steps < 4000 {
        let nav = common::truth_nav(&l.sim);
        let target = flip.update(&nav);
        let sp = Setpoint { time: l.sim.time(), armed: true, target, landing: false, failed_motor: None };
        l.ctl.set_setpoint(&sp).expect("valid");
        l.step();
        rolled += l.sim.state().angular_velocity_frd_rad_s.x * 0.0025;
        lowest = lowest.max(l.sim.state().position_ned_m.z);
        steps += 1;
    }
    let flip_s = f64::from(steps) * 0.0025;
    // Hold the altitude the flip ended at.
    let end = l.position();
    l.fly(hold([end.x, end.y, end.z], 0.0), 3.0, |s| lowest = lowest.max(s.state().position_ned_m.z));
    let loss = lowest + 20.0;
    println!("flip: rolled {:.0}° in {flip_s:.2} s, altitude loss {loss:.2} m", rolled.to_degrees());
    assert!(flip.done(), "flip did not finish");
    assert!((rolled.to_degrees() - 360.0).abs() < 30.0, "rolled {}°", rolled.to_degrees());
    assert!(loss < 3.0, "lost {loss} m");
    assert!(l.tilt() < 0.05);
    let _ = SetpointTarget::MotorsOff;
}

#[test]
fn the_default_airframe_matches_quad_x_toml() {
    assert_eq!(common::airframe_of(&common::quad_x()), kestrel_control::AirframeParams::default());
}

#[test]
fn hexa_and_octo_frames_hold_step_and_recover_with_the_same_gains() {
    for name in ["hexa_x", "octo_x"] {
        let mut l = Loop::with_vehicle(
            common::vehicle(name),
            World::default(),
            [0.0, 0.0, -10.0],
            UnitQuaternion::identity(),
        );
        let mut overshoot: f64 = 0.0;
        l.fly(hold([10.0, 0.0, -10.0], 0.0), 10.0, |s| {
            overshoot = overshoot.max(s.state().position_ned_m.x - 10.0)
        });
        let error = (l.position() - Vector3::new(10.0, 0.0, -10.0)).norm();
        let q = UnitQuaternion::from_euler_angles(150f64.to_radians(), 0.0, 0.0);
        let mut r = Loop::with_vehicle(common::vehicle(name), World::default(), [0.0, 0.0, -20.0], q);
        let mut lowest: f64 = -20.0;
        r.fly(hold([0.0, 0.0, -20.0], 0.0), 6.0, |s| lowest = lowest.max(s.state().position_ned_m.z));
        println!(
            "{name}: 10 m step overshoot {overshoot:.3} m, error after 10 s {error:.3} m; 150° recovery lost {:.2} m",
            lowest + 20.0
        );
        // The gains are tuned for quad-X; the heavier frames overshoot a little more.
        assert!(overshoot < 0.4 && error < 0.1, "{name}: overshoot {overshoot} m, error {error} m");
        assert!(r.tilt() < 0.05 && lowest + 20.0 < 6.0 && !r.sim.crashed(), "{name}");
    }
}
