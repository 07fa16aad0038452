//! The camera and stereo actors in whole graphs on the lockstep clock: frames flow from a
//! folder of images to depth grids, and a panic inside the stereo worker is contained by the
//! supervisor while the camera keeps publishing.

use std::path::Path;
use std::time::Duration;

use kestrel::run::RunReport;
use kestrel::{LoadedConfig, Registry, RunOptions, run};
use kestrel_proto::messages::SupervisorEventKind;
use kestrel_proto::{Actor, ActorError, Context, Setup, Time};
use kestrel_vision::{
    CameraActor, Geometry, PipelineParams, StereoActor, StereoFrame, StereoInput, StereoParams,
    StereoPipeline,
};

/// The stereo actor with a fault injected: it panics on frame 2.
struct FaultyStereo(StereoActor);

impl Actor for FaultyStereo {
    type Params = StereoParams;
    type Input = StereoInput;

    fn build(params: &StereoParams, setup: &mut impl Setup<StereoInput>) -> Result<Self, ActorError> {
        StereoActor::build(params, setup).map(FaultyStereo)
    }

    async fn handle(&mut self, ctx: &Context, input: StereoInput) -> Result<(), ActorError> {
        if let StereoInput::Frame(frame) = &input
            && frame.sequence == 2
        {
            panic!("injected fault in the stereo worker at frame {}", frame.sequence);
        }
        self.0.handle(ctx, input).await
    }
}

fn graph(stereo_type: &str) -> String {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("actors/vision/tests/data/middlebury2003_cones");
    format!(
        r#"
[actors.camera]
type = "camera"
params = {{ fps = 10.0, source = {{ kind = "image_folder", dir = "{}", left = "im2.png", right = "im6.png", repeat = true }} }}

[actors.stereo]
type = "{stereo_type}"
restart = {{ max_restarts = 3, window_s = 60.0, backoff_initial_s = 0.1, backoff_max_s = 1.0 }}
inputs.stereo_frame = {{ topic = "stereo_frame", mailbox = "latest" }}
params = {{ geometry = {{ rectified = {{ focal_px = 450.0, cx_px = 224.5, cy_px = 187.0, baseline_m = 0.1 }} }} }}
"#,
        data.display()
    )
}

fn run_graph(text: &str, seconds: f64) -> RunReport {
    let config = LoadedConfig::parse(Path::new("graph.toml"), text).unwrap();
    let registry = Registry::new()
        .with::<CameraActor>("camera")
        .with::<StereoActor>("stereo")
        .with::<FaultyStereo>("faulty_stereo");
    let options = RunOptions {
        duration: Some(Duration::from_secs_f64(seconds)),
        speedup: Some(0.0),
        ..Default::default()
    };
    run(&config, &registry, options).unwrap()
}

fn published(report: &RunReport, topic: &str) -> u64 {
    report.topics.iter().find(|(name, _, _)| name == topic).map_or(0, |t| t.2)
}

#[test]
fn frames_from_a_folder_become_depth_grids() {
    let report = run_graph(&graph("stereo"), 0.5);
    assert_eq!(published(&report, "stereo_frame"), 5, "{report:#?}");
    assert_eq!(published(&report, "depth_grid"), 5, "{report:#?}");
    assert!(report.supervisor_events.is_empty(), "{:?}", report.supervisor_events);
}

#[test]
fn a_panic_in_the_stereo_worker_is_contained_and_the_worker_restarts() {
    let report = run_graph(&graph("faulty_stereo"), 1.0);
    let kinds: Vec<SupervisorEventKind> = report.supervisor_events.iter().map(|e| e.kind).collect();
    assert_eq!(kinds, [SupervisorEventKind::Failed, SupervisorEventKind::Restarted], "{report:#?}");
    assert!(
        report.supervisor_events[0].reason.contains("injected fault"),
        "{:?}",
        report.supervisor_events[0]
    );
    assert_eq!(published(&report, "stereo_frame"), 10, "the camera never missed a frame");
    let grids = published(&report, "depth_grid");
    assert!((7..=9).contains(&grids), "frames after the restart are processed again: {grids}");
}

#[test]
fn recorded_frames_keep_their_metadata_and_drop_their_pixels() {
    let frame = StereoFrame::new(Time(5), 3, 2, 1, vec![1, 2], vec![3, 4]).unwrap();
    let json = serde_json::to_string(&frame).unwrap();
    assert_eq!(json, r#"{"time":5,"sequence":3,"width":2,"height":1}"#);
    let back: StereoFrame = serde_json::from_str(&json).unwrap();
    assert!(!back.has_pixels());
    let geometry = Geometry::Rectified(kestrel_vision::StereoGeometry {
        focal_px: 450.0,
        cx_px: 0.0,
        cy_px: 0.0,
        baseline_m: 0.1,
        doffs_px: 0.0,
        depth_scale: 1.0,
    });
    let mut pipeline = StereoPipeline::new(&geometry, &PipelineParams::default(), Path::new(".")).unwrap();
    let err = pipeline.process(&back).unwrap_err();
    assert!(err.to_string().contains("carries no pixels"), "{err}");
    assert!(StereoFrame::new(Time(0), 0, 2, 2, vec![0; 3], vec![0; 4]).is_err());
}

#[test]
fn bad_actor_parameters_are_reported_at_start() {
    let text = graph("stereo").replace("baseline_m = 0.1", "baseline_m = -0.1");
    let config = LoadedConfig::parse(Path::new("graph.toml"), &text).unwrap();
    let registry = Registry::new().with::<CameraActor>("camera").with::<StereoActor>("stereo");
    let options =
        RunOptions { duration: Some(Duration::from_secs_f64(0.2)), speedup: Some(0.0), ..Default::default() };
    let outcome = run(&config, &registry, options);
    let text = match outcome {
        Err(e) => e.to_string(),
        Ok(report) => format!("{:?}", report.supervisor_events),
    };
    assert!(text.contains("baseline"), "{text}");
}
