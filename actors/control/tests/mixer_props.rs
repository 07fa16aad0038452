//! Property tests of the mixer: whatever the demand, commands stay in 0..1, and saturation
//! never reverses the roll or pitch torque.

use kestrel_control::{AirframeParams, Mixer};
use kestrel_proto::frame_layout::FrameLayout;
use nalgebra::Vector3;
use proptest::prelude::*;

fn torque_of(airframe: &AirframeParams, motors: &[f64]) -> Vector3<f64> {
    airframe.frame.motors(airframe.arm_length_m).zip(motors).fold(Vector3::zeros(), |acc, (m, &u)| {
        let (r, t) = (m.position_frd_m, u * airframe.max_thrust_per_motor_n);
        acc + Vector3::new(-r.y * t, r.x * t, m.spin.yaw_sign() * airframe.torque_to_thrust_m * t)
    })
}

fn frame() -> impl Strategy<Value = FrameLayout> {
    prop_oneof![Just(FrameLayout::QuadX), Just(FrameLayout::HexaX), Just(FrameLayout::OctoX)]
}

proptest! {
    #[test]
    fn commands_stay_within_zero_and_one(
        frame in frame(), tx in -20.0f64..20.0, ty in -20.0f64..20.0, tz in -5.0f64..5.0, thrust in -10.0f64..200.0,
    ) {
        let airframe = AirframeParams { frame, ..AirframeParams::default() };
        let out = Mixer::new(&airframe).mix(&Vector3::new(tx, ty, tz), thrust);
        prop_assert!(out.motors.iter().all(|m| (0.0..=1.0).contains(m)), "{:?}", out.motors);
        prop_assert!(out.motors[frame.motor_count()..].iter().all(|m| *m == 0.0));
    }

    #[test]
    fn saturation_keeps_the_sign_and_ratio_of_roll_and_pitch(
        frame in frame(), tx in -20.0f64..20.0, ty in -20.0f64..20.0, tz in -5.0f64..5.0, thrust in 0.0f64..60.0,
    ) {
        prop_assume!(tx.abs() > 0.05 && ty.abs() > 0.05);
        let airframe = AirframeParams { frame, ..AirframeParams::default() };
        let out = Mixer::new(&airframe).mix(&Vector3::new(tx, ty, tz), thrust);
        let got = torque_of(&airframe, &out.motors);
        prop_assert!(got.x * tx > 0.0 && got.y * ty > 0.0, "asked {tx}, {ty}; got {got}");
        prop_assert!((got.x / got.y - tx / ty).abs() < 1e-6 * (1.0 + (tx / ty).abs()), "ratio changed: {got}");
        // Yaw may shrink but never reverse.
        prop_assert!(got.z * tz >= -1e-9, "yaw reversed: asked {tz}, got {}", got.z);
    }

    #[test]
    fn feasible_demands_are_met_exactly(
        frame in frame(), tx in -0.3f64..0.3, ty in -0.3f64..0.3, tz in -0.05f64..0.05, share in 0.3f64..0.6,
    ) {
        let airframe = AirframeParams { frame, ..AirframeParams::default() };
        let mixer = Mixer::new(&airframe);
        let thrust = share * mixer.full_thrust_n();
        let out = mixer.mix(&Vector3::new(tx, ty, tz), thrust);
        let got = torque_of(&airframe, &out.motors);
        prop_assert!((got - Vector3::new(tx, ty, tz)).norm() < 1e-9, "{got}");
        let total: f64 = out.motors.iter().sum::<f64>() * airframe.max_thrust_per_motor_n;
        prop_assert!((total - thrust).abs() < 1e-9);
    }
}
