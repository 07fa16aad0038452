//! The programs in `examples/` build and run as a newcomer runs them: each is built by cargo
//! (with this test's features, so nothing else is rebuilt) and run with arguments that finish
//! in seconds, and what it prints is checked against a reference it does not compute itself —
//! `kestrel replay`, Middlebury's ground truth, a pymavlink ground station, the box it was given.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Builds `examples/NAME.rs` (a no-op when it is up to date) and returns its executable.
fn example(name: &str) -> PathBuf {
    // This test runs from <target>/<profile>/deps/; the example is built into the same target
    // directory, under <target>/<profile>/examples/.
    let exe = std::env::current_exe().expect("the test's own path");
    let profile_dir = exe.parent().and_then(Path::parent).expect("<target>/<profile>");
    let target_dir = profile_dir.parent().expect("<target>");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| env!("CARGO").into());
    let mut build = Command::new(cargo);
    build.current_dir(root()).args(["build", "--quiet", "--locked", "-p", "kestrel", "--example", name]);
    build.arg("--target-dir").arg(target_dir);
    // Tests built with --release look for their examples under release/: build them so too.
    if profile_dir.ends_with("release") {
        build.arg("--release");
    }
    if cfg!(feature = "zenoh") {
        build.args(["--features", "zenoh"]);
    }
    let status = build.status().expect("run cargo build");
    assert!(status.success(), "cargo build --example {name}: {status}");
    let path = profile_dir.join("examples").join(name);
    assert!(path.exists(), "{} was not built", path.display());
    path
}

/// Runs `exe` with `args` to its end; stdout as text, after checking it succeeded.
fn run_to_end(exe: &Path, args: &[&str]) -> (String, Duration) {
    let start = Instant::now();
    let out: Output = Command::new(exe).args(args).current_dir(scratch()).output().expect("run the example");
    let took = start.elapsed();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    println!("{} {args:?} ({:.1} s):\n{stdout}", exe.display(), took.as_secs_f64());
    assert!(
        out.status.success(),
        "{}: {}\n{}",
        exe.display(),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    (stdout, took)
}

/// A directory of this test run's own for what the examples write.
fn scratch() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("examples");
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// The `(width, height)` of a PNG file, read by the `png` crate.
fn png_size(path: &Path) -> (u32, u32) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().expect("a PNG");
    let info = reader.info();
    (info.width, info.height)
}

/// The text after `key ` up to `end` in `line`, e.g. `field(line, "roll", ",")`.
fn field<'a>(line: &'a str, key: &str, end: &str) -> &'a str {
    let rest = line.split(&format!("{key} ")).nth(1).unwrap_or_else(|| panic!("no '{key}' in {line}"));
    rest.split(end).next().unwrap_or(rest).trim()
}

#[test]
fn replay_px4_log_agrees_with_kestrel_replay_and_stays_near_ekf2() {
    let exe = example("replay_px4_log");
    let plot = scratch().join("replay.png");
    let (stdout, took) = run_to_end(&exe, &["--plot", plot.to_str().expect("utf-8 path")]);
    let ours = stdout.lines().find(|l| l.starts_with("RMS vs EKF2")).expect("an RMS line");

    // The same log through `kestrel replay`, whose EKF loop and comparison are the library's.
    let log = root().join("tests/data/px4/px4_sitl_takeoff_land.ulg");
    let csv = scratch().join("replay.csv");
    let cli = Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .args(["replay", "--log"])
        .arg(&log)
        .arg("--out")
        .arg(&csv)
        .output()
        .expect("run kestrel replay");
    let cli_out = String::from_utf8_lossy(&cli.stdout);
    assert!(cli.status.success(), "kestrel replay: {}", String::from_utf8_lossy(&cli.stderr));
    let theirs =
        cli_out.split("; ").find(|p| p.starts_with("RMS vs EKF2")).expect("kestrel replay's RMS vs EKF2");
    println!("example: {ours}\nkestrel replay: {theirs}");
    for (key, end) in [("roll", ","), ("pitch", ","), ("yaw", ","), ("height", " m")] {
        assert_eq!(field(ours, key, end), field(theirs, key, end), "{key}: {ours} / {theirs}");
    }
    let degrees = |key| field(ours, key, "°").parse::<f64>().expect("a number");
    // The bounds tests/replay_ulog.rs holds for this log.
    assert!(degrees("roll") < 2.0 && degrees("pitch") < 2.0, "{ours}");
    assert!(field(ours, "height", " m").parse::<f64>().expect("a number") < 0.5, "{ours}");
    assert_eq!(png_size(&plot), (1280, 1200));
    println!("replay_px4_log ran in {:.2} s", took.as_secs_f64());
}

#[test]
fn stereo_from_images_finds_teddys_ground_truth_disparity_and_writes_the_depth_picture() {
    let exe = example("stereo_from_images");
    let out = scratch().join("depth.png");
    let (stdout, took) = run_to_end(&exe, &["--out", out.to_str().expect("utf-8 path")]);
    let pixels: Vec<&str> = stdout.lines().filter(|l| l.starts_with("pixel (")).collect();
    assert_eq!(pixels.len(), 5, "{stdout}");
    let (mut compared, mut good) = (0, 0);
    for line in &pixels {
        if line.contains("no disparity") || !line.contains("ground truth") {
            continue;
        }
        let d: f64 = field(line, "disparity", " px").parse().expect("disparity");
        let z: f64 = field(line, "depth", " m").parse().expect("depth");
        let truth: f64 = field(line, "ground truth", " px").parse().expect("ground truth");
        // Z = f·B / d with the example's default geometry (450 px, 0.1 m), to the printed digits.
        assert!((z - 450.0 * 0.1 / d).abs() < 0.01, "{line}");
        compared += 1;
        // Middlebury's bad-2 criterion: within 2 px of the ground truth.
        if (d - truth).abs() <= 2.0 {
            good += 1;
        }
    }
    // Outside the left band the default matcher misses by more than 2 px on 8.9 % of teddy's
    // pixels (`kestrel disparity --gt`): one of these five may miss.
    assert!(compared >= 4 && good + 1 >= compared, "{good} of {compared} within 2 px:\n{stdout}");
    assert_eq!(png_size(&out), (450, 375));
    println!("stereo_from_images ran in {:.2} s", took.as_secs_f64());
}

#[test]
fn link_bench_serves_a_pymavlink_ground_station_and_ends_on_its_own() {
    let exe = example("link_bench");
    let python = root().join(".venv/bin/python");
    assert!(python.exists(), "no Python venv at {}: run scripts/python-env.sh", python.display());
    let mut client = Command::new(&python)
        .arg(root().join("tests/python/link_bench_client.py"))
        .env("PYTHONUNBUFFERED", "1")
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .stdout(Stdio::piped())
        .spawn()
        .expect("start the pymavlink client");
    let mut lines = BufReader::new(client.stdout.take().expect("stdout")).lines();
    let first = lines.next().and_then(Result::ok).unwrap_or_default();
    let Some(port) = first.strip_prefix("PORT ").map(str::trim) else {
        let _ = client.kill();
        panic!("the client did not announce its port: {first:?}");
    };
    let gcs = format!("127.0.0.1:{port}");
    let seconds = 4.0;
    let (stdout, took) =
        run_to_end(&exe, &["--gcs", &gcs, "--listen", "127.0.0.1:0", "--seconds", &seconds.to_string()]);
    let transcript: Vec<String> = lines.map_while(Result::ok).collect();
    let status = client.wait().expect("client exit");
    println!("pymavlink: {transcript:?}");
    assert!(status.success(), "the ground station failed: {transcript:?}");
    let results: serde_json::Value =
        serde_json::from_str(transcript.last().expect("a result line")).expect("JSON results");
    // bench-link.toml's two parameters, at its values.
    assert_eq!(results["params"]["RTL_ALT_M"], 15.0, "{results}");
    assert_eq!(results["params"]["FS_GCS_TIMEOUT_S"], 5.0, "{results}");
    assert_eq!(results["heartbeat"]["autopilot"], "MAV_AUTOPILOT_ARDUPILOTMEGA", "{results}");
    // Ended by --seconds, not by anyone stopping it.
    assert!(stdout.contains("stopped at"), "{stdout}");
    assert!(
        took >= Duration::from_secs_f64(seconds) && took < Duration::from_secs_f64(seconds + 10.0),
        "{took:?}"
    );
    println!("link_bench ran in {:.2} s", took.as_secs_f64());
}

#[test]
fn custom_actor_reports_the_flight_leaving_its_box_and_nothing_from_a_box_too_big_to_leave() {
    let exe = example("custom_actor");
    // The defaults: a box 10 m wide and 15 m high around the origin; the square's first leg
    // flies 20 m north at 10 m.
    let (stdout, took) = run_to_end(&exe, &["--seconds", "10"]);
    let exits: Vec<&str> = stdout.lines().filter(|l| l.contains("left the box")).collect();
    assert_eq!(exits.len(), 1, "{stdout}");
    assert!(exits[0].contains("through the north"), "{}", exits[0]);
    // Crossed just then: past the north face (5 m) by less than one estimate's travel, and
    // under the top.
    let north: f64 = field(exits[0], "N", " m").parse().expect("north");
    let height: f64 = field(exits[0], "height", " m").parse().expect("height");
    assert!((5.0..5.2).contains(&north) && height < 15.0, "{}", exits[0]);
    assert!(stdout.contains(", 1 on box_exit"), "the exit was published once: {stdout}");
    println!("custom_actor ran in {:.2} s", took.as_secs_f64());

    // The same flight in a box it never leaves: nothing published.
    let (stdout, _) = run_to_end(&exe, &["--seconds", "10", "--half-width-m", "100", "--ceiling-m", "50"]);
    assert!(!stdout.contains("left the box"), "{stdout}");
    assert!(stdout.contains(", 0 on box_exit"), "{stdout}");
}
