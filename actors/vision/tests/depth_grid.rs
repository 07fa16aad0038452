//! The depth grid on synthetic scenes with known geometry: hand-made depth maps (exact) and a
//! rendered textured stereo pair driven through the whole pipeline.

use kestrel_proto::Time;
use kestrel_proto::messages::{DepthGrid, SECTOR_UNKNOWN};
use kestrel_vision::depth::FixedPointDepth;
use kestrel_vision::{
    DepthGridder, DepthMap, DisparityMap, Geometry, GridParams, PipelineParams, StereoFrame, StereoGeometry,
    StereoPipeline, depth_grid,
};
use opencv::core::MatTraitConst;

const W: usize = 640;
const H: usize = 480;

fn geometry() -> StereoGeometry {
    StereoGeometry {
        focal_px: 500.0,
        cx_px: 319.5,
        cy_px: 239.5,
        baseline_m: 0.12,
        doffs_px: 0.0,
        depth_scale: 1.0,
    }
}

fn in_centre(x: usize, y: usize) -> bool {
    (213..427).contains(&x) && (160..320).contains(&y)
}

fn print(grid: &DepthGrid) {
    for row in &grid.regions {
        let cells: Vec<String> = row
            .iter()
            .map(|r| {
                format!("near {:.3} invalid {:.3} nearest {:?}", r.near_share, r.invalid_share, r.nearest_m)
            })
            .collect();
        println!("{}", cells.join(" | "));
    }
}

#[test]
fn exact_plane_at_three_metres_fills_the_centre_and_nothing_else() {
    let mut values = vec![20.0f32; W * H];
    for (i, z) in values.iter_mut().enumerate() {
        if in_centre(i % W, i / W) {
            *z = 3.0;
        } else if i / W < H / 3 && i % W < W / 3 {
            *z = f32::NAN;
        }
    }
    let depth = DepthMap { width: W, height: H, values };
    let grid = depth_grid(&depth, &geometry(), &GridParams::default(), Time(42), 7);
    assert_eq!((grid.time, grid.frame_sequence, grid.threshold_m), (Time(42), 7, 5.0));
    let c = grid.regions[1][1];
    assert_eq!((c.near_share, c.invalid_share, c.nearest_m), (1.0, 0.0, Some(3.0)));
    let up_left = grid.regions[0][0];
    assert_eq!((up_left.near_share, up_left.invalid_share, up_left.nearest_m), (0.0, 1.0, None));
    for (r, c) in [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1), (2, 2)] {
        let region = grid.regions[r][c];
        assert_eq!(
            (region.near_share, region.invalid_share, region.nearest_m),
            (0.0, 0.0, Some(20.0)),
            "{r},{c}"
        );
    }
    // Sectors: the camera sees ±32.6° (fx 500 over 640 px): sectors −35°..+35° are known
    // (the outermost ones only in part).
    let s = &grid.sectors;
    assert_eq!((s.distances_cm.len(), s.increment_deg, s.angle_offset_deg), (72, 5.0, 0.0));
    assert_eq!(s.distances_cm[0], 300, "straight ahead: the plane at 3 m");
    let range_cm = |deg: f64| (2000.0 / deg.to_radians().cos()).round() as u16;
    assert_eq!(
        s.distances_cm[6],
        range_cm(30.0).min(s.max_distance_cm + 1),
        "30° right: the background, beyond range"
    );
    assert_eq!(s.distances_cm[6], s.max_distance_cm + 1);
    assert_eq!((s.distances_cm[7], s.distances_cm[65]), (s.max_distance_cm + 1, s.max_distance_cm + 1));
    assert!((8..=64).all(|i| s.distances_cm[i] == SECTOR_UNKNOWN), "outside the field of view: unknown");
    assert_eq!(s.distances_cm[66], s.max_distance_cm + 1, "30° left");
}

/// Smooth pseudo-random texture on a surface, in world units (value noise, bilinear).
fn texture(u: f64, v: f64, seed: u64) -> f64 {
    let hash = |i: i64, j: i64| {
        let mut h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ seed;
        h ^= h >> 29;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 32;
        (h % 256) as f64
    };
    let (i, j) = (u.floor() as i64, v.floor() as i64);
    let (fu, fv) = (u - u.floor(), v - v.floor());
    let top = hash(i, j) * (1.0 - fu) + hash(i + 1, j) * fu;
    let bottom = hash(i, j + 1) * (1.0 - fu) + hash(i + 1, j + 1) * fu;
    top * (1.0 - fv) + bottom * fv
}

/// Renders one camera at `camera_x_m` looking at a background plane at 20 m and a textured
/// plane at 3 m whose left-camera image is the centre third; the world rectangle `flat`
/// (left-image pixels on the background) is painted uniform grey: a textureless wall.
fn render(camera_x_m: f64, flat: Option<[usize; 4]>) -> Vec<u8> {
    let g = geometry();
    let ray = |px: f64, c: f64| (px - c) / g.focal_px;
    // The foreground rectangle in world coordinates (m) at Z = 3 m, from the left image's centre third.
    let (x0, x1) = (ray(W as f64 / 3.0, g.cx_px) * 3.0, ray(2.0 * W as f64 / 3.0, g.cx_px) * 3.0);
    let (y0, y1) = (ray(H as f64 / 3.0, g.cy_px) * 3.0, ray(2.0 * H as f64 / 3.0, g.cy_px) * 3.0);
    let mut image = vec![0u8; W * H];
    for y in 0..H {
        for x in 0..W {
            let (rx, ry) = (ray(x as f64, g.cx_px), ray(y as f64, g.cy_px));
            let (fx, fy) = (camera_x_m + rx * 3.0, ry * 3.0);
            let value = if (x0..x1).contains(&fx) && (y0..y1).contains(&fy) {
                texture(fx / 0.008, fy / 0.008, 1)
            } else {
                let (bx, by) = (camera_x_m + rx * 20.0, ry * 20.0);
                let on_wall = flat.is_some_and(|[a, b, c, d]| {
                    let (wx0, wx1) = (ray(a as f64, g.cx_px) * 20.0, ray(b as f64, g.cx_px) * 20.0);
                    let (wy0, wy1) = (ray(c as f64, g.cy_px) * 20.0, ray(d as f64, g.cy_px) * 20.0);
                    (wx0..wx1).contains(&bx) && (wy0..wy1).contains(&by)
                });
                if on_wall { 128.0 } else { texture(bx / 0.06, by / 0.06, 2) }
            };
            image[y * W + x] = value.round() as u8;
        }
    }
    image
}

fn rendered_grid(flat: Option<[usize; 4]>, params: &PipelineParams) -> DepthGrid {
    let frame =
        StereoFrame::new(Time(1), 0, W as u32, H as u32, render(0.0, flat), render(0.12, flat)).unwrap();
    let mut pipeline =
        StereoPipeline::new(&Geometry::Rectified(geometry()), params, std::path::Path::new(".")).unwrap();
    let grid = pipeline.process(&frame).unwrap();
    print(&grid);
    grid
}

/// The stock pipeline and the one matching every second row (same depths, half the rows).
fn pipelines() -> [PipelineParams; 2] {
    [PipelineParams::default(), PipelineParams { row_downscale: 2, ..PipelineParams::default() }]
}

#[test]
fn rendered_plane_at_three_metres_reads_near_in_the_centre_only() {
    for params in pipelines() {
        rendered_plane_in_the_centre(&params);
    }
}

fn rendered_plane_in_the_centre(params: &PipelineParams) {
    let grid = rendered_grid(None, params);
    let centre = grid.regions[1][1];
    assert!(centre.near_share > 0.97, "{centre:?}");
    let nearest = centre.nearest_m.unwrap();
    assert!((2.7..3.05).contains(&nearest), "{nearest}");
    for (r, c) in [(0, 0), (0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1), (2, 2)] {
        assert!(grid.regions[r][c].near_share < 0.05, "{r},{c}: {:?}", grid.regions[r][c]);
    }
    assert!((250..=320).contains(&grid.sectors.distances_cm[0]), "{:?}", grid.sectors.distances_cm);
}

#[test]
fn textureless_wall_reads_invalid_not_free() {
    // The whole up-right region (and a margin) is a uniform wall on the background.
    for params in pipelines() {
        let grid = rendered_grid(Some([2 * W / 3 - 20, W, 0, H / 3 + 20]), &params);
        let wall = grid.regions[0][2];
        assert!(wall.invalid_share > 0.9, "{wall:?}");
        assert!(grid.regions[1][1].near_share > 0.97);
    }
}

#[test]
fn a_speckle_does_not_define_the_nearest_depth() {
    // Every region at 10 m, with a 7×7 speckle of 0.5 m in the centre region (49 of its
    // 34 240 pixels, 0.14 %).
    let mut values = vec![10.0f32; W * H];
    for y in 230..237 {
        for x in 300..307 {
            values[y * W + x] = 0.5;
        }
    }
    let depth = DepthMap { width: W, height: H, values };
    let robust = depth_grid(&depth, &geometry(), &GridParams::default(), Time(0), 0);
    assert_eq!(robust.regions[1][1].nearest_m, Some(10.0), "{:?}", robust.regions[1][1]);
    assert!((robust.regions[1][1].near_share - 49.0 / 34_240.0).abs() < 1e-6, "the share still counts it");
    let raw = GridParams { nearest_percentile: 0.0, ..GridParams::default() };
    let grid = depth_grid(&depth, &geometry(), &raw, Time(0), 0);
    assert_eq!(grid.regions[1][1].nearest_m, Some(0.5), "percentile 0 is the raw minimum");
    assert_eq!(grid.regions[0][0].nearest_m, Some(10.0));
    // A real obstacle covering 5 % of the region defines it at the 2nd percentile.
    let mut values = vec![10.0f32; W * H];
    for y in 160..320 {
        for x in 213..224 {
            values[y * W + x] = 2.0;
        }
    }
    let depth = DepthMap { width: W, height: H, values };
    let grid = depth_grid(&depth, &geometry(), &GridParams::default(), Time(0), 0);
    assert_eq!(grid.regions[1][1].nearest_m, Some(2.0));
    // Beyond the histogram's 20 m the nearest depth is exact.
    let depth = DepthMap { width: W, height: H, values: vec![31.25; W * H] };
    let grid = depth_grid(&depth, &geometry(), &GridParams::default(), Time(0), 0);
    assert_eq!(grid.regions[2][2].nearest_m, Some(31.25));
}

#[test]
fn nearest_percentile_out_of_range_is_refused() {
    for p in [-1.0, 50.5, f32::NAN] {
        let params = GridParams { nearest_percentile: p, ..GridParams::default() };
        let err = params.check().unwrap_err();
        assert!(err.to_string().contains("nearest_percentile"), "{err}");
    }
}

/// The k-th smallest valid depth of region (`band`, `column`), k = max(1, ⌈p·n⌉), by sorting:
/// the reference the gridder's histogram must match to the centimetre.
fn sorted_percentile(depth: &DepthMap, band: usize, column: usize, percentile: f32) -> Option<f32> {
    let third = |i: usize, n: usize| {
        usize::from(i >= (n as f32 / 3.0).round() as usize)
            + usize::from(i >= (2.0 * n as f32 / 3.0).round() as usize)
    };
    let mut valid: Vec<f32> = (0..depth.height)
        .flat_map(|y| (0..depth.width).map(move |x| (x, y)))
        .filter(|&(x, y)| third(y, depth.height) == band && third(x, depth.width) == column)
        .filter_map(|(x, y)| depth.get(x, y))
        .collect();
    valid.sort_by(f32::total_cmp);
    let rank = ((f64::from(percentile) / 100.0 * valid.len() as f64).ceil() as usize).max(1);
    valid.get(rank - 1).copied()
}

proptest::proptest! {
    /// Any depth map, however sparse, gives shares in 0..1, a nearest depth only where some
    /// pixel is valid and equal (±0.5 cm within the 20 m histogram) to the sorted percentile,
    /// and 72 sectors within MAVLink's value range.
    #[test]
    fn grid_invariants_hold_for_any_depth_map(
        values in proptest::collection::vec(proptest::option::of(0.05f32..30.0), 48 * 36),
        percentile in 0.0f32..50.0,
    ) {
        let values: Vec<f32> = values.into_iter().map(|v| v.unwrap_or(f32::NAN)).collect();
        let depth = DepthMap { width: 48, height: 36, values };
        let small = StereoGeometry { focal_px: 40.0, cx_px: 23.5, cy_px: 17.5, ..geometry() };
        let params = GridParams { nearest_percentile: percentile, ..GridParams::default() };
        let grid = depth_grid(&depth, &small, &params, Time(0), 0);
        for (band, row) in grid.regions.iter().enumerate() {
            for (column, region) in row.iter().enumerate() {
                proptest::prop_assert!((0.0..=1.0).contains(&region.near_share));
                proptest::prop_assert!((0.0..=1.0).contains(&region.invalid_share));
                proptest::prop_assert_eq!(region.nearest_m.is_none(), region.invalid_share == 1.0);
                let reference = sorted_percentile(&depth, band, column, percentile);
                match (region.nearest_m, reference) {
                    (Some(z), Some(r)) if (r * 100.0).round() <= 2000.0 => proptest::prop_assert!((z - r).abs() <= 0.005 + 1e-6, "{} vs {}", z, r),
                    (Some(z), Some(r)) => proptest::prop_assert!(z > 20.0 && z <= r, "{} vs {}", z, r),
                    (z, r) => proptest::prop_assert_eq!(z, r),
                }
            }
        }
        proptest::prop_assert_eq!(grid.sectors.distances_cm.len(), 72);
        for &d in &grid.sectors.distances_cm {
            proptest::prop_assert!(d <= params.max_distance_cm + 1 || d == SECTOR_UNKNOWN);
        }
    }
}

/// The frame → grid path converts the matcher's fixed-point output to depth in one pass
/// (a table, the texture check folded in); its grid is exactly the grid of the pipeline's
/// depth map (disparity, texture check, then division), for both pipelines and with a
/// textureless wall in view.
#[test]
fn the_one_pass_grid_is_the_grid_of_the_depth_map() {
    let flat = Some([2 * W / 3 - 20, W, 0, H / 3 + 20]);
    let (left, right) = (render(0.0, flat), render(0.12, flat));
    for params in pipelines() {
        let mut pipeline =
            StereoPipeline::new(&Geometry::Rectified(geometry()), &params, std::path::Path::new("."))
                .unwrap();
        let (l, r) = (
            kestrel_vision::image::gray_mat(&left, W as u32, H as u32).unwrap(),
            kestrel_vision::image::gray_mat(&right, W as u32, H as u32).unwrap(),
        );
        let one_pass = pipeline.grid(&l, &r, Time(5), 3).unwrap();
        let depth = pipeline.depth(&l, &r).unwrap();
        let geometry = *pipeline.geometry();
        assert!(depth.values.iter().any(|z| z.is_nan()) && depth.values.iter().any(|z| !z.is_nan()));
        assert_eq!(one_pass, depth_grid(&depth, &geometry, &params.grid, Time(5), 3));
    }
}

/// The matcher's fixed-point output (`width`×`height`) as an OpenCV `CV_16S` image.
fn raw_mat(raw: &[i16], width: usize, height: usize) -> opencv::core::Mat {
    opencv::core::Mat::new_rows_cols_with_data(height as i32, width as i32, raw).unwrap().try_clone().unwrap()
}

proptest::proptest! {
    /// Straight from the matcher's output (codes, one increment a pixel) the grid is exactly
    /// the grid of the depth map the long way gives: disparity, texture flags to `NaN`, then
    /// division. Any size, any band edges, a negative `doffs` (disparities at or beyond
    /// infinity: no depth), a histogram shorter than some depths, codes below the range.
    #[test]
    fn the_grid_from_the_matchers_codes_is_the_grid_of_its_depth_map(
        width in 1usize..48,
        height in 1usize..36,
        min_disparity in -2i32..3,
        wide in proptest::bool::ANY,
        doffs_px in proptest::sample::select(vec![0.0f64, -3.5, 2.0]),
        max_distance_cm in proptest::sample::select(vec![300u16, 2000]),
        edges in (0.05f32..0.45, 0.55f32..0.95),
        percentile in 0.0f32..50.0,
        seed in proptest::num::u64::ANY,
    ) {
        let num_disparities = if wide { 32 } else { 16 };
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let first = min_disparity * 16;
        let raw: Vec<i16> = (0..width * height)
            .map(|_| match next() % 8 {
                0 => (first - 16) as i16,
                1 => (first - 1 - (next() % 40) as i32) as i16,
                _ => (first + (next() % (num_disparities as u64 * 16 + 1)) as i32) as i16,
            })
            .collect();
        let flags: Vec<u8> = (0..width * height).map(|_| u8::from(next() % 5 == 0)).collect();
        let geometry = StereoGeometry { focal_px: 40.0, cx_px: width as f64 / 2.0, cy_px: height as f64 / 2.0, doffs_px, ..geometry() };
        let params = GridParams {
            column_edges: [edges.0, edges.1],
            row_edges: [edges.1 - 0.5, edges.0 + 0.5],
            max_distance_cm,
            nearest_percentile: percentile,
            ..GridParams::default()
        };
        params.check().unwrap();
        let depths = FixedPointDepth::new(&geometry, min_disparity, num_disparities);
        let mut gridder = DepthGridder::new(&params, &geometry);
        for textureless in [None, Some(&flags[..])] {
            let fast = gridder.grid_fixed_point(&raw, textureless, width, height, &depths, Time(9), 4).unwrap();
            let mut disparity = DisparityMap::from_fixed_point(&raw_mat(&raw, width, height), min_disparity).unwrap();
            for (d, &t) in disparity.values.iter_mut().zip(textureless.unwrap_or(&[])) {
                if t != 0 {
                    *d = f32::NAN;
                }
            }
            let depth = DepthMap::from_disparity(&disparity, &geometry);
            proptest::prop_assert_eq!(fast, depth_grid(&depth, &geometry, &params, Time(9), 4));
        }
    }
}

/// A raw value past the matcher's range (no matcher gives one) is an error naming it, not a
/// guess, and a size that does not match the buffer is refused.
#[test]
fn codes_beyond_the_search_and_mismatched_sizes_are_refused() {
    let depths = FixedPointDepth::new(&geometry(), 0, 16);
    let mut gridder = DepthGridder::new(&GridParams::default(), &geometry());
    let err = gridder.grid_fixed_point(&[0, 16 * 16 + 1], None, 2, 1, &depths, Time(0), 0).unwrap_err();
    assert!(err.to_string().contains("beyond the matcher's"), "{err}");
    let err = gridder.grid_fixed_point(&[0, 1, 2], None, 2, 1, &depths, Time(0), 0).unwrap_err();
    assert!(err.to_string().contains("2×1"), "{err}");
}
