//! A random forest of trees (vertical cylinders) from a seed: the world file's `[forest]`, for
//! the obstacle-avoidance tests of many random layouts (issue: ≥ 20 trees on a 100 m leg).

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, finite};
use crate::obstacles::Obstacle;

/// Tries per tree before the layout is declared too crowded for the area.
const TRIES_PER_TREE: usize = 1000;

/// `[forest]`: trees placed uniformly at random in a rectangle, keeping a gap between trunks
/// so that the vehicle can pass between any two, and keeping clear circles (take-off and
/// landing spots) free.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Forest {
    /// Seed of the layout: the same seed gives the same trees.
    pub seed: u64,
    /// Number of trees, at most [`MAX_TREES`].
    pub trees: usize,
    /// North extent of the trunks' centres, `[from, to]` (m from home).
    pub north_m: [f64; 2],
    /// East extent of the trunks' centres, `[from, to]` (m from home).
    pub east_m: [f64; 2],
    /// Trunk radius range `[min, max]` (m).
    pub radius_m: [f64; 2],
    /// Height range `[min, max]` (m).
    pub height_m: [f64; 2],
    /// Least gap between two trunks' surfaces (m).
    pub min_gap_m: f64,
    /// Points `[north, east]` (m) that no trunk comes within `keep_clear_radius_m` of.
    #[serde(default)]
    pub keep_clear_ne_m: Vec<[f64; 2]>,
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
            ("north_m", self.north_m),
            ("east_m", self.east_m),
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
        finite("min_gap_m", &[self.min_gap_m, self.keep_clear_radius_m])?;
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
            let at = [uniform(&mut rng, self.north_m), uniform(&mut rng, self.east_m)];
            let radius = uniform(&mut rng, self.radius_m);
            let distance = |p: [f64; 2]| (at[0] - p[0]).hypot(at[1] - p[1]);
            let crowded = trunks.iter().any(|&(p, r)| distance(p) - r - radius < self.min_gap_m)
                || self.keep_clear_ne_m.iter().any(|&p| distance(p) - radius < self.keep_clear_radius_m);
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
}

fn uniform(rng: &mut Pcg64, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo { rng.random_range(lo..hi) } else { lo }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn forest(seed: u64) -> Forest {
        Forest {
            seed,
            trees: 24,
            north_m: [15.0, 90.0],
            east_m: [-6.0, 6.0],
            radius_m: [0.3, 0.8],
            height_m: [8.0, 15.0],
            min_gap_m: 3.0,
            keep_clear_ne_m: vec![[0.0, 0.0], [100.0, 0.0]],
            keep_clear_radius_m: 5.0,
        }
    }

    #[test]
    fn the_same_seed_plants_the_same_trees_and_gaps_are_kept() {
        let a = forest(3).plant().expect("fits");
        assert_eq!(a, forest(3).plant().expect("fits"));
        assert_ne!(a, forest(4).plant().expect("fits"));
        assert_eq!(a.len(), 24);
        let trunks: Vec<([f64; 2], f64)> = a
            .iter()
            .map(|o| match o {
                Obstacle::Cylinder { base_ne_m, radius_m, height_m } => {
                    assert!((8.0..=15.0).contains(height_m));
                    (*base_ne_m, *radius_m)
                }
                other => panic!("not a tree: {other:?}"),
            })
            .collect();
        for (i, (p, r)) in trunks.iter().enumerate() {
            assert!((15.0..=90.0).contains(&p[0]) && (-6.0..=6.0).contains(&p[1]));
            for (q, s) in &trunks[i + 1..] {
                assert!((p[0] - q[0]).hypot(p[1] - q[1]) - r - s >= 3.0);
            }
        }
    }

    #[test]
    fn a_forest_too_dense_for_its_area_is_refused() {
        let crowded = Forest { trees: 500, ..forest(1) };
        let e = crowded.plant().expect_err("cannot fit");
        assert!(e.to_string().contains("trees"), "{e}");
    }
}
