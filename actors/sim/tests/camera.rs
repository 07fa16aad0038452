//! The simulated stereo camera against geometry worked out by hand.

use std::path::Path;

use kestrel_sim::Obstacle;
use kestrel_sim::World;
use kestrel_sim::camera::reference::render_moving_reference;
use kestrel_sim::camera::{
    CapturePose, RenderBuffers, Scene, StereoCamera, StereoCameraParams, StereoRender,
};
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

const ALTITUDE_M: f64 = 1.5;

fn camera() -> StereoCamera {
    StereoCamera::new(&StereoCameraParams::default()).unwrap()
}

/// Renders `obstacles` from `ALTITUDE_M` above home, level, facing north (yaw in degrees).
fn render(obstacles: Vec<Obstacle>, yaw_deg: f64) -> StereoRender {
    let attitude = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_deg.to_radians());
    camera().render(&Scene::new(&obstacles), &Vector3::new(0.0, 0.0, -ALTITUDE_M), &attitude, 0)
}

fn wall_at(north_m: f64, textured: bool) -> Obstacle {
    Obstacle::Wall {
        from_ne_m: [north_m, -20.0],
        to_ne_m: [north_m, 20.0],
        height_m: 6.0,
        thickness_m: 0.2,
        textured,
    }
}

/// Pixels of `image` in the inclusive window `cols` × `rows`.
fn patch(r: &StereoRender, image: &[u8], cols: (u32, u32), rows: (u32, u32)) -> Vec<u8> {
    (rows.0..=rows.1)
        .flat_map(|y| (cols.0..=cols.1).map(move |x| image[(y * r.width + x) as usize]))
        .collect()
}

/// The right-image shift (px, sub-pixel) that best matches a left-image window, by normalised
/// cross-correlation over whole-pixel shifts and a parabola through the best three.
fn best_shift(r: &StereoRender, cols: (u32, u32), rows: (u32, u32), max: u32) -> f64 {
    let left: Vec<f64> = patch(r, &r.left, cols, rows).into_iter().map(f64::from).collect();
    let ncc = |d: u32| {
        let right: Vec<f64> =
            patch(r, &r.right, (cols.0 - d, cols.1 - d), rows).into_iter().map(f64::from).collect();
        let n = left.len() as f64;
        let (ml, mr) = (left.iter().sum::<f64>() / n, right.iter().sum::<f64>() / n);
        let cov: f64 = left.iter().zip(&right).map(|(a, b)| (a - ml) * (b - mr)).sum();
        let var = |v: &[f64], m: f64| v.iter().map(|a| (a - m).powi(2)).sum::<f64>();
        cov / (var(&left, ml) * var(&right, mr)).sqrt()
    };
    let scores: Vec<f64> = (0..=max).map(ncc).collect();
    let best = (1..max as usize).max_by(|&a, &b| scores[a].total_cmp(&scores[b])).unwrap();
    let (a, b, c) = (scores[best - 1], scores[best], scores[best + 1]);
    best as f64 + 0.5 * (a - c) / (a - 2.0 * b + c)
}

#[test]
fn a_box_three_metres_ahead_fills_the_centre_at_three_metres() {
    let cube = Obstacle::Box { center_ned_m: [3.5, 0.0, -1.5], size_m: [1.0, 2.0, 3.0], yaw_deg: 0.0 };
    let r = render(vec![cube], 0.0);
    for row in 190..290 {
        for col in 270..370 {
            let z = r.depth.at(col, row).unwrap();
            assert!((z - 3.0).abs() < 0.03, "depth {z} m at ({col}, {row})");
        }
    }
}

#[test]
fn a_textured_wall_shows_the_disparity_of_its_depth() {
    let k = *camera().intrinsics();
    for north_m in [2.1, 5.1, 10.1] {
        let r = render(vec![wall_at(north_m, true)], 0.0);
        let depth_m = north_m - 0.1;
        assert!((f64::from(r.depth.at(320, 240).unwrap()) - depth_m).abs() < 1e-3);
        let expected = k.disparity_px(depth_m);
        let found = best_shift(&r, (280, 360), (200, 230), 30);
        assert!(
            (found - expected).abs() < 0.25,
            "wall at {depth_m} m: shift {found} px, f·B/Z = {expected} px"
        );
    }
}

#[test]
fn a_textureless_wall_is_uniform_and_a_textured_one_is_not() {
    let plain = render(vec![wall_at(4.0, false)], 0.0);
    let p = patch(&plain, &plain.left, (200, 440), (150, 260));
    assert!(p.iter().all(|&v| v == p[0]), "plain wall varies");
    let textured = render(vec![wall_at(4.0, true)], 0.0);
    let p = patch(&textured, &textured.left, (200, 440), (150, 260));
    let (lo, hi) = (p.iter().min().unwrap(), p.iter().max().unwrap());
    assert!(hi - lo > 60, "textured wall spans only {lo}..{hi}");
}

#[test]
fn the_ground_meets_the_sky_at_the_horizon_row() {
    let r = render(Vec::new(), 0.0);
    let k = *camera().intrinsics();
    for row in [0, 100, 239] {
        assert_eq!(r.depth.at(320, row), None, "row {row} should be sky");
        assert!(
            patch(&r, &r.left, (0, 639), (row, row))
                .iter()
                .all(|&v| v == patch(&r, &r.left, (0, 0), (0, 0))[0])
        );
    }
    for row in [240, 245, 300, 479] {
        let expected = ALTITUDE_M * k.focal_px / (f64::from(row) - k.cy_px);
        let z = f64::from(r.depth.at(100, row).unwrap());
        assert!((z - expected).abs() / expected < 1e-3, "row {row}: {z} m, expected {expected} m");
    }
}

#[test]
fn images_follow_the_body_frame_x_right_y_down() {
    // Facing east, a box to the east-south-east appears right of centre and ahead.
    let cube = Obstacle::Box { center_ned_m: [-1.0, 4.0, -1.5], size_m: [0.5, 0.5, 0.5], yaw_deg: 0.0 };
    let r = render(vec![cube.clone()], 90.0);
    let hit_cols: Vec<u32> = (0..r.width).filter(|&c| r.depth.at(c, 240).is_some_and(|z| z < 10.0)).collect();
    assert!(!hit_cols.is_empty() && hit_cols.iter().all(|&c| c > 320), "{hit_cols:?}");
    // Facing north it is outside the field of view: only the far ground is seen.
    let r = render(vec![cube], 0.0);
    assert!((0..r.width).all(|c| r.depth.at(c, 240).is_some_and(|z| z > 100.0)));
}

#[test]
fn rendering_is_deterministic_and_noise_depends_on_the_frame() {
    let world =
        World::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds/obstacles.toml"))
            .unwrap();
    let scene = Scene::new(&world.obstacles);
    let noisy =
        StereoCamera::new(&StereoCameraParams { noise_std: 2.0, ..StereoCameraParams::default() }).unwrap();
    let pose = (Vector3::new(0.0, 0.0, -2.0), UnitQuaternion::from_euler_angles(0.0, 0.05, 0.1));
    let a = noisy.render(&scene, &pose.0, &pose.1, 7);
    assert_eq!(a, noisy.render(&scene, &pose.0, &pose.1, 7));
    let b = noisy.render(&scene, &pose.0, &pose.1, 8);
    assert_ne!(a.left, b.left);
    assert_eq!(a.depth, b.depth);
}

/// A rig with `exposure_time_s` and `blur_samples`, otherwise the defaults.
fn blurring(exposure_time_s: f64, blur_samples: u32) -> StereoCamera {
    StereoCamera::new(&StereoCameraParams { exposure_time_s, blur_samples, ..StereoCameraParams::default() })
        .unwrap()
}

/// The body `ALTITUDE_M` above home, level, facing north, moving at `velocity_ned_m_s` and
/// turning at `rate_frd_rad_s`.
fn moving(velocity_ned_m_s: [f64; 3], rate_frd_rad_s: [f64; 3]) -> CapturePose {
    CapturePose {
        velocity_ned_m_s: Vector3::from(velocity_ned_m_s),
        angular_velocity_frd_rad_s: Vector3::from(rate_frd_rad_s),
        ..CapturePose::still(Vector3::new(0.0, 0.0, -ALTITUDE_M), UnitQuaternion::identity())
    }
}

/// Row `row` of `image`, columns `cols` (inclusive), as numbers.
fn row_of(r: &StereoRender, image: &[u8], row: u32, cols: (u32, u32)) -> Vec<f64> {
    patch(r, image, cols, (row, row)).into_iter().map(f64::from).collect()
}

/// A still render of `scene` by the default rig at four times its resolution: the same field
/// of view, 2560 px wide (focal length ×4) and 1917 px high, so that row `4·r` of it is row `r`
/// of the default image and column `4·c + 1.5` is column `c`.
fn still_at_four_times_the_resolution(scene: &Scene) -> StereoRender {
    let fine = StereoCameraParams { width_px: 2560, height_px: 1917, ..StereoCameraParams::default() };
    StereoCamera::new(&fine).unwrap().render(
        scene,
        &Vector3::new(0.0, 0.0, -ALTITUDE_M),
        &UnitQuaternion::identity(),
        0,
    )
}

/// The width (px) of the horizontal box filter that, applied to the still image, best
/// reproduces the blurred one over the window `cols` × `rows`: widths every 0.5 px up to 20 px,
/// then every 0.05 px around the best. The still image is `fine`,
/// [`still_at_four_times_the_resolution`], interpolated linearly along its rows and averaged
/// over 64 evenly spread shifts across the box: an independent reference for the renderer's
/// motion blur, which moves the cameras in 3-D and ray casts again. (Interpolating a still
/// image at the blurred one's own resolution would smooth it and bias the fit low by up to
/// half a pixel.)
fn fitted_box_width_px(
    fine: &StereoRender,
    blurred: &StereoRender,
    cols: (u32, u32),
    rows: (u32, u32),
) -> f64 {
    let pairs: Vec<(Vec<f64>, Vec<f64>)> = (rows.0..=rows.1)
        .map(|row| {
            (
                row_of(fine, &fine.left, 4 * row, (0, fine.width - 1)),
                row_of(blurred, &blurred.left, row, cols),
            )
        })
        .collect();
    let error = |width: f64| -> f64 {
        let mut sum = 0.0;
        for (sharp, blur) in &pairs {
            let at = |x: f64| {
                let (i, frac) = (x.floor() as usize, x - x.floor());
                sharp[i] + frac * (sharp[i + 1] - sharp[i])
            };
            for (col, b) in (cols.0..=cols.1).zip(blur) {
                let centre = 4.0 * f64::from(col) + 1.5;
                let boxed = (0..64)
                    .map(|j| at(centre + 4.0 * width * ((f64::from(j) + 0.5) / 64.0 - 0.5)))
                    .sum::<f64>()
                    / 64.0;
                sum += (boxed - b).powi(2);
            }
        }
        sum
    };
    let best = |widths: Vec<f64>| widths.into_iter().min_by(|a, b| error(*a).total_cmp(&error(*b))).unwrap();
    let coarse = best((0..=40).map(|i| f64::from(i) * 0.5).collect());
    best((-10..=10).map(|i| (coarse + f64::from(i) * 0.05).max(0.0)).collect())
}

#[test]
fn sideways_motion_blurs_a_textured_wall_by_f_v_t_over_z() {
    let f = camera().intrinsics().focal_px;
    // Within 2.5 m every octave of the texture is at full strength at both resolutions, so both
    // images sample one and the same pattern.
    for (depth_m, cases) in [(2.0, [(1.0, 0.02), (2.0, 0.04)]), (1.5, [(1.0, 0.01), (2.0, 0.03)])] {
        let scene = Scene::new(&[wall_at(depth_m + 0.1, true)]);
        let fine = still_at_four_times_the_resolution(&scene);
        let still =
            camera().render(&scene, &Vector3::new(0.0, 0.0, -ALTITUDE_M), &UnitQuaternion::identity(), 0);
        for (speed_m_s, exposure_s) in cases {
            let pose = moving([0.0, speed_m_s, 0.0], [0.0; 3]);
            let blurred =
                blurring(exposure_s, 33).render_moving(&scene, &pose, 0, &mut RenderBuffers::default());
            let expected = f * speed_m_s * exposure_s / depth_m;
            let found = fitted_box_width_px(&fine, &blurred, (220, 420), (120, 200));
            eprintln!(
                "{speed_m_s} m/s, {exposure_s} s at {depth_m} m: blur {found:.2} px, f·v·T/Z = {expected:.2} px"
            );
            assert!((found - expected).abs() < 0.25, "blur {found} px, expected {expected} px");
            assert_eq!(blurred.depth, still.depth, "depth is the capture instant's");
        }
    }
}

#[test]
fn motion_blur_spreads_an_edge_over_f_v_t_over_z_pixels_centred_on_the_capture_pose() {
    // A textureless wall (grey 99) from 20 m west of the line of sight to it, against the sky
    // (grey 200): a step edge at the image's centre column, above the horizon.
    let wall = Obstacle::Wall {
        from_ne_m: [5.1, -20.0],
        to_ne_m: [5.1, 0.0],
        height_m: 6.0,
        thickness_m: 0.2,
        textured: false,
    };
    let scene = Scene::new(&[wall]);
    let (v, exposure_s, depth_m) = (3.0, 0.04, 5.0);
    let expected = camera().intrinsics().focal_px * v * exposure_s / depth_m;
    for samples in [33, 32] {
        let blurred = blurring(exposure_s, samples).render_moving(
            &scene,
            &moving([0.0, v, 0.0], [0.0; 3]),
            0,
            &mut RenderBuffers::default(),
        );
        let profile = row_of(&blurred, &blurred.left, 150, (280, 360));
        let (dark, bright) = (profile[0], profile[profile.len() - 1]);
        assert_eq!((dark, bright), (99.0, 200.0));
        // 10 % and 90 % crossings, interpolated; a box blur of width w rises over 0.8·w.
        let crossing = |level: f64| {
            let target = dark + level * (bright - dark);
            let k = profile.iter().position(|&p| p >= target).unwrap();
            k as f64 - 1.0 + (target - profile[k - 1]) / (profile[k] - profile[k - 1])
        };
        let width = (crossing(0.9) - crossing(0.1)) / 0.8;
        let middle = 280.0 + crossing(0.5);
        eprintln!(
            "{samples} samples: edge {width:.2} px wide at column {middle:.2}, f·v·T/Z = {expected:.2} px"
        );
        assert!((width - expected).abs() < 1.0, "edge {width} px wide, expected {expected} px");
        // The wall ends straight ahead of the rig's centre, half a baseline right of the left camera.
        let centre = 319.5 + camera().intrinsics().disparity_px(depth_m) / 2.0;
        assert!((middle - centre).abs() < 0.25, "edge centred at {middle}, expected {centre}");
        let still =
            camera().render(&scene, &Vector3::new(0.0, 0.0, -ALTITUDE_M), &UnitQuaternion::identity(), 0);
        assert_eq!(blurred.depth, still.depth, "depth is the capture instant's");
    }
}

#[test]
fn yawing_blurs_the_image_centre_by_f_omega_t() {
    let f = camera().intrinsics().focal_px;
    let scene = Scene::new(&[wall_at(2.1, true)]);
    let fine = still_at_four_times_the_resolution(&scene);
    for (rate_rad_s, exposure_s) in [(0.5, 0.02), (1.0, 0.04)] {
        let pose = moving([0.0; 3], [0.0, 0.0, rate_rad_s]);
        let blurred = blurring(exposure_s, 33).render_moving(&scene, &pose, 0, &mut RenderBuffers::default());
        // Within 30 px of the centre the image moves at f·ω·(1 + (x/f)²) ≤ 1.02·f·ω px/s.
        let expected = f * rate_rad_s * exposure_s;
        let found = fitted_box_width_px(&fine, &blurred, (290, 350), (120, 200));
        eprintln!("{rate_rad_s} rad/s, {exposure_s} s: blur {found:.2} px, f·ω·T = {expected:.2} px");
        assert!((found - expected).abs() < 0.25, "blur {found} px, expected {expected} px");
    }
}

#[test]
fn exposure_gains_scale_the_images_and_saturate() {
    let scene = Scene::new(&[wall_at(4.0, true)]);
    let pose = (Vector3::new(0.0, 0.0, -ALTITUDE_M), UnitQuaternion::identity());
    let mean = |image: &[u8]| image.iter().map(|&p| f64::from(p)).sum::<f64>() / image.len() as f64;
    let plain = camera().render(&scene, &pose.0, &pose.1, 0);
    assert!(plain.left.iter().chain(&plain.right).all(|&p| p < 210), "no pixel near saturation");

    let params = StereoCameraParams {
        exposure_gain_std: 0.1,
        lr_gain_mismatch: 0.05,
        ..StereoCameraParams::default()
    };
    let rig = StereoCamera::new(&params).unwrap();
    for sequence in 0..4 {
        let (left_gain, right_gain) = rig.exposure_gains(sequence);
        assert!((right_gain / left_gain - 1.05).abs() < 1e-12);
        if right_gain > 1.2 {
            continue;
        }
        let r = rig.render(&scene, &pose.0, &pose.1, sequence);
        let (left_ratio, right_ratio) =
            (mean(&r.left) / mean(&plain.left), mean(&r.right) / mean(&plain.right));
        eprintln!(
            "frame {sequence}: gains {left_gain:.4}/{right_gain:.4}, mean ratios {left_ratio:.4}/{right_ratio:.4}"
        );
        assert!((left_ratio - left_gain).abs() < 0.005 && (right_ratio - right_gain).abs() < 0.005);
        assert_eq!(r.depth, plain.depth);
    }
    // Frame to frame the log gain is a standard normal times exposure_gain_std.
    let logs: Vec<f64> = (0..4000).map(|s| rig.exposure_gains(s).0.ln()).collect();
    let m = logs.iter().sum::<f64>() / logs.len() as f64;
    let std = (logs.iter().map(|l| (l - m).powi(2)).sum::<f64>() / logs.len() as f64).sqrt();
    assert!(m.abs() < 0.01 && (std - 0.1).abs() < 0.005, "log gain mean {m}, std {std}");

    // Open ground and sky: the sky's 200 grey levels times 1.5 saturate at 255.
    let open = Scene::new(&[]);
    let plain = camera().render(&open, &pose.0, &pose.1, 0);
    let bright =
        StereoCamera::new(&StereoCameraParams { lr_gain_mismatch: 0.5, ..StereoCameraParams::default() })
            .unwrap()
            .render(&open, &pose.0, &pose.1, 0);
    assert_eq!(bright.left, plain.left);
    let sky: Vec<usize> = (0..plain.right.len()).filter(|&i| plain.depth.depth_m[i].is_infinite()).collect();
    assert!(sky.len() > 1000 && sky.iter().all(|&i| plain.right[i] == 200 && bright.right[i] == 255));
}

#[test]
fn blurred_and_gained_renders_are_deterministic() {
    let world =
        World::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds/obstacles.toml"))
            .unwrap();
    let scene = Scene::new(&world.obstacles);
    let params = StereoCameraParams {
        exposure_time_s: 0.01,
        blur_samples: 4,
        exposure_gain_std: 0.1,
        lr_gain_mismatch: -0.03,
        noise_std: 1.0,
        ..StereoCameraParams::default()
    };
    let rig = StereoCamera::new(&params).unwrap();
    let pose = CapturePose {
        velocity_ned_m_s: Vector3::new(3.0, 0.5, 0.0),
        angular_velocity_frd_rad_s: Vector3::new(0.1, -0.2, 0.8),
        ..CapturePose::still(Vector3::new(5.0, 0.0, -2.0), UnitQuaternion::from_euler_angles(0.0, 0.05, 0.1))
    };
    let mut buffers = RenderBuffers::default();
    let a = rig.render_moving(&scene, &pose, 3, &mut buffers);
    assert_eq!(a, rig.render_moving(&scene, &pose, 3, &mut buffers), "reused buffers change nothing");
    assert_eq!(a, rig.clone().render_moving(&scene, &pose, 3, &mut RenderBuffers::default()));
    let b = rig.render_moving(&scene, &pose, 4, &mut buffers);
    assert_ne!(a.left, b.left);
    assert_eq!(a.depth, b.depth);
}

/// Asserts that the fast caster's render of `scene` at `pose` is the per-pixel reference's, bit
/// for bit: both images and the depth.
fn assert_renders_as_the_reference(camera: &StereoCamera, scene: &Scene, pose: &CapturePose, what: &str) {
    let fast = camera.render_moving(scene, pose, 7, &mut RenderBuffers::default());
    let slow = render_moving_reference(camera, scene, pose, 7, &mut RenderBuffers::default());
    let differ = |a: &[u8], b: &[u8]| a.iter().zip(b).filter(|(a, b)| a != b).count();
    assert_eq!(differ(&fast.left, &slow.left), 0, "{what}: left pixels differ");
    assert_eq!(differ(&fast.right, &slow.right), 0, "{what}: right pixels differ");
    let depth_differ = fast.depth.depth_m.iter().zip(&slow.depth.depth_m).filter(|(a, b)| a != b).count();
    assert_eq!(depth_differ, 0, "{what}: depths differ");
}

#[test]
fn the_fast_caster_renders_the_shipped_worlds_as_the_per_pixel_reference_does() {
    let worlds = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds");
    let sharp = camera();
    let blurred = StereoCamera::new(&StereoCameraParams {
        exposure_time_s: 0.01,
        blur_samples: 2,
        noise_std: 2.0,
        exposure_gain_std: 0.1,
        lr_gain_mismatch: 0.05,
        ..StereoCameraParams::default()
    })
    .unwrap();
    for name in ["obstacles.toml", "forest.toml", "wall-plain.toml"] {
        let world = World::load(&worlds.join(name)).unwrap();
        let scene = Scene::new(&world.obstacles);
        // Level at 5 m, pitched down and yawed inside the forest, low beside a trunk, moving.
        let poses = [
            CapturePose::still(Vector3::new(5.0, 0.0, -5.0), UnitQuaternion::identity()),
            CapturePose::still(
                Vector3::new(40.0, 2.0, -3.0),
                UnitQuaternion::from_euler_angles(0.1, -0.3, 0.7),
            ),
            CapturePose::still(
                Vector3::new(14.0, -1.0, -0.4),
                UnitQuaternion::from_euler_angles(0.0, 0.0, -0.4),
            ),
        ];
        for (i, pose) in poses.iter().enumerate() {
            assert_renders_as_the_reference(&sharp, &scene, pose, &format!("{name} pose {i}"));
        }
        let pose = moving([3.0, 0.5, 0.0], [0.1, -0.2, 0.8]);
        assert_renders_as_the_reference(&blurred, &scene, &pose, &format!("{name} blurred"));
    }
}

fn any_obstacle() -> impl Strategy<Value = Obstacle> {
    let coord = -30.0..30.0f64;
    prop_oneof![
        (coord.clone(), coord.clone(), -6.0..0.0f64, 0.1..6.0f64, 0.1..6.0f64, 0.1..6.0f64, -180.0..180.0f64)
            .prop_map(|(n, e, d, a, b, c, yaw_deg)| Obstacle::Box {
                center_ned_m: [n, e, d.min(-c / 2.0)],
                size_m: [a, b, c],
                yaw_deg,
            }),
        (coord.clone(), coord.clone(), 0.05..2.0f64, 0.5..20.0f64).prop_map(|(n, e, radius_m, height_m)| {
            Obstacle::Cylinder { base_ne_m: [n, e], radius_m, height_m }
        }),
        (coord.clone(), coord, -3.2..3.2f64, 0.5..20.0f64, 0.5..8.0f64, 0.05..1.0f64, any::<bool>())
            .prop_map(|(n, e, heading, length, height_m, thickness_m, textured)| Obstacle::Wall {
                from_ne_m: [n, e],
                to_ne_m: [n + length * heading.cos(), e + length * heading.sin()],
                height_m,
                thickness_m,
                textured,
            }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Random boxes, trunks and walls seen from random poses, at a small resolution so many
    /// cases run: the fast caster's images and depth are the reference's exactly.
    #[test]
    fn the_fast_caster_renders_random_scenes_as_the_per_pixel_reference_does(
        obstacles in proptest::collection::vec(any_obstacle(), 0..12),
        position in (-20.0..20.0f64, -20.0..20.0f64, -12.0..-0.2f64),
        euler in (-0.6..0.6f64, -0.8..0.8f64, -3.2..3.2f64),
    ) {
        let camera = StereoCamera::new(&StereoCameraParams {
            width_px: 96,
            height_px: 72,
            ..StereoCameraParams::default()
        })
        .unwrap();
        let pose = CapturePose::still(
            Vector3::new(position.0, position.1, position.2),
            UnitQuaternion::from_euler_angles(euler.0, euler.1, euler.2),
        );
        assert_renders_as_the_reference(&camera, &Scene::new(&obstacles), &pose, "random scene");
    }
}
