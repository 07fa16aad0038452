//! The mixer's allocation around a failed motor (PX4 `CA_FAILURE_MODE = 1`) against an
//! independent reference: the effectiveness built here from the frame table with the failed
//! motor's column zeroed, its rank and its pseudo-inverse by nalgebra's SVD, and the wrench the
//! commands produce by the simulator's thrust and drag-torque model.

use kestrel_control::{AirframeParams, Mixer};
use kestrel_proto::frame_layout::FrameLayout;
use kestrel_proto::messages::MAX_MOTORS;
use nalgebra::{DMatrix, DVector, Vector3, Vector4};
use proptest::prelude::*;

/// Roll, pitch, yaw torque (N·m) and thrust (N) per unit command of each motor, `failed`'s
/// column zero.
fn effectiveness(airframe: &AirframeParams, failed: Option<usize>) -> DMatrix<f64> {
    let motors: Vec<_> = airframe.frame.motors(airframe.arm_length_m).collect();
    let mut b = DMatrix::zeros(4, motors.len());
    for (i, m) in motors.iter().enumerate().filter(|(i, _)| Some(*i) != failed) {
        let t = airframe.max_thrust_per_motor_n;
        let r = m.position_frd_m;
        b.set_column(
            i,
            &Vector4::new(-r.y * t, r.x * t, m.spin.yaw_sign() * airframe.torque_to_thrust_m * t, t),
        );
    }
    b
}

/// What the commands produce: roll, pitch, yaw torque and thrust.
fn wrench(airframe: &AirframeParams, motors: &[f64; MAX_MOTORS]) -> Vector4<f64> {
    let n = airframe.frame.motor_count();
    let w = effectiveness(airframe, None) * DVector::from_column_slice(&motors[..n]);
    Vector4::new(w[0], w[1], w[2], w[3])
}

fn rank(m: &DMatrix<f64>) -> usize {
    let sv = m.clone().svd(false, false).singular_values;
    sv.iter().filter(|&&s| s > 1e-9 * sv.max()).count()
}

fn hexa() -> AirframeParams {
    AirframeParams {
        mass_kg: 2.4,
        inertia_frd_kg_m2: [0.055, 0.055, 0.10],
        arm_length_m: 0.275,
        frame: FrameLayout::HexaX,
        ..AirframeParams::default()
    }
}

fn failed_mixer(airframe: &AirframeParams, motor: usize) -> Mixer {
    let mut mixer = Mixer::new(airframe);
    mixer.set_failed_motor(Some(motor)).expect("a motor of the frame");
    mixer
}

#[test]
fn one_motor_less_keeps_rank_four_on_a_hexa_and_an_octo_and_three_on_a_quad() {
    for (frame, rank_after) in [(FrameLayout::QuadX, 3), (FrameLayout::HexaX, 4), (FrameLayout::OctoX, 4)] {
        let airframe = AirframeParams { frame, ..AirframeParams::default() };
        assert_eq!(rank(&effectiveness(&airframe, None)), 4, "{frame:?}");
        for motor in 0..frame.motor_count() {
            assert_eq!(rank(&effectiveness(&airframe, Some(motor))), rank_after, "{frame:?} less {motor}");
            let mixer = failed_mixer(&airframe, motor);
            assert_eq!(mixer.has_yaw_authority(), rank_after == 4, "{frame:?} less {motor}");
            assert_eq!(mixer.failed_motor(), Some(motor));
        }
    }
    let mut mixer = Mixer::new(&hexa());
    assert_eq!(mixer.set_failed_motor(Some(6)), Err(6), "a hexa has no seventh motor");
    assert_eq!(mixer.failed_motor(), None, "a refused motor leaves the allocation as it was");
}

#[test]
fn a_hexa_without_a_motor_hovers_on_the_other_five_with_the_svd_pseudo_inverse_commands() {
    let airframe = hexa();
    let weight_n = airframe.weight_n();
    for motor in 0..6 {
        let b = effectiveness(&airframe, Some(motor));
        let pinv = b.clone().pseudo_inverse(1e-12).expect("pseudo-inverse");
        let demand = Vector4::new(0.0, 0.0, 0.0, weight_n);
        let reference = &pinv * DVector::from_column_slice(demand.as_slice());
        let out = failed_mixer(&airframe, motor).mix(&Vector3::zeros(), weight_n);
        for i in 0..6 {
            assert!(
                (out.motors[i] - reference[i]).abs() < 1e-9,
                "less {motor}: {:?} vs {reference}",
                out.motors
            );
        }
        assert_eq!(out.motors[motor], 0.0);
        assert!((wrench(&airframe, &out.motors) - demand).norm() < 1e-9, "less {motor}");
    }
}

#[test]
fn a_hexa_without_a_motor_keeps_roll_and_pitch_and_gives_yaw_where_the_opposite_motor_would_go_negative() {
    // Motor 1 (right) lost: motor 2 (left) carries no thrust in hover, and rolling left
    // without yawing would need it below zero. Roll, pitch and thrust are kept; yaw gives.
    let airframe = hexa();
    let weight_n = airframe.weight_n();
    let mixer = failed_mixer(&airframe, 0);
    for roll_n_m in [-0.5, 0.5] {
        let out = mixer.mix(&Vector3::new(roll_n_m, 0.0, 0.0), weight_n);
        let got = wrench(&airframe, &out.motors);
        assert!((got.x - roll_n_m).abs() < 1e-6 && got.y.abs() < 1e-6, "{roll_n_m}: {got}");
        assert!((got.w - weight_n).abs() < 1e-6, "{roll_n_m}: {got}");
        assert!(out.motors[..6].iter().all(|m| (0.0..=1.0).contains(m)) && out.motors[0] == 0.0);
        let b = effectiveness(&airframe, Some(0));
        let unconstrained = b.pseudo_inverse(1e-12).expect("pinv")
            * DVector::from_column_slice(&[roll_n_m, 0.0, 0.0, weight_n]);
        let needs_negative = unconstrained.iter().any(|u| *u < -1e-9);
        assert_eq!(out.saturation.yaw, needs_negative, "{roll_n_m}: {unconstrained}");
        assert!(!out.saturation.roll_pitch);
    }
}

#[test]
fn a_quad_without_a_motor_gives_up_yaw_and_meets_roll_pitch_and_thrust_on_three() {
    let airframe = AirframeParams::default();
    let weight_n = airframe.weight_n();
    let mixer = failed_mixer(&airframe, 0);
    // Roll, pitch and thrust rows only: three equations, three motors.
    let b = effectiveness(&airframe, Some(0)).select_rows(&[0, 1, 3]);
    let pinv = b.pseudo_inverse(1e-12).expect("pinv");
    // A torque motor 2 (opposite, the only one with a lever about the other diagonal) can give.
    let demand = Vector3::new(0.05, -0.05, 0.3);
    let reference = &pinv * DVector::from_column_slice(&[demand.x, demand.y, weight_n]);
    let out = mixer.mix(&demand, weight_n);
    let got = wrench(&airframe, &out.motors);
    for i in 0..4 {
        assert!((out.motors[i] - reference[i]).abs() < 1e-9, "{:?} vs {reference}", out.motors);
    }
    assert!(
        (got.x - demand.x).abs() < 1e-9 && (got.y - demand.y).abs() < 1e-9 && (got.w - weight_n).abs() < 1e-9
    );
    assert!(out.saturation.yaw, "yaw is not allocated: the rate loop must not wind up on it");
}

proptest! {
    /// Around any failed motor of a hexa or octo, a demand whose pseudo-inverse commands lie in
    /// 0..1 is met exactly, by those commands; whatever the demand, commands stay in 0..1 and
    /// the failed motor gets none.
    #[test]
    fn feasible_demands_are_met_exactly_around_a_failed_motor(
        octo in any::<bool>(), motor in 0usize..8, tx in -1.0f64..1.0, ty in -1.0f64..1.0,
        tz in -0.3f64..0.3, thrust in 0.0f64..60.0,
    ) {
        let airframe = if octo { AirframeParams { frame: FrameLayout::OctoX, ..hexa() } } else { hexa() };
        let n = airframe.frame.motor_count();
        let motor = motor % n;
        let out = failed_mixer(&airframe, motor).mix(&Vector3::new(tx, ty, tz), thrust);
        prop_assert!(out.motors.iter().all(|m| (0.0..=1.0).contains(m)), "{:?}", out.motors);
        prop_assert_eq!(out.motors[motor], 0.0);
        let pinv = effectiveness(&airframe, Some(motor)).pseudo_inverse(1e-12).expect("pinv");
        let reference = pinv * DVector::from_column_slice(&[tx, ty, tz, thrust]);
        if reference.iter().all(|u| (1e-9..=1.0 - 1e-9).contains(u) || u.abs() < 1e-12) {
            for i in 0..n {
                prop_assert!((out.motors[i] - reference[i]).abs() < 1e-7, "{:?} vs {}", out.motors, reference);
            }
        }
    }
}
