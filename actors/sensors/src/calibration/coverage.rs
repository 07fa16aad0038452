//! How much of the sphere of directions a compass calibration saw: 32 fixed regions (the
//! Voronoi cells of an icosahedron's 12 vertices and its 20 face centres), each sample counted
//! in the region nearest its corrected direction. ArduPilot's compass calibrator keeps a
//! similar completion mask; this is our own, coarser one.

use nalgebra::Vector3;

/// Number of regions.
pub const REGIONS: usize = 32;

/// The golden ratio, which places the icosahedron's vertices.
const PHI: f64 = 1.618_033_988_749_895;

/// The regions' centre directions (unit vectors, board FRD).
pub fn region_centres() -> [Vector3<f64>; REGIONS] {
    let mut centres = [Vector3::zeros(); REGIONS];
    let mut n = 0;
    let mut push = |v: Vector3<f64>| {
        centres[n] = v.normalize();
        n += 1;
    };
    // Icosahedron vertices: cyclic permutations of (0, ±1, ±φ).
    for (a, b) in [(1.0, PHI), (1.0, -PHI), (-1.0, PHI), (-1.0, -PHI)] {
        push(Vector3::new(0.0, a, b));
        push(Vector3::new(a, b, 0.0));
        push(Vector3::new(b, 0.0, a));
    }
    // Its face centres, the dual dodecahedron's vertices: (±1, ±1, ±1) and cyclic (0, ±φ, ±1/φ).
    for x in [1.0, -1.0] {
        for y in [1.0, -1.0] {
            for z in [1.0, -1.0] {
                push(Vector3::new(x, y, z));
            }
        }
    }
    for (a, b) in [(PHI, 1.0 / PHI), (PHI, -1.0 / PHI), (-PHI, 1.0 / PHI), (-PHI, -1.0 / PHI)] {
        push(Vector3::new(0.0, a, b));
        push(Vector3::new(a, b, 0.0));
        push(Vector3::new(b, 0.0, a));
    }
    centres
}

/// Samples per region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Coverage {
    pub counts: [u32; REGIONS],
}

impl Coverage {
    /// Counts each direction in its nearest region; zero vectors count nowhere.
    pub fn of(directions: impl IntoIterator<Item = Vector3<f64>>) -> Coverage {
        let centres = region_centres();
        let mut counts = [0u32; REGIONS];
        for d in directions {
            let Some(unit) = d.try_normalize(1e-12) else { continue };
            let nearest =
                (0..REGIONS).max_by(|&a, &b| centres[a].dot(&unit).total_cmp(&centres[b].dot(&unit)));
            if let Some(i) = nearest {
                counts[i] += 1;
            }
        }
        Coverage { counts }
    }

    /// Regions holding at least `min_samples` samples.
    pub fn covered(&self, min_samples: u32) -> usize {
        self.counts.iter().filter(|&&c| c >= min_samples.max(1)).count()
    }

    /// Bit i set when region i holds at least `min_samples` (for progress reports).
    pub fn mask(&self, min_samples: u32) -> u32 {
        self.counts
            .iter()
            .enumerate()
            .filter(|(_, c)| **c >= min_samples.max(1))
            .fold(0, |m, (i, _)| m | 1 << i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_regions_are_distinct_and_evenly_spread() {
        let centres = region_centres();
        for (i, a) in centres.iter().enumerate() {
            let nearest = centres
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, b)| a.angle(b))
                .fold(f64::MAX, f64::min);
            // Vertex to neighbouring face centre is 37.4°, face centre to face centre 41.8°.
            assert!((nearest.to_degrees() - 37.38).abs() < 0.1, "{i}: {}", nearest.to_degrees());
        }
        let all = Coverage::of(centres.iter().copied());
        assert_eq!((all.covered(1), all.mask(1)), (REGIONS, u32::MAX));
        let one = Coverage::of([Vector3::x(); 50]);
        assert_eq!(one.covered(1), 1);
    }
}
