//! Sensor chip axes → body FRD (forward, right, down).
//!
//! InvenSense and AKM parts are right-handed with Z out of the package top. How the chip sits
//! on the board, and the board in the airframe, decides which chip axis is forward: the map is
//! configuration, checked on the bench: level, the accelerometer must read about −9.8 m/s² on
//! down; pitching nose-up must give a positive rate about body right.

/// `frd[i] = sign[i] · chip[axis[i]]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct AxisMap {
    /// Which chip axis (0 = X, 1 = Y, 2 = Z) is body forward, right, down.
    pub axis: [usize; 3],
    /// Its sign (+1 or −1).
    pub sign: [f64; 3],
}

impl Default for AxisMap {
    /// Chip flat, top up, X forward: Y then points left and Z up, so FRD = (x, −y, −z).
    fn default() -> AxisMap {
        AxisMap { axis: [0, 1, 2], sign: [1.0, -1.0, -1.0] }
    }
}

impl AxisMap {
    /// `chip` in body FRD.
    pub fn to_frd(&self, chip: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| self.sign[i] * chip[self.axis[i].min(2)])
    }

    /// Whether the map is a signed permutation (each chip axis used once, signs ±1).
    pub fn is_valid(&self) -> bool {
        let mut seen = [false; 3];
        for &a in &self.axis {
            if a > 2 || seen[a] {
                return false;
            }
            seen[a] = true;
        }
        self.sign.iter().all(|&s| s == 1.0 || s == -1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_level_chip_reads_minus_g_down() {
        // A level, resting InvenSense accelerometer reads +1 g on its Z (up) axis.
        assert_eq!(AxisMap::default().to_frd([0.0, 0.0, 9.8]), [0.0, 0.0, -9.8]);
        assert!(AxisMap::default().is_valid());
        assert!(!AxisMap { axis: [0, 0, 2], sign: [1.0; 3] }.is_valid());
        assert!(!AxisMap { axis: [0, 1, 2], sign: [1.0, 0.5, 1.0] }.is_valid());
    }
}
