//! The camera actor shell: ports, capture and delivery schedule on ground-truth time, renders
//! on the blocking pool, bad params.

use std::path::Path;
use std::time::Duration;

use kestrel_proto::messages::{GroundTruth, SimFault, SimFaultPhase, StereoFrame};
use kestrel_proto::testing::TestSetup;
use kestrel_proto::{Actor, ActorError, Time};
use kestrel_sim::{CameraInput, CameraSimActor, CameraSimParams};

fn setup() -> TestSetup<CameraInput> {
    TestSetup::new("camera", Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config"))
}

/// Level, facing north, 2 m up, 10 m south of the first tree of `obstacles.toml` (at 15, −3),
/// drifting north at `speed_m_s`.
fn truth(time_us: u64, speed_m_s: f64) -> GroundTruth {
    let north_m = 5.0 + speed_m_s * time_us as f64 * 1e-6;
    GroundTruth {
        time: Time(time_us),
        position_ned_m: [north_m, -3.0, -2.0],
        velocity_ned_m_s: [speed_m_s, 0.0, 0.0],
        ..GroundTruth::default()
    }
}

/// A QVGA camera on `obstacles.toml` with the given extra parameters.
fn params(extra: &str) -> CameraSimParams {
    toml::from_str(&format!(
        "world = \"worlds/obstacles.toml\"\n{extra}\n[camera]\nwidth_px = 320\nheight_px = 240\n"
    ))
    .unwrap()
}

/// One published frame: stamp, sequence, pixels, and the time of the ground-truth sample
/// whose handler published it (the graph time of publication under lockstep).
#[derive(Debug, PartialEq)]
struct Delivery {
    stamp_us: u64,
    sequence: u64,
    published_us: u64,
    left: Vec<u8>,
    right: Vec<u8>,
}

/// Feeds 50 Hz ground truth for one second into a fresh actor. With `settle`, the test waits
/// 40 ms of wall time after each sample, so renders are finished when their delivery sample
/// comes; without, the delivery sample usually has to await them.
async fn fly(params: &CameraSimParams, speed_m_s: f64, settle: bool) -> (Vec<Delivery>, CameraSimActor) {
    let mut setup = setup();
    let mut actor = CameraSimActor::build(params, &mut setup).unwrap();
    let ctx = setup.context();
    let mut out = Vec::new();
    for i in 0..50 {
        let truth = truth(i * 20_000, speed_m_s);
        setup.manual_clock().set(truth.time);
        actor.handle(&ctx, setup.input("ground_truth", truth.clone())).await.unwrap();
        let frames = setup.published::<StereoFrame>("stereo_frame");
        out.extend(frames.iter().skip(out.len()).map(|f: &StereoFrame| Delivery {
            stamp_us: f.time.0,
            sequence: f.sequence,
            published_us: truth.time.0,
            left: f.left().to_vec(),
            right: f.right().to_vec(),
        }));
        if settle {
            tokio::time::sleep(Duration::from_millis(40)).await;
        }
    }
    (out, actor)
}

/// Capture instants of 15 Hz frames on a 50 Hz ground truth (ms).
const CAPTURES_MS: [u64; 15] = [0, 80, 140, 200, 280, 340, 400, 480, 540, 600, 680, 740, 800, 880, 940];

#[tokio::test]
async fn captures_at_its_rate_and_delivers_latency_later_stamped_with_the_capture() {
    let mut setup = setup();
    let params = params("");
    assert_eq!((params.rate_hz, params.latency_s), (15.0, 0.04));
    CameraSimActor::build(&params, &mut setup).unwrap();
    assert_eq!(setup.input_ports(), ["ground_truth", "sim_fault"]);
    assert_eq!(setup.output_ports(), ["stereo_frame"]);

    let (frames, actor) = fly(&params, 0.0, false).await;
    let stamps: Vec<u64> = frames.iter().map(|f| f.stamp_us / 1000).collect();
    assert_eq!(stamps, CAPTURES_MS);
    let published: Vec<u64> = frames.iter().map(|f| f.published_us / 1000).collect();
    assert_eq!(published, CAPTURES_MS.map(|t| t + 40), "first sample at or after capture + 40 ms");
    assert!(frames.iter().enumerate().all(|(i, f)| f.sequence == i as u64 && f.left.len() == 320 * 240));
    assert_eq!(frames[0].left, frames[14].left, "same pose, same picture");
    assert_eq!(actor.skipped(), 0);
    // The trunk (radius 0.6 m) is 10 m ahead of the rig's centre, the left camera 6 cm to its left.
    let centre = actor.last_depth().unwrap().at(159, 119).unwrap();
    assert!((centre - 9.4).abs() < 0.01, "{centre} m");
}

#[tokio::test]
async fn a_latency_between_samples_delivers_on_the_next_sample_and_zero_on_the_capture_sample() {
    let (frames, _) = fly(&params("latency_s = 0.025"), 0.0, false).await;
    let published: Vec<u64> = frames.iter().map(|f| f.published_us / 1000).collect();
    assert_eq!(published, CAPTURES_MS.map(|t| t + 40), "25 ms after capture is the second sample on");

    let (frames, _) = fly(&params("latency_s = 0.0"), 0.0, false).await;
    assert!(frames.iter().all(|f| f.published_us == f.stamp_us));
    assert_eq!(frames.len(), CAPTURES_MS.len());
}

#[tokio::test]
async fn the_same_ground_truth_gives_the_same_frames_at_the_same_times_however_fast_renders_finish() {
    let params = params("");
    let (awaited, _) = fly(&params, 2.0, false).await;
    let (settled, _) = fly(&params, 2.0, true).await;
    let (again, _) = fly(&params, 2.0, false).await;
    assert_eq!(awaited.len(), CAPTURES_MS.len());
    assert_ne!(awaited[0].left, awaited[1].left, "the pose moves, so frames differ");
    assert!(awaited == settled && awaited == again, "deliveries differ between runs");
}

#[tokio::test]
async fn a_latency_longer_than_four_frames_skips_captures_instead_of_queueing() {
    // 0.3 s at 15 Hz would keep five frames in flight; the pipeline holds four.
    let (frames, actor) = fly(&params("latency_s = 0.3"), 0.0, false).await;
    assert!(actor.skipped() > 0);
    assert!(frames.iter().enumerate().all(|(i, f)| f.sequence == i as u64));
    assert!(frames.iter().all(|f| f.published_us >= f.stamp_us + 300_000));
    assert!(frames.iter().all(|f| f.published_us < f.stamp_us + 320_000));
}

/// A `sim_fault` event of the simulator's fault `index` (beyond the world's own) at `time_us`.
fn sim_fault(index: u32, phase: SimFaultPhase, time_us: u64, kind: &str, values: &str) -> SimFault {
    SimFault {
        time: Time(time_us),
        index,
        phase,
        kind: kind.into(),
        values: values.into(),
        at_s: time_us as f64 * 1e-6,
        for_s: None,
    }
}

#[tokio::test]
async fn a_camera_fault_the_simulator_adds_while_running_applies_from_its_start_to_its_end() {
    let mut setup = setup();
    let mut actor = CameraSimActor::build(&params("latency_s = 0.0"), &mut setup).unwrap();
    let ctx = setup.context();
    for i in 0..50u64 {
        let time_us = i * 20_000;
        if time_us == 300_000 {
            let start = sim_fault(3, SimFaultPhase::Started, time_us, "camera_capped", "lens = \"right\"");
            actor.handle(&ctx, setup.input("sim_fault", start)).await.unwrap();
            // Another sensor's fault is none of the camera's business.
            let gps = sim_fault(4, SimFaultPhase::Started, time_us, "gps_off", "");
            actor.handle(&ctx, setup.input("sim_fault", gps)).await.unwrap();
        }
        if time_us == 700_000 {
            let end = sim_fault(3, SimFaultPhase::Ended, time_us, "camera_capped", "lens = \"right\"");
            actor.handle(&ctx, setup.input("sim_fault", end)).await.unwrap();
        }
        let truth = truth(time_us, 0.0);
        setup.manual_clock().set(truth.time);
        actor.handle(&ctx, setup.input("ground_truth", truth)).await.unwrap();
    }
    let frames = setup.published::<StereoFrame>("stereo_frame");
    let capped: Vec<u64> =
        frames.iter().filter(|f| f.right().iter().all(|&p| p == 0)).map(|f| f.time.0 / 1000).collect();
    assert_eq!(capped, [340, 400, 480, 540, 600, 680], "captured from 300 ms up to 700 ms");
    assert!(frames.iter().all(|f| f.left().iter().any(|&p| p != 0)), "the left lens still sees");
}

#[test]
fn bad_params_are_errors_naming_the_field() {
    let field = |p: CameraSimParams| p.validate().unwrap_err().field;
    let d = CameraSimParams::default;
    assert_eq!(field(CameraSimParams { rate_hz: 0.0, ..d() }), "rate_hz");
    for latency_s in [-0.01, f64::NAN, f64::INFINITY, 1.5] {
        assert_eq!(field(CameraSimParams { latency_s, ..d() }), "latency_s");
    }
    let build = |text: &str| {
        let params: CameraSimParams = toml::from_str(text).unwrap();
        CameraSimActor::build(&params, &mut setup()).err()
    };
    assert!(matches!(build("rate_hz = 0.0"), Some(ActorError::Params(m)) if m.contains("rate_hz")));
    assert!(matches!(build("latency_s = -0.1"), Some(ActorError::Params(m)) if m.contains("latency_s")));
    assert!(
        matches!(build("[camera]\nhorizontal_fov_deg = 200.0"), Some(ActorError::Params(m)) if m.contains("camera.horizontal_fov_deg"))
    );
    assert!(matches!(build("world = \"worlds/missing.toml\""), Some(ActorError::Params(_))));
}

/// `obstacles.toml` with `faults` appended, written to a scratch file (an absolute path, which
/// the camera's `world` accepts as is).
fn world_with_faults(name: &str, faults: &str) -> String {
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds/obstacles.toml");
    let text = std::fs::read_to_string(base).unwrap();
    let dir = std::env::temp_dir().join(format!("kestrel-camera-faults-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, format!("{text}\n{faults}")).unwrap();
    path.display().to_string()
}

#[tokio::test]
async fn camera_faults_stop_blacken_and_freeze_the_frames_in_their_windows() {
    let world = world_with_faults(
        "camera.toml",
        "[[faults]]\nat_s = 0.19\nfor_s = 0.2\nkind = \"camera_stop\"\n\n\
         [[faults]]\nat_s = 0.39\nfor_s = 0.2\nkind = \"camera_black\"\n\n\
         [[faults]]\nat_s = 0.59\nfor_s = 0.2\nkind = \"camera_frozen\"\n",
    );
    let with_faults: CameraSimParams =
        toml::from_str(&format!("world = \"{world}\"\n[camera]\nwidth_px = 320\nheight_px = 240\n")).unwrap();
    let (healthy, _) = fly(&params(""), 2.0, false).await;
    let (frames, _) = fly(&with_faults, 2.0, false).await;
    let stamps: Vec<u64> = frames.iter().map(|f| f.stamp_us / 1000).collect();
    // Captures at 200, 280 and 340 ms fall in the stop window: never taken.
    assert_eq!(stamps, [0, 80, 140, 400, 480, 540, 600, 680, 740, 800, 880, 940]);
    assert!(frames.iter().enumerate().all(|(i, f)| f.sequence == i as u64), "no gap in the sequence");
    let healthy_at = |ms: u64| healthy.iter().find(|f| f.stamp_us == ms * 1000).unwrap();
    for f in &frames {
        let ms = f.stamp_us / 1000;
        let (left, right) = match ms {
            400..=540 => (vec![0; 320 * 240], vec![0; 320 * 240]),
            // The last healthy frame before the freeze is the one of 140 ms.
            600..=740 => (healthy_at(140).left.clone(), healthy_at(140).right.clone()),
            _ => (healthy_at(ms).left.clone(), healthy_at(ms).right.clone()),
        };
        assert!(f.left == left && f.right == right, "frame at {ms} ms");
        assert_eq!(f.published_us, f.stamp_us + 40_000, "on time at {ms} ms");
    }
    assert_ne!(healthy_at(140).left, healthy_at(600).left, "the pose moved, so a frozen frame is stale");
}
