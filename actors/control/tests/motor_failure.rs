//! Flying on after a motor failure, closed loop (true state, no estimator): the simulator's
//! `motor_lost` fault, and the setpoint naming the failed motor from the detector's timeout on,
//! as the commander does. A hexa holds its position on the other five; a quad spins and steers
//! its thrust axis on the three left ([`kestrel_control::SpinDescent`]): it holds its height
//! upright at the spin rate where the two rotors' reaction torque meets the simulator's yaw
//! drag, and descends at a walking pace to an upright touchdown.

mod common;

use common::{Loop, hold};
use kestrel_proto::messages::{SetpointTarget, TrajectorySetpoint};
use kestrel_proto::units::GRAVITY_M_S2;
use kestrel_sim::{FaultKind, World};
use nalgebra::{UnitQuaternion, Vector3};

/// PX4's `FD_ACT_MOT_TOUT`: how long the loop flies on the full allocation with the motor gone.
const DETECTION_S: f64 = 0.1;

fn lose_motor_1(l: &mut Loop, target: SetpointTarget) -> (f64, f64) {
    l.sim.add_fault(FaultKind::MotorLost { motor: 1 }).expect("valid fault");
    let mut worst_tilt: f64 = 0.0;
    let mut worst_error: f64 = 0.0;
    l.fly(target, DETECTION_S, |_| {});
    l.failed_motor = Some(0);
    let home = Vector3::new(0.0, 0.0, -10.0);
    l.fly(target, 10.0, |s| {
        worst_tilt = worst_tilt.max((s.state().attitude * Vector3::z()).angle(&Vector3::z()));
        worst_error = worst_error.max((s.state().position_ned_m - home).norm());
    });
    (worst_tilt, worst_error)
}

#[test]
fn a_hexa_that_lost_a_motor_holds_its_position_on_the_other_five() {
    let mut l = Loop::with_vehicle(
        common::vehicle("hexa_x"),
        World::default(),
        [0.0, 0.0, -10.0],
        UnitQuaternion::identity(),
    );
    l.fly(hold([0.0, 0.0, -10.0], 0.0), 2.0, |_| {});
    let (tilt, error) = lose_motor_1(&mut l, hold([0.0, 0.0, -10.0], 0.0));
    let final_error = (l.position() - Vector3::new(0.0, 0.0, -10.0)).norm();
    println!(
        "hexa, motor 1 lost: worst tilt {:.1} deg, worst error {error:.2} m, after 10 s {final_error:.2} m",
        tilt.to_degrees()
    );
    assert!(l.ctl.mixer().has_yaw_authority());
    assert!(!l.sim.crashed() && tilt < 0.5 && final_error < 0.5, "tilt {tilt} rad, error {final_error} m");
}

/// Tilt the recovery from the loss may reach (rad, 80°): until the spin builds up, the
/// opposite motor cannot pull, and the roll the loss started runs on (55° descending, 73°
/// holding height in these flights).
const RECOVERY_TILT_RAD: f64 = 1.4;

#[test]
fn a_quad_that_lost_a_motor_spins_upright_and_holds_its_height() {
    let mut l = Loop::new(World::default(), [0.0, 0.0, -10.0], UnitQuaternion::identity());
    l.fly(hold([0.0, 0.0, -10.0], 0.0), 2.0, |_| {});
    let (tilt, error) = lose_motor_1(&mut l, hold([0.0, 0.0, -10.0], 0.0));
    // 10 s more: the spin settles (time constant I_zz/γ = 3.8 s) and the tilt with it.
    let mut late_tilt: f64 = 0.0;
    l.fly(hold([0.0, 0.0, -10.0], 0.0), 10.0, |s| {
        late_tilt = late_tilt.max((s.state().attitude * Vector3::z()).angle(&Vector3::z()));
    });
    let v = l.sim.vehicle();
    // Where the pair's reaction torque, 2 · k_m/k_f · m·g/2, meets the drag γ·r.
    let k_m_over_k_f = v.motor.torque_coefficient_n_m_per_rad2_s2 / v.motor.thrust_coefficient_n_per_rad2_s2;
    let spin_want = k_m_over_k_f * v.mass_kg * GRAVITY_M_S2 / v.drag.yaw_n_m_per_rad_s;
    let spin = l.sim.state().angular_velocity_frd_rad_s.z.abs();
    let final_error = (l.position() - Vector3::new(0.0, 0.0, -10.0)).norm();
    println!(
        "quad, motor 1 lost: worst tilt {:.1} deg, then {:.1} deg; spin {spin:.1} rad/s (equilibrium \
         {spin_want:.1}); worst error {error:.2} m, after 20 s {final_error:.2} m",
        tilt.to_degrees(),
        late_tilt.to_degrees()
    );
    assert!(!l.ctl.mixer().has_yaw_authority() && !l.sim.crashed());
    assert!(tilt < RECOVERY_TILT_RAD, "worst tilt {tilt} rad");
    assert!(late_tilt < 0.1, "tilt after the recovery {late_tilt} rad");
    assert!((spin - spin_want).abs() < 0.05 * spin_want, "spin {spin} rad/s, want {spin_want}");
    assert!(final_error < 1.0, "{final_error} m from where it was");
}

#[test]
fn a_quad_that_lost_a_motor_descends_to_an_upright_touchdown() {
    let mut l = Loop::new(World::default(), [0.0, 0.0, -10.0], UnitQuaternion::identity());
    l.fly(hold([0.0, 0.0, -10.0], 0.0), 2.0, |_| {});
    let descend = SetpointTarget::Trajectory(TrajectorySetpoint {
        position_ned_m: [Some(0.0), Some(0.0), None],
        velocity_ned_m_s: [None, None, Some(1.5)],
        ..TrajectorySetpoint::default()
    });
    l.sim.add_fault(FaultKind::MotorLost { motor: 1 }).expect("valid fault");
    l.fly(descend, DETECTION_S, |_| {});
    l.failed_motor = Some(0);
    let (mut tilt, mut last_speed, mut touchdown): (f64, f64, Option<(f64, f64)>) = (0.0, 0.0, None);
    l.fly(descend, 20.0, |s| {
        let now = (s.state().attitude * Vector3::z()).angle(&Vector3::z());
        if s.landed() && touchdown.is_none() {
            touchdown = Some((last_speed, now));
        }
        tilt = tilt.max(now);
        last_speed = s.state().velocity_ned_m_s.norm();
    });
    let (speed, touchdown_tilt) = touchdown.expect("it reached the ground");
    println!(
        "quad, motor 1 lost, descending: worst tilt {:.1} deg; touchdown at {speed:.2} m/s, tilted \
         {:.1} deg, {:.2} m from above the start",
        tilt.to_degrees(),
        touchdown_tilt.to_degrees(),
        l.position().xy().norm()
    );
    assert!(!l.sim.crashed() && tilt < RECOVERY_TILT_RAD);
    assert!(speed < 2.0 && touchdown_tilt < 0.1, "touchdown {speed} m/s, {touchdown_tilt} rad");
}
