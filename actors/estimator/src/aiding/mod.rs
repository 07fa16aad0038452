//! The aiding sources, one file each: when to fuse (checks, gates, timeouts, resets) and the
//! maths of the observation (PX4 EKF2's `aid_sources/*`).

pub mod baro;
pub mod gps;
pub mod mag;
pub mod mag_yaw_reset;

use kestrel_proto::messages::Innovation;

/// An innovation `y` with variance `s`, gated at `gate_sigma` standard deviations.
pub fn innovation(y: f64, s: f64, gate_sigma: f64) -> Innovation {
    let test_ratio = if s > 0.0 { y * y / (gate_sigma * gate_sigma * s) } else { f64::INFINITY };
    Innovation { innovation: y, variance: s, test_ratio }
}

/// Whether every innovation passes its chi-square gate.
pub fn passes(innovations: &[Innovation]) -> bool {
    innovations.iter().all(|i| i.test_ratio <= 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_ratio_is_one_at_the_gate() {
        assert!((innovation(5.0, 1.0, 5.0).test_ratio - 1.0).abs() < 1e-12);
        assert!(passes(&[innovation(4.9, 1.0, 5.0)]));
        assert!(!passes(&[innovation(0.0, 1.0, 5.0), innovation(10.0, 1.0, 5.0)]));
    }
}
