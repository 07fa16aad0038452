//! `kestrel stereo`: frame → depth grid on a stereo source, with per-stage timings.
//!
//! It drives the same cores the camera and stereo actors wrap ([`FrameSource`],
//! [`StereoPipeline`]) in a plain loop rather than through an actor graph: the stage timings
//! live inside the pipeline, which the actors' messages (`StereoFrame`, `DepthGrid`) do not
//! carry, and a bench must time every frame, while the graph's `latest` mailbox deliberately
//! skips frames the worker is too slow for. The graph itself runs with `kestrel run` and a
//! config naming the `camera` and `stereo` actors.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use kestrel::recorder::Recorder;
use kestrel_proto::Time;
use kestrel_proto::messages::DepthGrid;
use kestrel_vision::{FrameSource, SourceParams, StereoParams, StereoPipeline};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::cli::StereoArgs;

/// How long each stage of one frame took (ms), as recorded on `stereo_timing`.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
pub struct StereoTiming {
    /// When the frame was read, since the command started.
    pub time: Time,
    pub frame_sequence: u64,
    /// Reading and decoding the pair (camera, video or image files).
    pub capture_ms: f64,
    /// Undistortion and rectification, and any downscale.
    pub rectify_ms: f64,
    /// Disparity search and the texture check.
    pub match_ms: f64,
    /// Disparity → depth: 0 since the grid is summarised straight from the matcher's output
    /// (`DepthGridder::grid_fixed_point`), which `grid_ms` counts.
    pub depth_ms: f64,
    /// The matcher's output → grid regions and sectors.
    pub grid_ms: f64,
    /// Capture to grid.
    pub total_ms: f64,
}
kestrel_proto::impl_message!(StereoTiming);

impl StereoTiming {
    fn stages(&self) -> [f64; 6] {
        [self.capture_ms, self.rectify_ms, self.match_ms, self.depth_ms, self.grid_ms, self.total_ms]
    }
}

const STAGES: [&str; 6] = ["capture", "rectify", "match", "depth", "grid", "total"];

/// Runs the pipeline over the source until it ends, `--frames` are done or Ctrl-C.
pub fn run(args: StereoArgs) -> Result<(), String> {
    let params = stereo_params(&args.config)?;
    let base_dir = args.config.parent().unwrap_or(Path::new("."));
    let mut pipeline =
        StereoPipeline::new(&params.geometry, &params.pipeline, base_dir).map_err(|e| e.to_string())?;
    let mut source = FrameSource::open(&source_params(&args)?, Path::new("")).map_err(|e| e.to_string())?;
    let recording = match &args.record {
        Some(path) => {
            let recorder = Recorder::create(path).map_err(|e| e.to_string())?;
            let grids = recorder.channel::<DepthGrid>("depth_grid").map_err(|e| e.to_string())?;
            let timings = recorder.channel::<StereoTiming>("stereo_timing").map_err(|e| e.to_string())?;
            Some((recorder, grids, timings))
        }
        None => None,
    };
    let interrupted = interrupt_flag();
    let start = Instant::now();
    let mut timings = Vec::new();
    let mut sequence = 0;
    while args.frames.is_none_or(|n| sequence < n) && !interrupted.load(Ordering::Relaxed) {
        let capture_start = Instant::now();
        let Some((left, right)) = source.next_pair().map_err(|e| format!("{}: {e}", source.name()))? else {
            break;
        };
        let captured = Instant::now();
        let time = Time::from_micros(u64::try_from((captured - start).as_micros()).unwrap_or(u64::MAX));
        let grid =
            pipeline.grid(&left, &right, time, sequence).map_err(|e| format!("frame {sequence}: {e}"))?;
        let stages = pipeline.times();
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let timing = StereoTiming {
            time,
            frame_sequence: sequence,
            capture_ms: ms(captured - capture_start),
            rectify_ms: ms(stages.rectify),
            match_ms: ms(stages.matching),
            depth_ms: ms(stages.depth),
            grid_ms: ms(stages.grid),
            total_ms: ms(capture_start.elapsed()),
        };
        if !args.quiet {
            print_frame(&grid, &timing);
        }
        if let Some((_, grids, timings)) = &recording {
            grids.record(time, &grid);
            timings.record(time, &timing);
        }
        timings.push(timing);
        sequence += 1;
    }
    if timings.is_empty() {
        return Err(format!("{}: no frames", source.name()));
    }
    print_summary(&timings, start.elapsed());
    if let Some((recorder, _, _)) = recording {
        let summary = recorder.finish().map_err(|e| e.to_string())?;
        println!("recorded {} frames to {}", timings.len(), summary.path.display());
    }
    Ok(())
}

/// The stereo parameters in `path`: a bare params table, or a graph config's one `stereo` actor.
fn stereo_params(path: &Path) -> Result<StereoParams, String> {
    let at = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let text = std::fs::read_to_string(path).map_err(|e| at(&e))?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| at(&e))?;
    let params = match table.get("actors").and_then(toml::Value::as_table) {
        Some(actors) => {
            let mut stereo =
                actors.values().filter(|a| a.get("type").and_then(toml::Value::as_str) == Some("stereo"));
            let (Some(actor), None) = (stereo.next(), stereo.next()) else {
                return Err(at(&"a graph config needs exactly one actor of type \"stereo\""));
            };
            actor.get("params").cloned().unwrap_or_else(|| toml::Value::Table(toml::Table::new()))
        }
        None => toml::Value::Table(table),
    };
    params.try_into().map_err(|e| at(&e))
}

/// The frame source `--source` names.
fn source_params(args: &StereoArgs) -> Result<SourceParams, String> {
    let source = args.source.as_str();
    if let Some(device) = source.strip_prefix("/dev/video") {
        let device = device.parse().map_err(|_| format!("--source {source}: expected /dev/videoN"))?;
        let bad_size = || format!("--size {}: expected WIDTHxHEIGHT, e.g. 1344x376", args.size);
        let (width, height) = args.size.split_once('x').ok_or_else(bad_size)?;
        return Ok(SourceParams::SideBySide {
            device,
            width: width.parse().map_err(|_| bad_size())?,
            height: height.parse().map_err(|_| bad_size())?,
            fps: args.fps,
        });
    }
    if let Some((left, right)) = source.split_once(',') {
        return Ok(SourceParams::VideoPair { left: left.into(), right: right.into() });
    }
    if Path::new(source).is_dir() {
        return Ok(SourceParams::ImageFolder {
            dir: PathBuf::from(source),
            left: args.left.clone(),
            right: args.right.clone(),
            repeat: false,
        });
    }
    Err(format!("--source {source}: not a folder, a LEFT,RIGHT pair of videos or /dev/videoN"))
}

/// Set on Ctrl-C or SIGTERM, so the loop can stop and still print its summary and close the log.
fn interrupt_flag() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = Arc::clone(&flag);
    std::thread::spawn(move || {
        let Ok(runtime) = tokio::runtime::Builder::new_current_thread().enable_all().build() else {
            return;
        };
        runtime.block_on(kestrel::shutdown::interrupt());
        set.store(true, Ordering::Relaxed);
    });
    flag
}

fn print_frame(grid: &DepthGrid, t: &StereoTiming) {
    println!(
        "frame {} at {:.3} s: capture {:.2} rectify {:.2} match {:.2} depth {:.2} grid {:.2} total {:.2} ms",
        t.frame_sequence,
        t.time.as_secs_f64(),
        t.capture_ms,
        t.rectify_ms,
        t.match_ms,
        t.depth_ms,
        t.grid_ms,
        t.total_ms
    );
    for (name, row) in ["up", "centre", "down"].iter().zip(&grid.regions) {
        let near: Vec<String> = row.iter().map(|r| format!("{:.2}", r.near_share)).collect();
        let invalid: Vec<String> = row.iter().map(|r| format!("{:.2}", r.invalid_share)).collect();
        let nearest: Vec<String> =
            row.iter().map(|r| r.nearest_m.map_or_else(|| "-".to_owned(), |z| format!("{z:.2}"))).collect();
        println!(
            "  {name:6} near {}  invalid {}  nearest_m {}",
            near.join(" "),
            invalid.join(" "),
            nearest.join(" ")
        );
    }
}

/// Nearest-rank percentile `p` (0..1) of ascending `sorted`.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    let rank = ((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

fn print_summary(timings: &[StereoTiming], elapsed: Duration) {
    println!(
        "{} frames in {:.2} s ({:.1} frames/s)\nstage      p50 ms   p95 ms   max ms",
        timings.len(),
        elapsed.as_secs_f64(),
        timings.len() as f64 / elapsed.as_secs_f64()
    );
    for (i, name) in STAGES.iter().enumerate() {
        let mut values: Vec<f64> = timings.iter().map(|t| t.stages()[i]).collect();
        values.sort_by(f64::total_cmp);
        println!(
            "{name:8} {:8.2} {:8.2} {:8.2}",
            percentile(&values, 0.5),
            percentile(&values, 0.95),
            values[values.len() - 1]
        );
    }
}
