//! Wall time of the simulated stereo camera, the fast caster beside the per-pixel reference it
//! replaced, in one run: a VGA pair of `config/worlds/obstacles.toml` and of the forest of
//! `config/worlds/forest.toml`, sharp and with four motion-blur samples
//! (`cargo bench -p kestrel-sim --bench render`). The tests check that both render the same
//! pixels; how fast depends on the machine, so it is measured here and printed as a ratio.

use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use criterion::Criterion;
use kestrel_sim::World;
use kestrel_sim::camera::reference::render_moving_reference;
use kestrel_sim::camera::{CapturePose, RenderBuffers, Scene, StereoCamera, StereoCameraParams};
use nalgebra::{UnitQuaternion, Vector3};

/// Renders per timing of the printed ratio, alternating fast and reference so that a load
/// change on the shared machine hits both alike.
const RATIO_RENDERS: u32 = 20;

struct Case {
    name: &'static str,
    camera: StereoCamera,
    scene: Scene,
    pose: CapturePose,
}

fn cases() -> Vec<Case> {
    let worlds = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds");
    let scene =
        |name: &str| Scene::new(&World::load(&worlds.join(name)).expect("a shipped world loads").obstacles);
    let sharp = StereoCamera::new(&StereoCameraParams::default()).expect("default camera is valid");
    let blurred = StereoCamera::new(&StereoCameraParams {
        exposure_time_s: 0.01,
        blur_samples: 4,
        ..StereoCameraParams::default()
    })
    .expect("blurred camera is valid");
    let level_at = |north_m: f64, down_m: f64| {
        CapturePose::still(Vector3::new(north_m, 0.0, down_m), UnitQuaternion::identity())
    };
    let flying = CapturePose {
        velocity_ned_m_s: Vector3::new(3.0, 0.5, 0.0),
        angular_velocity_frd_rad_s: Vector3::new(0.1, -0.2, 0.8),
        ..CapturePose::still(Vector3::new(5.0, 0.0, -2.0), UnitQuaternion::from_euler_angles(0.0, 0.05, 0.1))
    };
    vec![
        Case {
            name: "VGA pair of obstacles.toml",
            camera: sharp.clone(),
            scene: scene("obstacles.toml"),
            pose: level_at(5.0, -2.0),
        },
        Case {
            name: "VGA pair of obstacles.toml, 4 blur samples",
            camera: blurred,
            scene: scene("obstacles.toml"),
            pose: flying,
        },
        Case {
            name: "VGA pair of forest.toml at 5 m",
            camera: sharp,
            scene: scene("forest.toml"),
            pose: level_at(8.0, -5.0),
        },
    ]
}

fn main() {
    let mut criterion = Criterion::default().configure_from_args();
    let cases = cases();
    let mut buffers = RenderBuffers::default();
    let mut sequence = 0;
    for case in &cases {
        criterion.bench_function(&format!("camera: {}", case.name), |b| {
            b.iter(|| {
                sequence += 1;
                black_box(case.camera.render_moving(&case.scene, &case.pose, sequence, &mut buffers))
            })
        });
        criterion.bench_function(&format!("camera (reference): {}", case.name), |b| {
            b.iter(|| {
                sequence += 1;
                black_box(render_moving_reference(
                    &case.camera,
                    &case.scene,
                    &case.pose,
                    sequence,
                    &mut buffers,
                ))
            })
        });
    }
    criterion.final_summary();

    for case in &cases {
        let (mut fast, mut reference) = (Duration::ZERO, Duration::ZERO);
        for _ in 0..RATIO_RENDERS {
            sequence += 1;
            let started = Instant::now();
            black_box(case.camera.render_moving(&case.scene, &case.pose, sequence, &mut buffers));
            fast += started.elapsed();
            let started = Instant::now();
            black_box(render_moving_reference(&case.camera, &case.scene, &case.pose, sequence, &mut buffers));
            reference += started.elapsed();
        }
        let per = |d: Duration| d.as_secs_f64() * 1e3 / f64::from(RATIO_RENDERS);
        println!(
            "render {}: fast {:.2} ms, reference {:.2} ms, {:.1}x faster",
            case.name,
            per(fast),
            per(reference),
            reference.as_secs_f64() / fast.as_secs_f64().max(1e-9)
        );
    }
}
