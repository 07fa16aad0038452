//! What stands in the vehicle's own path, from the full-resolution `OBSTACLE_DISTANCE` sectors
//! rather than the 3×3 grid (thin objects).
//!
//! Why: a region's nearest depth is a low percentile of its pixels (so a speckle cannot define
//! it), and a 10 cm pole is too few pixels of the centre region to reach that percentile
//! until it is close. In front of a textured backdrop at 320 × 240 the centre region's nearest
//! depth read 6.15 m with the pole 4.95 m ahead: the speed cap would have vouched for 1.2 m
//! more than there was, beyond its 1 m margin (tests/vision_detection_range.rs). Each sector keeps the
//! nearest return of its columns, so the pole is there from about 10 m out. Only sectors whose
//! return can lie in the vehicle's corridor count: a trunk 3 m beside the path must not hold
//! the vehicle back.
//!
//! PX4's collision prevention limits the velocity towards every one of its 72 bins; here the
//! forward speed is capped by what is in the corridor, and the obstacle memory limits the
//! velocity towards every sector's return, in view or not ([`crate::avoidance::memory`]).

use kestrel_proto::messages::ObstacleSectors;

/// The distance along the body's forward axis (m, from the camera) to the nearest obstacle
/// return of `sectors` that can lie within `half_width_m` of that axis; `None` when none can.
///
/// A sector tells its return's range, not its bearing within the sector's width, so each
/// return is taken at the sector's edge nearest the axis, where it would be closest to the
/// path: a sector `[a, b]` with `0 ∉ [a, b]` counts when `range · sin(min(|a|, |b|)) ≤
/// half_width_m`, and its distance ahead is `range · cos(min(|a|, |b|))`. Sectors behind the
/// vehicle's beam (edge at 90° or more) never count.
pub fn nearest_in_path_m(sectors: &ObstacleSectors, half_width_m: f64) -> Option<f64> {
    let half_sector_deg = f64::from(sectors.increment_deg) / 2.0;
    (0..sectors.distances_cm.len())
        .filter_map(|index| {
            let range_m = sectors.obstacle_m(index)?;
            let edge_deg = (sectors.bearing_deg(index).abs() - half_sector_deg).max(0.0);
            if edge_deg >= 90.0 {
                return None;
            }
            let (sin, cos) = edge_deg.to_radians().sin_cos();
            (range_m * sin <= half_width_m).then_some(range_m * cos)
        })
        .min_by(f64::total_cmp)
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::OBSTACLE_SECTORS;
    use proptest::prelude::*;

    use super::*;

    /// 72 sectors of 5° from straight ahead, 0.3–20 m, all unknown but `set`.
    fn sectors(set: &[(usize, u16)]) -> ObstacleSectors {
        crate::avoidance::test_sectors(set.iter().copied())
    }

    #[test]
    fn a_return_straight_ahead_counts_at_its_range() {
        assert_eq!(nearest_in_path_m(&sectors(&[(0, 734)]), 0.75), Some(7.34));
    }

    #[test]
    fn no_information_free_sectors_and_returns_below_the_minimum_are_not_obstacles() {
        assert_eq!(nearest_in_path_m(&sectors(&[]), 0.75), None);
        assert_eq!(nearest_in_path_m(&sectors(&[(0, 2001), (1, 29)]), 0.75), None);
    }

    #[test]
    fn a_side_sector_counts_only_while_its_nearest_edge_is_inside_the_corridor() {
        // Sector 2 spans 7.5°..12.5°: its return can come within r·sin 7.5° of the axis.
        let edge = 7.5_f64.to_radians();
        let reach_cm = (0.75 / edge.sin() * 100.0).floor() as u16;
        let inside = nearest_in_path_m(&sectors(&[(2, reach_cm)]), 0.75).unwrap();
        assert!((inside - f64::from(reach_cm) / 100.0 * edge.cos()).abs() < 1e-9);
        assert_eq!(nearest_in_path_m(&sectors(&[(2, reach_cm + 1)]), 0.75), None);
        // Mirrored on the left (sector 70 spans −12.5°..−7.5°).
        assert!(nearest_in_path_m(&sectors(&[(70, reach_cm)]), 0.75).is_some());
        assert_eq!(nearest_in_path_m(&sectors(&[(70, reach_cm + 1)]), 0.75), None);
    }

    #[test]
    fn sectors_behind_never_count_and_abeam_only_inside_the_corridor() {
        // Straight behind (sector 36) and its neighbours, however near.
        assert_eq!(nearest_in_path_m(&sectors(&[(35, 30), (36, 30), (37, 30)]), 0.75), None);
        // Abeam (18: 87.5°..92.5°; 54 on the left): 1 m out is beside the corridor, 0.5 m out
        // is in it, 2 cm ahead of the camera.
        assert_eq!(nearest_in_path_m(&sectors(&[(18, 100), (54, 100)]), 0.75), None);
        let beside = nearest_in_path_m(&sectors(&[(54, 50)]), 0.75).unwrap();
        assert!((beside - 0.5 * 87.5_f64.to_radians().cos()).abs() < 1e-9);
    }

    proptest! {
        /// The answer is the distance ahead of a counted sector, no sector nearer than it
        /// counts, and every counted return lies within the corridor at its nearest edge.
        #[test]
        fn the_nearest_counted_return_is_the_answer(
            set in proptest::collection::vec((0usize..OBSTACLE_SECTORS, 0u16..2100), 0..20),
            half_width_m in 0.1f64..3.0,
        ) {
            let s = sectors(&set);
            let counted: Vec<f64> = (0..OBSTACLE_SECTORS)
                .filter_map(|i| {
                    let range = s.obstacle_m(i)?;
                    let centre = s.bearing_deg(i);
                    // The edge nearest the axis, by brute force over the sector's width.
                    let edge = (0..=500)
                        .map(|k| (centre - 2.5 + 5.0 * f64::from(k) / 500.0).abs())
                        .fold(f64::INFINITY, f64::min);
                    (edge < 90.0 && range * edge.to_radians().sin() <= half_width_m + 1e-9)
                        .then(|| range * edge.to_radians().cos())
                })
                .collect();
            let nearest = counted.iter().copied().fold(None, |m: Option<f64>, d| Some(m.map_or(d, |m| m.min(d))));
            match (nearest_in_path_m(&s, half_width_m), nearest) {
                (Some(a), Some(b)) => prop_assert!((a - b).abs() < 1e-6, "{a} vs {b}"),
                (a, b) => prop_assert_eq!(a, b),
            }
        }
    }
}
