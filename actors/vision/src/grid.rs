//! The depth grid (thesis §3.3.1–3.3.3 with DESIGN.md's correction): the depth image split
//! into 3×3 regions, each summarised by its share of near pixels, its share of pixels without
//! a depth and its nearest depth (a low percentile, so one speckle cannot define it); and the
//! same depth as `OBSTACLE_DISTANCE` sectors.
//!
//! The camera is assumed to look along the body's forward axis, image right = body right,
//! image down = body down (FRD); a mounting rotation is not modelled.

use kestrel_proto::Time;
use kestrel_proto::messages::{DepthGrid, GridRegion, OBSTACLE_SECTORS, ObstacleSectors, SECTOR_UNKNOWN};
use serde::{Deserialize, Serialize};

use crate::depth::{DepthMap, FixedPointDepth, StereoGeometry};
use crate::error::VisionError;

/// Width of one `OBSTACLE_DISTANCE` sector (deg): 72 sectors cover the full circle.
pub const SECTOR_DEG: f32 = 360.0 / OBSTACLE_SECTORS as f32;

/// How the depth image is summarised.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GridParams {
    /// A valid pixel nearer than this is an obstacle (m); the thesis uses 5 m (max speed 5 m/s
    /// × 1 s).
    pub threshold_m: f32,
    /// Where the left|centre and centre|right columns meet, as fractions of the image width.
    pub column_edges: [f32; 2],
    /// Where the up|centre and centre|down rows meet, as fractions of the image height.
    pub row_edges: [f32; 2],
    /// Nearest distance the sectors report (cm).
    pub min_distance_cm: u16,
    /// Farthest distance the sectors report (cm); beyond it a sector reads "free". Also the
    /// top of the centimetre histogram behind each region's nearest depth.
    pub max_distance_cm: u16,
    /// A region's nearest depth is this percentile (%) of its valid depths, 0..=50: a blob of
    /// wrong disparities smaller than this share of the region cannot pull it in. 0 gives the
    /// raw minimum.
    pub nearest_percentile: f32,
}

impl Default for GridParams {
    /// Thirds of the image (thesis Figure 3.29), 5 m threshold, sectors 0.3–20 m (the ZED's
    /// range), nearest depth at the 2nd percentile (~700 px of a VGA region, several times
    /// the largest speckle the default SGBM speckle filter lets through, 100 px).
    fn default() -> Self {
        GridParams {
            threshold_m: 5.0,
            column_edges: [1.0 / 3.0, 2.0 / 3.0],
            row_edges: [1.0 / 3.0, 2.0 / 3.0],
            min_distance_cm: 30,
            max_distance_cm: 2000,
            nearest_percentile: 2.0,
        }
    }
}

impl GridParams {
    /// Rejects a threshold or layout that cannot be used.
    pub fn check(&self) -> Result<(), VisionError> {
        if !(self.threshold_m.is_finite() && self.threshold_m > 0.0) {
            return Err(VisionError::Params(format!(
                "grid threshold {} m must be positive",
                self.threshold_m
            )));
        }
        for (what, [a, b]) in [("column_edges", self.column_edges), ("row_edges", self.row_edges)] {
            if !(0.0 < a && a < b && b < 1.0) {
                return Err(VisionError::Params(format!(
                    "{what} [{a}, {b}] must satisfy 0 < first < second < 1"
                )));
            }
        }
        if self.min_distance_cm >= self.max_distance_cm || self.max_distance_cm == SECTOR_UNKNOWN {
            return Err(VisionError::Params(format!(
                "sector range {}..{} cm must be increasing and below {SECTOR_UNKNOWN}",
                self.min_distance_cm, self.max_distance_cm
            )));
        }
        if !(0.0..=50.0).contains(&self.nearest_percentile) {
            return Err(VisionError::Params(format!(
                "nearest_percentile {} must be in 0..=50",
                self.nearest_percentile
            )));
        }
        Ok(())
    }
}

/// Which of the three bands each of `n` pixels falls in, given the two edge fractions.
fn bands(n: usize, edges: [f32; 2], out: &mut Vec<u8>) {
    let cut = |f: f32| (f * n as f32).round() as usize;
    let (a, b) = (cut(edges[0]), cut(edges[1]));
    out.clear();
    out.extend((0..n).map(|i| u8::from(i >= a) + u8::from(i >= b)));
}

/// The grid of one depth map, built with a fresh [`DepthGridder`]. Per-frame callers keep a
/// gridder instead, which allocates nothing but the message.
pub fn depth_grid(
    depth: &DepthMap,
    geometry: &StereoGeometry,
    params: &GridParams,
    time: Time,
    frame_sequence: u64,
) -> DepthGrid {
    DepthGridder::new(params, geometry).grid(depth, time, frame_sequence)
}

/// Summarises depth maps into [`DepthGrid`]s. Keeps its per-column lookup tables (rebuilt only
/// when the image size changes) and its histograms across frames.
///
/// A region's nearest depth comes from a histogram of its valid depths in 1 cm bins from 0 to
/// `max_distance_cm` (so it is exact to ±0.5 cm); when the percentile falls beyond that range
/// it is the nearest depth beyond it, exact.
///
/// The sectors take the nearest horizontal range of the centre row band (the vehicle's own
/// level), so the ground and the sky above do not read as obstacles; they are raw minima per
/// sector.
pub struct DepthGridder {
    params: GridParams,
    geometry: StereoGeometry,
    /// Image size the lookup tables were built for, `(width, height)` (px).
    size: (usize, usize),
    /// Column band (0 left, 1 centre, 2 right) of each image column.
    column_band: Vec<u8>,
    /// The image columns of each column band.
    column_ranges: [std::ops::Range<usize>; 3],
    /// Row band (0 up, 1 centre, 2 down) of each image row.
    row_band: Vec<u8>,
    /// Per image column: its sector and the factor turning depth Z into horizontal range.
    columns: Vec<(usize, f32)>,
    in_view: [bool; OBSTACLE_SECTORS],
    /// Nine histograms of valid depths (region-major, `bins` each), counts per centimetre.
    histograms: Vec<u32>,
    bins: usize,
    /// [`DepthGridder::grid_fixed_point`]'s nine pairs of histograms over the matcher's codes
    /// (region-major, two of [`FixedPointDepth::codes`] bins each: see [`count_codes`]).
    code_histograms: Vec<u32>,
    /// Per image column, the largest code seen in the centre row band (the nearest depth).
    column_codes: Vec<u32>,
    /// No texture flags: one row of zeros.
    textured_row: Vec<u8>,
    /// The codes of the row being counted.
    row_codes: Vec<u32>,
}

impl DepthGridder {
    /// A gridder for depth maps with `geometry`; `params` should have passed
    /// [`GridParams::check`] (out-of-range values give meaningless grids, never a panic).
    pub fn new(params: &GridParams, geometry: &StereoGeometry) -> DepthGridder {
        let bins = usize::from(params.max_distance_cm) + 1;
        DepthGridder {
            params: params.clone(),
            geometry: *geometry,
            size: (0, 0),
            column_band: Vec::new(),
            row_band: Vec::new(),
            columns: Vec::new(),
            in_view: [false; OBSTACLE_SECTORS],
            histograms: vec![0; 9 * bins],
            bins,
            column_ranges: [0..0, 0..0, 0..0],
            code_histograms: Vec::new(),
            column_codes: Vec::new(),
            textured_row: Vec::new(),
            row_codes: Vec::new(),
        }
    }

    fn layout(&mut self, width: usize, height: usize) {
        if self.size == (width, height) {
            return;
        }
        bands(width, self.params.column_edges, &mut self.column_band);
        let cut = |band: u8| self.column_band.iter().position(|&b| b >= band).unwrap_or(width);
        let (a, b) = (cut(1), cut(2));
        self.column_ranges = [0..a, a..b, b..width];
        self.textured_row = vec![0; width];
        bands(height, self.params.row_edges, &mut self.row_band);
        let g = &self.geometry;
        self.columns.clear();
        self.columns.extend((0..width).map(|u| {
            let tan = (u as f64 - g.cx_px) / g.focal_px;
            let azimuth_deg = tan.atan().to_degrees() as f32;
            let sector = (azimuth_deg / SECTOR_DEG).round().rem_euclid(OBSTACLE_SECTORS as f32) as usize;
            (sector % OBSTACLE_SECTORS, (1.0 + tan * tan).sqrt() as f32)
        }));
        self.in_view = [false; OBSTACLE_SECTORS];
        for &(sector, _) in &self.columns {
            self.in_view[sector] = true;
        }
        self.size = (width, height);
    }

    /// The grid of `depth` (captured at `time`, frame `frame_sequence`).
    pub fn grid(&mut self, depth: &DepthMap, time: Time, frame_sequence: u64) -> DepthGrid {
        self.layout(depth.width, depth.height);
        self.histograms.fill(0);
        let (bins, threshold_m) = (self.bins, self.params.threshold_m);
        let mut counts = [[RegionCount::default(); 3]; 3];
        let mut seen = [false; OBSTACLE_SECTORS];
        let mut nearest_range = [f32::INFINITY; OBSTACLE_SECTORS];
        let rows = depth.values.chunks_exact(depth.width.max(1)).take(self.row_band.len());
        for (y, row) in rows.enumerate() {
            let band = usize::from(self.row_band[y]);
            for (x, &z) in row.iter().enumerate() {
                let column = usize::from(self.column_band[x]);
                let histogram = &mut self.histograms[(band * 3 + column) * bins..][..bins];
                counts[band][column].add(histogram, z, 1, threshold_m);
                if band == 1 && !z.is_nan() {
                    let (sector, range_factor) = self.columns[x];
                    seen[sector] = true;
                    nearest_range[sector] = nearest_range[sector].min(z * range_factor);
                }
            }
        }

        self.finish(&counts, &seen, &nearest_range, time, frame_sequence)
    }

    /// The grid of the matcher's fixed-point output `raw` (`width`×`height`, row-major) with
    /// its `textureless` flags (non-zero: no disparity), captured at `time`, frame
    /// `frame_sequence`: exactly [`DepthGridder::grid`] of the depth map that `depths` would
    /// convert it to, without one. Depth falls as the code rises, so each region counts its
    /// codes and converts the counts, and each column keeps its largest code in the centre
    /// band for the sectors: two table lookups per code instead of one per pixel, and the
    /// per-pixel work is one increment (the frame → grid path of the stereo overhead budget).
    #[allow(clippy::too_many_arguments)]
    pub fn grid_fixed_point(
        &mut self,
        raw: &[i16],
        textureless: Option<&[u8]>,
        width: usize,
        height: usize,
        depths: &FixedPointDepth,
        time: Time,
        frame_sequence: u64,
    ) -> Result<DepthGrid, VisionError> {
        if raw.len() != width * height || textureless.is_some_and(|t| t.len() != raw.len()) {
            return Err(VisionError::Input(format!(
                "{} raw disparities and {:?} texture flags for a {width}×{height} grid",
                raw.len(),
                textureless.map(<[u8]>::len)
            )));
        }
        self.layout(width, height);
        let codes = depths.codes();
        self.code_histograms.clear();
        self.code_histograms.resize(2 * 9 * codes, 0);
        self.column_codes.clear();
        self.column_codes.resize(width, 0);
        self.row_codes.resize(width, 0);
        for y in 0..height {
            let band = usize::from(self.row_band[y]);
            let row = &raw[y * width..][..width];
            let flags = textureless.map_or(&self.textured_row[..], |t| &t[y * width..][..width]);
            for ((code, &v), &t) in self.row_codes.iter_mut().zip(row).zip(flags) {
                *code = depths.code(v, t);
            }
            if band == 1 {
                for (nearest, &code) in self.column_codes.iter_mut().zip(&self.row_codes) {
                    *nearest = (*nearest).max(code);
                }
            }
            for (column, range) in self.column_ranges.iter().enumerate() {
                let pair = &mut self.code_histograms[2 * (band * 3 + column) * codes..][..2 * codes];
                count_codes(pair, &self.row_codes[range.clone()]);
            }
        }
        self.histograms.fill(0);
        let (bins, threshold_m) = (self.bins, self.params.threshold_m);
        let mut counts = [[RegionCount::default(); 3]; 3];
        for (region, pair) in self.code_histograms.chunks_exact(2 * codes).enumerate() {
            let histogram = &mut self.histograms[region * bins..][..bins];
            let (even, odd) = pair.split_at(codes);
            let codes_seen = even.iter().zip(odd).map(|(a, b)| a + b);
            for (code, n) in codes_seen.enumerate().filter(|&(_, n)| n > 0) {
                let z = depths.depth_of_code(code).ok_or_else(|| beyond_the_search(depths, code))?;
                counts[region / 3][region % 3].add(histogram, z, n, threshold_m);
            }
        }
        let mut seen = [false; OBSTACLE_SECTORS];
        let mut nearest_range = [f32::INFINITY; OBSTACLE_SECTORS];
        for (&code, &(sector, range_factor)) in self.column_codes.iter().zip(&self.columns) {
            let z = depths
                .depth_of_code(code as usize)
                .ok_or_else(|| beyond_the_search(depths, code as usize))?;
            if !z.is_nan() {
                seen[sector] = true;
                nearest_range[sector] = nearest_range[sector].min(z * range_factor);
            }
        }
        Ok(self.finish(&counts, &seen, &nearest_range, time, frame_sequence))
    }

    /// The grid from the regions' counts (their histograms in `self.histograms`) and the
    /// sectors' nearest horizontal ranges.
    fn finish(
        &self,
        counts: &[[RegionCount; 3]; 3],
        seen: &[bool; OBSTACLE_SECTORS],
        nearest_range: &[f32; OBSTACLE_SECTORS],
        time: Time,
        frame_sequence: u64,
    ) -> DepthGrid {
        let bins = self.bins;
        let threshold_m = self.params.threshold_m;
        let mut regions = [[GridRegion::default(); 3]; 3];
        for (band, row) in regions.iter_mut().enumerate() {
            for (column, region) in row.iter_mut().enumerate() {
                let histogram = &self.histograms[(band * 3 + column) * bins..][..bins];
                *region = counts[band][column].region(histogram, self.params.nearest_percentile);
            }
        }
        let max_cm = self.params.max_distance_cm;
        let distances_cm = (0..OBSTACLE_SECTORS)
            .map(|s| match (self.in_view[s], seen[s]) {
                (true, true) => {
                    let cm = (nearest_range[s] * 100.0).round();
                    if cm > f32::from(max_cm) { max_cm + 1 } else { cm.max(0.0) as u16 }
                }
                _ => SECTOR_UNKNOWN,
            })
            .collect();
        DepthGrid {
            time,
            frame_sequence,
            threshold_m,
            regions,
            sectors: ObstacleSectors {
                distances_cm,
                increment_deg: SECTOR_DEG,
                angle_offset_deg: 0.0,
                min_distance_cm: self.params.min_distance_cm,
                max_distance_cm: max_cm,
            },
        }
    }
}

/// One region's pixel counts; its valid depths within range sit in a histogram beside it.
#[derive(Clone, Copy)]
struct RegionCount {
    total: u32,
    invalid: u32,
    near: u32,
    /// Valid pixels beyond the histogram's range, and the nearest of them (m).
    beyond: u32,
    nearest_beyond: f32,
}

impl Default for RegionCount {
    fn default() -> Self {
        RegionCount { total: 0, invalid: 0, near: 0, beyond: 0, nearest_beyond: f32::INFINITY }
    }
}

impl RegionCount {
    /// Counts `n` pixels of depth `z` (m, `NaN`: none), the region's `histogram` beside it.
    #[inline(always)]
    fn add(&mut self, histogram: &mut [u32], z: f32, n: u32, threshold_m: f32) {
        self.total += n;
        if z.is_nan() {
            self.invalid += n;
            return;
        }
        self.near += if z < threshold_m { n } else { 0 };
        let cm = round(z * 100.0);
        if cm < histogram.len() as f32 {
            histogram[cm.max(0.0) as usize] += n;
        } else {
            self.beyond += n;
            self.nearest_beyond = self.nearest_beyond.min(z);
        }
    }

    /// The region, its nearest depth being the `percentile` (%) of its valid depths:
    /// the k-th smallest with k = max(1, ⌈percentile/100 · valid⌉).
    fn region(self, histogram: &[u32], percentile: f32) -> GridRegion {
        let valid = self.total - self.invalid;
        let rank = ((f64::from(percentile) / 100.0 * f64::from(valid)).ceil() as u32).max(1);
        let mut below = 0;
        let in_range = histogram.iter().position(|&n| {
            below += n;
            below >= rank
        });
        let nearest_m = match in_range {
            Some(cm) => Some(cm as f32 / 100.0),
            None => (self.beyond > 0).then_some(self.nearest_beyond),
        };
        GridRegion {
            near_share: if valid > 0 { self.near as f32 / valid as f32 } else { 0.0 },
            invalid_share: if self.total > 0 { self.invalid as f32 / self.total as f32 } else { 1.0 },
            nearest_m,
        }
    }
}

/// Counts `codes` into `pair`, two histograms of [`FixedPointDepth::codes`] bins each: even
/// pixels into the first, odd into the second.
/// Neighbouring pixels mostly share a code, and one histogram would make each increment wait
/// for the last one's store; two let pairs of them overlap.
#[inline(always)]
fn count_codes(pair: &mut [u32], codes: &[u32]) {
    let (even, odd) = pair.split_at_mut(pair.len() / 2);
    let pairs = codes.chunks_exact(2);
    let rest = pairs.remainder();
    for c in pairs {
        even[c[0] as usize] += 1;
        odd[c[1] as usize] += 1;
    }
    for &c in rest {
        even[c as usize] += 1;
    }
}

/// A code beyond the matcher's search range: a matcher never gives one, and the table that
/// would give its depth ends there.
fn beyond_the_search(depths: &FixedPointDepth, code: usize) -> VisionError {
    VisionError::Input(format!(
        "disparity code {code} is beyond the matcher's {} codes: not a matcher's output",
        depths.codes()
    ))
}

/// `x.round()` (half away from zero) without the library call it compiles to on x86-64
/// without SSE 4.1, which cost as much as the rest of a pixel's gridding: below 2²³ the
/// truncation is an integer conversion and the fraction it leaves is exact; from there up
/// every float is already whole.
#[inline(always)]
fn round(x: f32) -> f32 {
    /// 2²³: from here up every `f32` is whole.
    const WHOLE: f32 = 8_388_608.0;
    if x.abs() < WHOLE {
        let whole = x as i32;
        let fraction = x - whole as f32;
        // The sign too: what rounds to zero from below is −0.
        ((whole + i32::from(fraction >= 0.5) - i32::from(fraction <= -0.5)) as f32).copysign(x)
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::round;

    proptest::proptest! {
        /// On random bit patterns (NaNs, infinities and subnormals among them) and on depths
        /// in centimetres near half-centimetres.
        #[test]
        fn round_is_the_library_round(bits in proptest::num::u32::ANY, cm in -1e5f32..1e5) {
            for x in [f32::from_bits(bits), cm, cm.floor() + 0.5, (cm.floor() + 0.5).next_down(), (cm.floor() + 0.5).next_up()] {
                let (ours, library) = (round(x), x.round());
                proptest::prop_assert!(ours.to_bits() == library.to_bits() || (ours.is_nan() && library.is_nan()), "{} {} {}", x, ours, library);
            }
        }
    }
}
