//! Flying on after a motor failure, closed loop (true state, no estimator): the simulator's
//! `motor_lost` fault, and the setpoint naming the failed motor from the detector's timeout on,
//! as the commander does. A quad has no such test: on three rotors the one opposite the lost
//! motor can push only one way about the diagonal through the other two, and the cascade here
//! does not hold attitude so (the fault matrix's row 13 measures what happens).

mod common;

use common::{Loop, hold};
use kestrel_proto::messages::SetpointTarget;
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
