//! Attitude conversions: a message's `[w, x, y, z]` into a rotation, and quaternion ↔ Euler
//! angles, the latter for display, telemetry and error reports only: controllers and the
//! estimator work on quaternions and rotation matrices, never on Euler angles.

use nalgebra::{Quaternion, UnitQuaternion};

/// A `[w, x, y, z]` that names no rotation.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("attitude quaternion {0:?} is not a rotation (non-finite, or shorter than {MIN_NORM})")]
pub struct NotARotation(pub [f64; 4]);

/// The shortest `[w, x, y, z]` taken as a rotation. Messages carry unit quaternions up to
/// rounding; one under half a unit long is a zero, an uninitialised or a corrupted value, and
/// normalising it would turn noise into an arbitrary attitude.
pub const MIN_NORM: f64 = 0.5;

/// The rotation (body FRD → NED) of a message's `[w, x, y, z]`, normalised.
///
/// An error rather than identity for a zero or non-finite quaternion: identity is a level,
/// north-facing attitude that a controller would fly as if it were true, so each caller decides
/// what a missing attitude means for it (the controller flies blind and counts it, the
/// commander ignores the state).
pub fn unit_quaternion(q: [f64; 4]) -> Result<UnitQuaternion<f64>, NotARotation> {
    let [w, x, y, z] = q;
    let raw = Quaternion::new(w, x, y, z);
    if q.iter().all(|v| v.is_finite()) && raw.norm() >= MIN_NORM {
        Ok(UnitQuaternion::from_quaternion(raw))
    } else {
        Err(NotARotation(q))
    }
}

/// A rotation as a message's `[w, x, y, z]`.
pub fn wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

/// Angle (rad, 0..π) of the body's down axis from NED down for the attitude `q` (body FRD →
/// NED): 1 − 2(x² + y²) is that angle's cosine, exact at level (0, where the angle between two
/// rotated vectors would round to about 1e-8 rad).
pub fn tilt_rad(q: &UnitQuaternion<f64>) -> f64 {
    (1.0 - 2.0 * (q.i * q.i + q.j * q.j)).clamp(-1.0, 1.0).acos()
}

/// Roll, pitch, yaw (rad) of the attitude quaternion `[w, x, y, z]` (body FRD → NED), in the
/// aerospace Z-Y-X convention: yaw about down, then pitch about the new right axis, then roll
/// about forward. Pitch is clamped to ±90° at the singularity.
pub fn euler_rad(q: [f64; 4]) -> [f64; 3] {
    let [w, x, y, z] = q;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

/// The attitude quaternion `[w, x, y, z]` with these roll, pitch, yaw (rad), Z-Y-X.
pub fn quaternion_from_euler(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
}

/// `a − b` wrapped into (−π, π] (rad).
pub fn angle_difference_rad(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    if d > std::f64::consts::PI { d - std::f64::consts::TAU } else { d }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn zero_and_non_finite_quaternions_are_no_rotation() {
        for q in [[0.0; 4], [0.1, 0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0, 1.0], [1.0, f64::INFINITY, 0.0, 0.0]] {
            assert!(unit_quaternion(q).is_err(), "{q:?}");
        }
        let q = unit_quaternion([2.0, 0.0, 0.0, 0.0]).expect("a long quaternion is normalised");
        assert_eq!(wxyz(&q), [1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn a_pure_yaw_of_ninety_degrees() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let [r, p, y] = euler_rad([h, 0.0, 0.0, h]);
        assert!(r.abs() < 1e-12 && p.abs() < 1e-12 && (y - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn differences_wrap_across_north() {
        assert!((angle_difference_rad(0.1, -0.1) - 0.2).abs() < 1e-12);
        assert!((angle_difference_rad(-3.1, 3.1) - (std::f64::consts::TAU - 6.2)).abs() < 1e-12);
    }

    proptest! {
        #[test]
        fn tilt_is_the_angle_of_body_down_from_ned_down(roll in -3.1f64..3.1, pitch in -1.5f64..1.5, yaw in -3.1f64..3.1) {
            let q = unit_quaternion(quaternion_from_euler(roll, pitch, yaw)).expect("a rotation");
            let down = nalgebra::Vector3::z();
            // Body down in NED is (.., .., cos θ · cos φ): the tilt's cosine, whatever the yaw.
            prop_assert!((tilt_rad(&q) - (q * down).angle(&down)).abs() < 1e-6);
            prop_assert!((tilt_rad(&q).cos() - pitch.cos() * roll.cos()).abs() < 1e-9);
        }

        #[test]
        fn euler_round_trip(roll in -3.1f64..3.1, pitch in -1.5f64..1.5, yaw in -3.1f64..3.1) {
            let [r, p, y] = euler_rad(quaternion_from_euler(roll, pitch, yaw));
            prop_assert!(angle_difference_rad(r, roll).abs() < 1e-9);
            prop_assert!((p - pitch).abs() < 1e-9);
            prop_assert!(angle_difference_rad(y, yaw).abs() < 1e-9);
        }
    }
}
