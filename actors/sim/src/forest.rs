//! A random forest of trees (vertical cylinders) from a seed: the world file's `[forest]`, for
//! the obstacle-avoidance tests of many random layouts (issue: ≥ 20 trees on a 100 m leg).

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, finite, non_negative};
use crate::obstacles::Obstacle;

/// Tries per tree before the layout is declared too crowded for the area.
const TRIES_PER_TREE: usize = 1000;

/// `[forest]`: trees placed uniformly at random in a rectangle laid along a bearing from home
/// (a leg's heading, so that legs at any heading fly through the same kind of forest), keeping a
/// gap between trunks so that the vehicle can pass between any two, and keeping clear circles
/// (take-off and landing spots) free.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Forest {
    /// Seed of the layout: the same seed gives the same trees.
    pub seed: u64,
    /// Number of trees, at most [`MAX_TREES`].
    pub trees: usize,
    /// Bearing of the rectangle's along-track axis, clockwise from north (deg, `[0, 360)`);
    /// 0 lays `along_m` north and `cross_m` east.
    #[serde(default)]
    pub heading_deg: f64,
    /// Along-track extent of the trunks' centres, `[from, to]` (m from home along `heading_deg`).
    pub along_m: [f64; 2],
    /// Cross-track extent of the trunks' centres, `[from, to]` (m from home, right of the
    /// along-track axis positive).
    pub cross_m: [f64; 2],
    /// Trunk radius range `[min, max]` (m).
    pub radius_m: [f64; 2],
    /// Height range `[min, max]` (m).
    pub height_m: [f64; 2],
    /// Least gap between two trunks' surfaces (m).
    pub min_gap_m: f64,
    /// Points `[along, cross]` (m, turned with the rectangle, so a leg's ends stay clear at any
    /// heading) that no trunk comes within `keep_clear_radius_m` of.
    #[serde(default)]
    pub keep_clear_m: Vec<[f64; 2]>,
    /// Radius of the clear circles (m).
    #[serde(default)]
    pub keep_clear_radius_m: f64,
}

/// The most trees a forest may hold: a hundred times the test forest's 24, and few enough that
/// placing them (each tried against every other) and ray-casting them stays quick.
pub const MAX_TREES: usize = 10_000;

impl Forest {
    /// Checks the ranges.
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        if self.trees > MAX_TREES {
            return Err(InvalidParam::new(
                "trees",
                format!("must be at most {MAX_TREES}, got {}", self.trees),
            ));
        }
        for (field, [lo, hi]) in [
            ("along_m", self.along_m),
            ("cross_m", self.cross_m),
            ("radius_m", self.radius_m),
            ("height_m", self.height_m),
        ] {
            finite(field, &[lo, hi])?;
            if lo > hi {
                return Err(InvalidParam::new(field, format!("[{lo}, {hi}] must be [min, max]")));
            }
        }
        if self.radius_m[0] <= 0.0 || self.height_m[0] <= 0.0 {
            return Err(InvalidParam::new("radius_m", "radii and heights must be > 0"));
        }
        if !(0.0..360.0).contains(&self.heading_deg) {
            return Err(InvalidParam::new(
                "heading_deg",
                format!("must be a bearing in [0, 360) degrees, got {}", self.heading_deg),
            ));
        }
        non_negative("min_gap_m", self.min_gap_m)?;
        non_negative("keep_clear_radius_m", self.keep_clear_radius_m)?;
        for point in &self.keep_clear_m {
            finite("keep_clear_m", point)?;
        }
        Ok(())
    }

    /// The trees, always the same for the same parameters.
    pub fn plant(&self) -> Result<Vec<Obstacle>, InvalidParam> {
        let mut rng = Pcg64::seed_from_u64(self.seed);
        let mut trunks: Vec<([f64; 2], f64)> = Vec::with_capacity(self.trees);
        let mut tries = 0;
        while trunks.len() < self.trees {
            tries += 1;
            if tries > TRIES_PER_TREE * self.trees.max(1) {
                return Err(InvalidParam::new(
                    "trees",
                    format!(
                        "only {} of {} trees fit with a {} m gap",
                        trunks.len(),
                        self.trees,
                        self.min_gap_m
                    ),
                ));
            }
            let at = self.to_ne([uniform(&mut rng, self.along_m), uniform(&mut rng, self.cross_m)]);
            let radius = uniform(&mut rng, self.radius_m);
            let distance = |p: [f64; 2]| (at[0] - p[0]).hypot(at[1] - p[1]);
            let crowded = trunks.iter().any(|&(p, r)| distance(p) - r - radius < self.min_gap_m)
                || self
                    .keep_clear_m
                    .iter()
                    .any(|&p| distance(self.to_ne(p)) - radius < self.keep_clear_radius_m);
            if !crowded {
                trunks.push((at, radius));
            }
        }
        Ok(trunks
            .into_iter()
            .map(|(base_ne_m, radius_m)| Obstacle::Cylinder {
                base_ne_m,
                radius_m,
                height_m: uniform(&mut rng, self.height_m),
            })
            .collect())
    }

    /// North, east (m from home) of a point `[along, cross]` (m) of the rectangle.
    fn to_ne(&self, [along, cross]: [f64; 2]) -> [f64; 2] {
        let (sin, cos) = self.heading_deg.to_radians().sin_cos();
        [along * cos - cross * sin, along * sin + cross * cos]
    }
}

fn uniform(rng: &mut Pcg64, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo { rng.random_range(lo..hi) } else { lo }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn forest(seed: u64) -> Forest {
        Forest {
            seed,
            trees: 24,
            heading_deg: 0.0,
            along_m: [15.0, 90.0],
            cross_m: [-6.0, 6.0],
            radius_m: [0.3, 0.8],
            height_m: [8.0, 15.0],
            min_gap_m: 3.0,
            keep_clear_m: vec![[0.0, 0.0], [100.0, 0.0]],
            keep_clear_radius_m: 5.0,
        }
    }

    /// Each tree as `([along, cross], radius, height)` in `forest`'s rectangle, turned back from
    /// north and east by the heading independently of [`Forest::to_ne`].
    fn in_rectangle(forest: &Forest, trees: &[Obstacle]) -> Vec<([f64; 2], f64, f64)> {
        let h = forest.heading_deg.to_radians();
        trees
            .iter()
            .map(|o| match o {
                Obstacle::Cylinder { base_ne_m: [n, e], radius_m, height_m } => {
                    ([n * h.cos() + e * h.sin(), e * h.cos() - n * h.sin()], *radius_m, *height_m)
                }
                other => panic!("not a tree: {other:?}"),
            })
            .collect()
    }

    /// Every tree inside the rectangle, its radius and height in range, the gaps kept and the
    /// clear circles clear (to a micrometre of rounding in the turn).
    fn check_layout(forest: &Forest, trees: &[Obstacle]) {
        let within = |[lo, hi]: [f64; 2], v: f64| v >= lo - 1e-6 && v <= hi + 1e-6;
        let trunks = in_rectangle(forest, trees);
        assert_eq!(trunks.len(), forest.trees);
        for (i, &([a, c], r, h)) in trunks.iter().enumerate() {
            assert!(within(forest.along_m, a) && within(forest.cross_m, c), "tree {i} at {a}, {c}");
            assert!(within(forest.radius_m, r) && within(forest.height_m, h), "tree {i}: {r} m, {h} m");
            for &([b, d], s, _) in &trunks[i + 1..] {
                assert!((a - b).hypot(c - d) - r - s >= forest.min_gap_m - 1e-6, "gap at {a}, {c}");
            }
            for &[b, d] in &forest.keep_clear_m {
                assert!((a - b).hypot(c - d) - r >= forest.keep_clear_radius_m - 1e-6, "clear of {b}, {d}");
            }
        }
    }

    #[test]
    fn the_same_seed_plants_the_same_trees_and_gaps_are_kept() {
        let a = forest(3).plant().expect("fits");
        assert_eq!(a, forest(3).plant().expect("fits"));
        assert_ne!(a, forest(4).plant().expect("fits"));
        check_layout(&forest(3), &a);
    }

    #[test]
    fn at_heading_0_along_is_north_and_cross_is_east() {
        let trees = forest(5).plant().expect("fits");
        for ([a, c], ..) in in_rectangle(&forest(5), &trees) {
            assert!((15.0..=90.0).contains(&a) && (-6.0..=6.0).contains(&c), "{a}, {c}");
        }
        for o in &trees {
            let Obstacle::Cylinder { base_ne_m: [n, e], .. } = o else { panic!("not a tree: {o:?}") };
            assert!((15.0..=90.0).contains(n) && (-6.0..=6.0).contains(e), "{n} N, {e} E");
        }
    }

    #[test]
    fn a_forest_at_90_deg_lies_east_and_one_at_225_deg_south_west() {
        let east = Forest { heading_deg: 90.0, ..forest(2) }.plant().expect("fits");
        for o in &east {
            let Obstacle::Cylinder { base_ne_m: [n, e], .. } = o else { panic!("not a tree: {o:?}") };
            assert!((14.99..=90.01).contains(e) && (-6.01..=6.01).contains(n), "{n} N, {e} E");
        }
        let south_west = Forest { heading_deg: 225.0, ..forest(2) }.plant().expect("fits");
        for o in &south_west {
            let Obstacle::Cylinder { base_ne_m: [n, e], .. } = o else { panic!("not a tree: {o:?}") };
            // 15–90 m along the bearing, ±6 m across it: south and west of home, near its diagonal.
            assert!(*n < 0.0 && *e < 0.0 && (n - e).abs() <= 6.0 * 2f64.sqrt() + 1e-6, "{n} N, {e} E");
        }
    }

    #[test]
    fn a_forest_too_dense_for_its_area_is_refused() {
        let crowded = Forest { trees: 500, ..forest(1) };
        let e = crowded.plant().expect_err("cannot fit");
        assert!(e.to_string().contains("trees"), "{e}");
    }

    #[test]
    fn a_heading_outside_a_bearing_and_a_negative_gap_are_refused() {
        for heading_deg in [360.0, -1.0, f64::NAN] {
            let e = Forest { heading_deg, ..forest(1) }.validate().expect_err("not a bearing");
            assert!(e.to_string().contains("heading_deg"), "{e}");
        }
        let e = Forest { min_gap_m: -1.0, ..forest(1) }.validate().expect_err("negative gap");
        assert!(e.to_string().contains("min_gap_m"), "{e}");
        assert!(Forest { heading_deg: 359.9, ..forest(1) }.validate().is_ok());
    }

    proptest! {
        #[test]
        fn any_heading_keeps_trees_in_the_turned_rectangle_gaps_and_clear_circles(
            seed in any::<u64>(),
            heading_deg in 0.0f64..360.0,
            trees in 1usize..12,
            min_gap_m in 0.0f64..3.0,
            radius_lo in 0.1f64..0.5,
            radius_span in 0.0f64..0.5,
        ) {
            let f = Forest {
                seed,
                trees,
                heading_deg,
                along_m: [5.0, 45.0],
                cross_m: [-8.0, 4.0],
                radius_m: [radius_lo, radius_lo + radius_span],
                min_gap_m,
                keep_clear_m: vec![[0.0, 0.0], [50.0, 0.0], [25.0, -2.0]],
                keep_clear_radius_m: 3.0,
                ..forest(seed)
            };
            let planted = f.plant().expect("fits");
            prop_assert_eq!(&planted, &f.plant().expect("fits"));
            check_layout(&f, &planted);
        }
    }
}
