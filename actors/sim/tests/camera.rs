//! The simulated stereo camera against geometry worked out by hand.

use std::path::Path;
use std::time::Instant;

use kestrel_sim::Obstacle;
use kestrel_sim::World;
use kestrel_sim::camera::{Scene, StereoCamera, StereoCameraParams, StereoRender};
use nalgebra::{UnitQuaternion, Vector3};

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

#[test]
fn a_vga_pair_of_the_obstacle_course_renders_quickly() {
    let world =
        World::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds/obstacles.toml"))
            .unwrap();
    let scene = Scene::new(&world.obstacles);
    let cam = camera();
    let (position, attitude) = (Vector3::new(5.0, 0.0, -2.0), UnitQuaternion::identity());
    for (what, scene) in [("empty", Scene::new(&[])), ("obstacles", scene.clone())] {
        let start = Instant::now();
        std::hint::black_box(cam.render(&scene, &position, &attitude, 0));
        eprintln!("{what}: {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
    }
    let start = Instant::now();
    let frames = 10;
    for sequence in 0..frames {
        std::hint::black_box(cam.render(&scene, &position, &attitude, sequence));
    }
    let per_pair_ms = start.elapsed().as_secs_f64() * 1e3 / frames as f64;
    eprintln!("VGA stereo pair of obstacles.toml: {per_pair_ms:.1} ms");
    assert!(per_pair_ms < 500.0, "{per_pair_ms} ms per pair");
}
