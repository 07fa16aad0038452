//! The camera actor shell: ports, frame schedule on ground-truth time, bad params.

use std::path::Path;

use kestrel_proto::messages::{GroundTruth, StereoFrame};
use kestrel_proto::testing::{TestSetup, ready};
use kestrel_proto::{Actor, ActorError, Time};
use kestrel_sim::{CameraSimActor, CameraSimParams};

fn setup() -> TestSetup<GroundTruth> {
    TestSetup::new("camera", Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config"))
}

/// Level, facing north, 2 m up, 10 m south of the first tree of `obstacles.toml` (at 15, −3).
fn truth(time_us: u64) -> GroundTruth {
    GroundTruth {
        time: Time(time_us),
        position_ned_m: [5.0, -3.0, -2.0],
        velocity_ned_m_s: [0.0; 3],
        acceleration_ned_m_s2: [0.0; 3],
        attitude: [1.0, 0.0, 0.0, 0.0],
        angular_velocity_rad_s: [0.0; 3],
        lat_deg: 0.0,
        lon_deg: 0.0,
        alt_msl_m: 0.0,
        landed: false,
        crashed: false,
        collisions: 0,
        clearance_m: None,
    }
}

#[test]
fn renders_at_its_rate_on_ground_truth_time() {
    let mut setup = setup();
    let params: CameraSimParams =
        toml::from_str("world = \"worlds/obstacles.toml\"\n[camera]\nwidth_px = 320\nheight_px = 240\n")
            .unwrap();
    assert_eq!(params.rate_hz, 15.0);
    let mut actor = CameraSimActor::build(&params, &mut setup).unwrap();
    assert_eq!(setup.input_ports(), ["ground_truth"]);
    assert_eq!(setup.output_ports(), ["stereo_frame"]);
    let ctx = setup.context();
    for i in 0..50 {
        ready(actor.handle(&ctx, setup.input("ground_truth", truth(i * 20_000)))).unwrap();
    }
    let frames = setup.published::<StereoFrame>("stereo_frame");
    let times: Vec<u64> = frames.iter().map(|f| f.time.0 / 1000).collect();
    assert_eq!(times, [0, 80, 140, 200, 280, 340, 400, 480, 540, 600, 680, 740, 800, 880, 940]);
    assert!(frames.iter().enumerate().all(|(i, f)| f.sequence == i as u64 && f.has_pixels()));
    assert_eq!((frames[0].width, frames[0].height), (320, 240));
    assert_eq!(frames[0].left(), frames[14].left(), "same pose, same picture");
    // The trunk (radius 0.6 m) is 10 m ahead of the rig's centre, the left camera 6 cm to its left.
    let centre = actor.last_depth().unwrap().at(159, 119).unwrap();
    assert!((centre - 9.4).abs() < 0.01, "{centre} m");
}

#[test]
fn bad_params_are_errors() {
    let build = |text: &str| {
        let params: CameraSimParams = toml::from_str(text).unwrap();
        CameraSimActor::build(&params, &mut setup()).err()
    };
    assert!(matches!(build("rate_hz = 0.0"), Some(ActorError::Params(_))));
    assert!(
        matches!(build("[camera]\nhorizontal_fov_deg = 200.0"), Some(ActorError::Params(m)) if m.contains("horizontal_fov_deg"))
    );
    assert!(matches!(build("world = \"worlds/missing.toml\""), Some(ActorError::Params(_))));
}
