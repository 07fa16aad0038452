//! An independent client: pymavlink (from the venv made by `scripts/python-env.sh`) acting as a
//! ground station against the link actor running in a real Kestrel graph on the realtime clock,
//! with a stand-in commander that obeys every command and a stand-in estimator position.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command as Process, Stdio};
use std::time::Duration;

use kestrel::{LoadedConfig, Registry, RunOptions, run};
use kestrel_link::LinkActor;
use kestrel_proto::geo::Geodetic;
use kestrel_proto::messages::{
    Command, CommandResult, FlightMode, Home, LandedState, NavState, NavValidity, VehicleCommand,
    VehicleStatus,
};
use kestrel_proto::testing::vehicle_status;
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};

/// The stand-in commander takes no parameters.
#[derive(serde::Deserialize)]
struct NoParams {}

/// Obeys every command at once and reports it, like a commander whose checks all pass.
struct StandInCommander {
    status: VehicleStatus,
    status_out: Publisher<VehicleStatus>,
    result_out: Publisher<CommandResult>,
    nav_out: Publisher<NavState>,
}

enum StandInInput {
    Command(VehicleCommand),
    Tick(Time),
}

impl Actor for StandInCommander {
    type Params = NoParams;
    type Input = StandInInput;

    fn build(_: &NoParams, setup: &mut impl Setup<StandInInput>) -> Result<Self, ActorError> {
        setup.input("vehicle_command", StandInInput::Command);
        setup.timer("tick", Duration::from_millis(100), StandInInput::Tick);
        Ok(StandInCommander {
            status: vehicle_status(Time::ZERO, false, FlightMode::Stabilize, LandedState::OnGround),
            status_out: setup.output("vehicle_status"),
            result_out: setup.output("command_result"),
            nav_out: setup.output("nav_state"),
        })
    }

    async fn handle(&mut self, ctx: &Context, input: StandInInput) -> Result<(), ActorError> {
        let now = ctx.now();
        match input {
            StandInInput::Command(c) => {
                match c.command {
                    Command::Arm => self.status.armed = true,
                    Command::Disarm { .. } => self.status.armed = false,
                    Command::SetMode(m) => self.status.mode = m,
                    Command::MissionStart => self.status.mode = FlightMode::Auto,
                    Command::Land => self.status.mode = FlightMode::Land,
                    Command::ReturnToLaunch => self.status.mode = FlightMode::ReturnToLaunch,
                    Command::SetGeofence { enabled } => self.status.geofence_enabled = enabled,
                    Command::SetMissionCurrent { index } => self.status.mission.current = index,
                    Command::SetHome { point } => {
                        // Only what the link reads back: a new revision at the point, on the origin's
                        // meridian as the client sends it.
                        let revision = self.status.home.map_or(1, |h| h.revision + 1);
                        let [north_m, down_m] = point
                            .map_or([0.0; 2], |p| [(p.lat_deg - 6.79710) * 110_574.0, -(p.alt_m - 20.0)]);
                        self.status.home = Some(Home { position_ned_m: [north_m, 0.0, down_m], revision });
                    }
                    _ => {}
                }
                if c.id != 0 {
                    self.result_out.publish(CommandResult {
                        time: now,
                        id: c.id,
                        command: c.command,
                        refusal: None,
                    });
                }
                self.status.time = now;
                self.status_out.publish(self.status.clone());
            }
            StandInInput::Tick(t) => {
                self.status.time = t;
                self.status_out.publish(self.status.clone());
                self.nav_out.publish(NavState {
                    time: t,
                    attitude: [1.0, 0.0, 0.0, 0.0],
                    angular_velocity_rad_s: [0.0; 3],
                    velocity_ned_m_s: [0.0; 3],
                    position_ned_m: [0.0; 3],
                    gyro_bias_rad_s: [0.0; 3],
                    accel_bias_m_s2: [0.0; 3],
                    covariance_diagonal: [0.0; 16],
                    origin: Some(Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 }),
                    valid: NavValidity { attitude: true, ..Default::default() },
                });
            }
        }
        Ok(())
    }
}

fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

const GRAPH: &str = r#"
[run]
clock = "realtime"
status_period_s = 0.0

[actors.link]
type = "link"
params = { system_id = 1, gcs_timeout_s = 2.0, param_file = "params.txt", endpoints = [ { type = "udp_out", address = "127.0.0.1:PORT" } ], params = [ { name = "RTL_ALT_M", value = 30.0, min = 5.0, max = 120.0, unit = "m" }, { name = "FS_GCS_ENABLE", value = 1, min = 0, max = 1, kind = "int32" }, { name = "WPNAV_SPEED_MS", value = 5.0, min = 0.5, max = 15.0, unit = "m/s" } ] }
inputs.vehicle_status = { topic = "vehicle_status", mailbox = "queue(16)" }
# The commander's answer to each command, which becomes its COMMAND_ACK.
inputs.command_result = { topic = "command_result", mailbox = "queue(16)" }
inputs.nav_state = { topic = "nav_state", mailbox = "latest" }

[actors.commander]
type = "stand_in_commander"
inputs.vehicle_command = { topic = "vehicle_command", mailbox = "queue(64)" }
"#;

#[test]
fn pymavlink_ground_station_flies_the_link() {
    let python = repo_root().join(".venv/bin/python");
    assert!(
        python.exists(),
        "no Python venv at {}: run scripts/python-env.sh (it installs pymavlink from scripts/requirements-test.txt)",
        python.display()
    );
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/link_client.py");
    let mut client = Process::new(&python)
        .arg(&script)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the pymavlink client");
    let mut lines = BufReader::new(client.stdout.take().expect("stdout")).lines();
    let first = lines.next().and_then(Result::ok).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).unwrap_or_else(|| {
        let _ = client.kill();
        panic!("the client did not announce its port: {first:?}")
    });

    let dir = std::env::temp_dir().join(format!("kestrel-link-pymavlink-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let text = GRAPH.replace("PORT", &port.to_string());
    let config = LoadedConfig::parse(&dir.join("graph.toml"), &text).expect("graph config");
    let registry = Registry::new().with::<LinkActor>("link").with::<StandInCommander>("stand_in_commander");
    let graph = std::thread::spawn(move || {
        let options = RunOptions { duration: Some(Duration::from_secs(14)), ..Default::default() };
        run(&config, &registry, options)
    });

    let transcript: Vec<String> = lines.map_while(Result::ok).collect();
    let status = client.wait().expect("client exit");
    let mut stderr = String::new();
    if let Some(mut e) = client.stderr.take() {
        use std::io::Read;
        let _ = e.read_to_string(&mut stderr);
    }
    let report = graph.join().expect("graph thread").expect("graph ran");
    println!("pymavlink transcript:\n{}", transcript.join("\n"));
    assert!(status.success(), "pymavlink client failed: {transcript:?}\n{stderr}");
    let last = transcript.last().cloned().unwrap_or_default();
    assert!(last.contains("\"ok\": true"), "{last}");
    let commands = report.topics.iter().find(|t| t.0 == "vehicle_command").map_or(0, |t| t.2);
    assert!(commands >= 3, "heartbeats and commands reached the graph: {:?}", report.topics);
    let saved = std::fs::read_to_string(dir.join("params.txt")).expect("parameters persisted");
    assert!(saved.contains("RTL_ALT_M=50"), "{saved}");
    std::fs::remove_dir_all(&dir).ok();
}
