//! Wall time of the simulated stereo camera: one VGA pair of `config/worlds/obstacles.toml`
//! from 2 m up, sharp and with four motion-blur samples
//! (`cargo bench -p kestrel-sim --bench render`). The tests check what is rendered; how fast
//! depends on the machine, so it is measured here.

use std::hint::black_box;
use std::path::Path;

use criterion::Criterion;
use kestrel_sim::World;
use kestrel_sim::camera::{CapturePose, RenderBuffers, Scene, StereoCamera, StereoCameraParams};
use nalgebra::{UnitQuaternion, Vector3};

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds/obstacles.toml");
    let world = World::load(&path).expect("the shipped obstacle world loads");
    let scene = Scene::new(&world.obstacles);
    let mut criterion = Criterion::default().configure_from_args();

    let sharp = StereoCamera::new(&StereoCameraParams::default()).expect("default camera is valid");
    let (position, level) = (Vector3::new(5.0, 0.0, -2.0), UnitQuaternion::identity());
    let mut sequence = 0;
    criterion.bench_function("camera: VGA pair of obstacles.toml", |b| {
        b.iter(|| {
            sequence += 1;
            black_box(sharp.render(&scene, &position, &level, sequence))
        })
    });

    let params =
        StereoCameraParams { exposure_time_s: 0.01, blur_samples: 4, ..StereoCameraParams::default() };
    let blurred = StereoCamera::new(&params).expect("blurred camera is valid");
    let pose = CapturePose {
        velocity_ned_m_s: Vector3::new(3.0, 0.5, 0.0),
        angular_velocity_frd_rad_s: Vector3::new(0.1, -0.2, 0.8),
        ..CapturePose::still(position, UnitQuaternion::from_euler_angles(0.0, 0.05, 0.1))
    };
    let mut buffers = RenderBuffers::default();
    criterion.bench_function("camera: VGA pair of obstacles.toml, 4 blur samples", |b| {
        b.iter(|| {
            sequence += 1;
            black_box(blurred.render_moving(&scene, &pose, sequence, &mut buffers))
        })
    });
    criterion.final_summary();
}
