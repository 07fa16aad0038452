//! The flight-log recorder through its public API: messages written by `Recorder` come back
//! exactly from `LogReader` and from the reference Python `mcap` reader, output is
//! bit-identical across runs, and mistakes (wrong type, unwritable path, full disk) are clear
//! errors naming the file, never panics.

use std::path::{Path, PathBuf};
use std::process::Command;

use kestrel::recorder::{LogReader, Recorded, Recorder, RecorderError};
use kestrel_proto::messages::{
    ActuatorOutputs, BaroSample, GpsFix, GpsFixType, GroundTruth, ImuSample, SupervisorEvent,
    SupervisorEventKind,
};
use kestrel_proto::{Message, Time};

/// A fresh path for `name` under cargo's per-test scratch directory.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("recorder");
    std::fs::create_dir_all(&dir).expect("create scratch dir");
    let path = dir.join(name);
    let _ = std::fs::remove_file(&path);
    path
}

/// Deterministic pseudo-random finite f64s spread over the whole bit space (subnormals, huge
/// and tiny exponents, negative zero), the values a lossy float printer or parser gets wrong.
struct Floats(u64);

impl Floats {
    fn next(&mut self) -> f64 {
        loop {
            // PCG-style LCG step; the high bits become the float's bit pattern.
            self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let x = f64::from_bits(self.0 ^ (self.0 >> 29));
            if x.is_finite() {
                return x;
            }
        }
    }

    fn array<const N: usize>(&mut self) -> [f64; N] {
        std::array::from_fn(|_| self.next())
    }
}

/// One "flight": every message type, interleaved as the router would see them.
struct Flight {
    imu: Vec<(Time, ImuSample)>,
    gps: Vec<(Time, GpsFix)>,
    baro: Vec<(Time, BaroSample)>,
    truth: Vec<(Time, GroundTruth)>,
    actuators: Vec<(Time, ActuatorOutputs)>,
    events: Vec<(Time, SupervisorEvent)>,
}

fn flight() -> Flight {
    let mut f = Floats(0x5eed);
    let mut flight = Flight {
        imu: Vec::new(),
        gps: Vec::new(),
        baro: Vec::new(),
        truth: Vec::new(),
        actuators: Vec::new(),
        events: Vec::new(),
    };
    for i in 0..800u64 {
        let t = Time::from_micros(2_500 * i);
        // Received a little after measurement, as real sensors are.
        let arrival = t + std::time::Duration::from_micros(150);
        flight.imu.push((
            arrival,
            ImuSample {
                time: t,
                gyro_rad_s: f.array(),
                accel_m_s2: [0.1 * i as f64, -0.0, -kestrel_proto::units::GRAVITY_M_S2],
                dt_s: 0.0025,
                gyro_clipped: [false; 3],
                accel_clipped: [i == 400, false, false],
            },
        ));
        if i % 80 == 0 {
            flight.gps.push((
                t + std::time::Duration::from_millis(220),
                GpsFix {
                    time: t,
                    fix_type: GpsFixType::Fix3d,
                    satellites: 12,
                    lat_deg: 6.797_1 + f.next() * 1e-300,
                    lon_deg: 79.901_7,
                    alt_msl_m: 20.0 + 1e-9 * i as f64,
                    vel_ned_m_s: f.array(),
                    h_acc_m: 0.8,
                    v_acc_m: 1.2,
                    s_acc_m_s: 0.1,
                },
            ));
        }
        if i % 40 == 0 {
            flight.baro.push((
                arrival,
                BaroSample {
                    time: t,
                    pressure_pa: 101_325.0 - 0.1 * i as f64,
                    altitude_m: f.next(),
                    temperature_c: 29.5,
                },
            ));
        }
        if i % 4 == 0 {
            flight.truth.push((
                t,
                GroundTruth {
                    time: t,
                    position_ned_m: f.array(),
                    velocity_ned_m_s: f.array(),
                    acceleration_ned_m_s2: f.array(),
                    attitude: [1.0, 0.0, 0.0, 0.0],
                    angular_velocity_rad_s: f.array(),
                    lat_deg: 6.797_1,
                    lon_deg: 79.901_7,
                    alt_msl_m: 20.0,
                    landed: i == 0,
                    crashed: false,
                    collisions: 0,
                    clearance_m: (i % 2 == 1).then_some(3.25),
                },
            ));
            flight.actuators.push((t, ActuatorOutputs { time: t, armed: i > 0, motors: f.array() }));
        }
    }
    for (i, kind) in
        [SupervisorEventKind::Failed, SupervisorEventKind::Restarted, SupervisorEventKind::GaveUp]
            .into_iter()
            .enumerate()
    {
        let t = Time::from_micros(1_000_000 + 10_000 * i as u64);
        flight.events.push((
            t,
            SupervisorEvent {
                time: t,
                actor: "stereo".into(),
                kind,
                critical: false,
                reason: "panicked at \"index out of bounds\"\n\tüñí€𝄞".into(),
                restarts_in_window: i as u32,
            },
        ));
    }
    flight
}

/// Records `flight` into `path`, interleaving topics in log-time order like the router does.
fn record(path: &Path, flight: &Flight) -> kestrel::recorder::RecordingSummary {
    let recorder = Recorder::create(path).expect("create recorder");
    let imu = recorder.channel::<ImuSample>("imu").unwrap();
    let gps = recorder.channel::<GpsFix>("gps").unwrap();
    let baro = recorder.channel::<BaroSample>("baro").unwrap();
    let truth = recorder.channel::<GroundTruth>("ground_truth").unwrap();
    let actuators = recorder.channel::<ActuatorOutputs>("actuators").unwrap();
    let events = recorder.channel::<SupervisorEvent>("supervisor").unwrap();

    let mut all: Vec<(Time, Box<dyn Fn()>)> = Vec::new();
    for (t, m) in &flight.imu {
        let (c, t, m) = (imu.clone(), *t, m.clone());
        all.push((t, Box::new(move || c.record(t, &m))));
    }
    for (t, m) in &flight.gps {
        let (c, t, m) = (gps.clone(), *t, m.clone());
        all.push((t, Box::new(move || c.record(t, &m))));
    }
    for (t, m) in &flight.baro {
        let (c, t, m) = (baro.clone(), *t, m.clone());
        all.push((t, Box::new(move || c.record(t, &m))));
    }
    for (t, m) in &flight.truth {
        let (c, t, m) = (truth.clone(), *t, m.clone());
        all.push((t, Box::new(move || c.record(t, &m))));
    }
    for (t, m) in &flight.actuators {
        let (c, t, m) = (actuators.clone(), *t, m.clone());
        all.push((t, Box::new(move || c.record(t, &m))));
    }
    for (t, m) in &flight.events {
        let (c, t, m) = (events.clone(), *t, m.clone());
        all.push((t, Box::new(move || c.record(t, &m))));
    }
    // Stable sort: equal log times keep their per-topic order.
    all.sort_by_key(|(t, _)| *t);
    for (_, record) in &all {
        record();
    }
    recorder.finish().expect("finish recording")
}

/// What reading `topic` as `T` should give back.
fn expected<T: Message>(recorded: &[(Time, T)]) -> Vec<Recorded<T>> {
    recorded
        .iter()
        .enumerate()
        .map(|(i, (log_time, message))| Recorded {
            log_time: *log_time,
            publish_time: message.time(),
            sequence: i as u32,
            message: message.clone(),
        })
        .collect()
}

#[test]
fn messages_round_trip_exactly() {
    let path = scratch("round_trip.mcap");
    let flight = flight();
    let summary = record(&path, &flight);

    assert_eq!(summary.path, path);
    assert!(summary.dropped_per_topic.is_empty(), "{summary:?}");
    let counts: Vec<(&str, u64)> = summary.messages_per_topic.iter().map(|(t, n)| (t.as_str(), *n)).collect();
    assert_eq!(
        counts,
        [
            ("actuators", 200),
            ("baro", 20),
            ("gps", 10),
            ("ground_truth", 200),
            ("imu", 800),
            ("supervisor", 3),
        ]
    );
    assert_eq!(summary.file_size_bytes, std::fs::metadata(&path).unwrap().len());

    let log = LogReader::open(&path).expect("open log");
    let topics: Vec<(String, String, String, String, u64)> = log
        .topics()
        .into_iter()
        .map(|t| (t.topic, t.schema_name, t.schema_encoding, t.message_encoding, t.message_count))
        .collect();
    let topic = |name: &str, schema: &str, count| {
        (name.to_owned(), schema.to_owned(), "jsonschema".to_owned(), "json".to_owned(), count)
    };
    assert_eq!(
        topics,
        [
            topic("actuators", "kestrel.ActuatorOutputs", 200),
            topic("baro", "kestrel.BaroSample", 20),
            topic("gps", "kestrel.GpsFix", 10),
            topic("ground_truth", "kestrel.GroundTruth", 200),
            topic("imu", "kestrel.ImuSample", 800),
            topic("supervisor", "kestrel.SupervisorEvent", 3),
        ]
    );

    // Exact equality, f64s included: JSON must print and parse every float losslessly.
    assert_eq!(log.read::<ImuSample>("imu").unwrap(), expected(&flight.imu));
    assert_eq!(log.read::<GpsFix>("gps").unwrap(), expected(&flight.gps));
    assert_eq!(log.read::<BaroSample>("baro").unwrap(), expected(&flight.baro));
    assert_eq!(log.read::<GroundTruth>("ground_truth").unwrap(), expected(&flight.truth));
    assert_eq!(log.read::<ActuatorOutputs>("actuators").unwrap(), expected(&flight.actuators));
    assert_eq!(log.read::<SupervisorEvent>("supervisor").unwrap(), expected(&flight.events));
}

#[test]
fn raw_reads_every_message_in_file_order() {
    let path = scratch("raw.mcap");
    let flight = flight();
    record(&path, &flight);
    let log = LogReader::open(&path).unwrap();

    let raw: Vec<_> = log.raw().collect::<Result<_, _>>().expect("raw read");
    assert_eq!(raw.len(), 800 + 10 + 20 + 200 + 200 + 3);
    assert!(raw.windows(2).all(|w| w[0].log_time <= w[1].log_time));
    let first_gps = raw.iter().find(|r| &*r.topic == "gps").unwrap();
    assert_eq!(&*first_gps.schema_name, "kestrel.GpsFix");
    assert_eq!(first_gps.log_time, flight.gps[0].0);
    assert_eq!(first_gps.publish_time, flight.gps[0].1.time);
    assert_eq!(first_gps.sequence, 0);
    let decoded: GpsFix = serde_json::from_slice(&first_gps.data).unwrap();
    assert_eq!(decoded, flight.gps[0].1);
}

#[test]
fn same_calls_give_bit_identical_files() {
    let flight = flight();
    let a = scratch("determinism_a.mcap");
    let b = scratch("determinism_b.mcap");
    record(&a, &flight);
    record(&b, &flight);
    let (a, b) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
    assert!(a.len() > 1_000, "log unexpectedly small: {} bytes", a.len());
    assert!(a == b, "two identical recordings differ");
}

#[test]
fn registering_a_topic_twice_shares_its_channel() {
    let path = scratch("register_twice.mcap");
    let recorder = Recorder::create(&path).unwrap();
    let first = recorder.channel::<BaroSample>("baro").unwrap();
    let second = recorder.channel::<BaroSample>("baro").unwrap();
    let sample = |us| BaroSample {
        time: Time::from_micros(us),
        pressure_pa: 101_000.0,
        altitude_m: 30.0,
        temperature_c: 25.0,
    };
    first.record(Time::from_micros(1), &sample(1));
    second.record(Time::from_micros(2), &sample(2));
    first.record(Time::from_micros(3), &sample(3));

    let err = recorder.channel::<ImuSample>("baro").err().expect("a second type on a topic must be refused");
    assert!(matches!(err, RecorderError::TopicTypeConflict { .. }));
    let text = err.to_string();
    for part in ["baro", "kestrel.BaroSample", "kestrel.ImuSample", "register_twice.mcap"] {
        assert!(text.contains(part), "{text:?} lacks {part:?}");
    }

    let summary = recorder.finish().unwrap();
    assert_eq!(summary.messages_per_topic["baro"], 3);
    let log = LogReader::open(&path).unwrap();
    assert_eq!(log.topics().len(), 1);
    let read = log.read::<BaroSample>("baro").unwrap();
    let sequences: Vec<u32> = read.iter().map(|r| r.sequence).collect();
    assert_eq!(sequences, [0, 1, 2]);
    assert_eq!(read[1].message, sample(2));
}

#[test]
fn publishers_on_many_threads_share_one_recorder() {
    let path = scratch("threads.mcap");
    let recorder = Recorder::create(&path).unwrap();
    let flight = flight();
    std::thread::scope(|scope| {
        for topic in ["imu0", "imu1", "imu2", "imu3"] {
            let channel = recorder.channel::<ImuSample>(topic).unwrap();
            let samples = &flight.imu;
            scope.spawn(move || {
                for (t, m) in samples {
                    channel.record(*t, m);
                }
            });
        }
    });
    let summary = recorder.finish().unwrap();
    assert!(summary.dropped_per_topic.is_empty(), "{summary:?}");
    assert!(summary.messages_per_topic.values().all(|n| *n == 800), "{summary:?}");
    let log = LogReader::open(&path).unwrap();
    assert_eq!(log.read::<ImuSample>("imu2").unwrap(), expected(&flight.imu));
}

#[test]
fn reading_a_topic_as_the_wrong_type_names_both_types() {
    let path = scratch("wrong_type.mcap");
    record(&path, &flight());
    let log = LogReader::open(&path).unwrap();

    let err = log.read::<GpsFix>("imu").expect_err("imu is not GpsFix");
    assert!(matches!(err, RecorderError::TypeMismatch { .. }), "{err:?}");
    let text = err.to_string();
    for part in ["imu", "kestrel.GpsFix", "kestrel.ImuSample", "wrong_type.mcap"] {
        assert!(text.contains(part), "{text:?} lacks {part:?}");
    }

    let err = log.read::<ImuSample>("imu_typo").expect_err("no such topic");
    assert!(matches!(err, RecorderError::UnknownTopic { .. }), "{err:?}");
    assert!(err.to_string().contains("imu_typo"), "{err}");
}

#[test]
fn unwritable_path_is_an_error_naming_it() {
    let path = scratch("no_such_dir").join("flight.mcap");
    let err = Recorder::create(&path).err().expect("a missing directory must be refused");
    assert!(matches!(err, RecorderError::Create { .. }), "{err:?}");
    assert!(err.to_string().contains(&path.display().to_string()), "{err}");
}

#[test]
fn a_full_disk_is_reported_by_finish_and_recording_never_panics() {
    // /dev/full accepts the open and fails every write with ENOSPC.
    let path = Path::new("/dev/full");
    let recorder = Recorder::create(path).expect("/dev/full opens");
    let imu = recorder.channel::<ImuSample>("imu").unwrap();
    let flight = flight();
    // The first chunk's write fails; every later message must still be taken and counted.
    for _ in 0..20 {
        for (t, m) in &flight.imu {
            imu.record(*t, m);
        }
    }
    // The failure is known the moment it happens, not only at `finish`.
    let probe = recorder.failure_probe();
    let start = std::time::Instant::now();
    while probe.failure().is_none() && start.elapsed() < std::time::Duration::from_secs(5) {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let failure = probe.failure().expect("the probe sees the failed write");
    assert!(failure.contains("/dev/full") && failure.contains("No space left on device"), "{failure}");
    let err = recorder.finish().expect_err("writing to a full disk must fail");
    assert!(matches!(err, RecorderError::Write { lost: 1.., .. }), "{err:?}");
    let text = err.to_string();
    for part in ["/dev/full", "No space left on device", "not recorded"] {
        assert!(text.contains(part), "{text:?} lacks {part:?}");
    }

    // After the recorder is gone, recording is counted as dropped, not a panic.
    let before = imu.dropped();
    imu.record(Time::ZERO, &flight.imu[0].1);
    assert_eq!(imu.dropped(), before + 1);
}

#[test]
fn a_log_cut_in_half_is_read_up_to_the_cut() {
    let path = scratch("cut-in-half.mcap");
    record(&path, &flight());
    let whole = LogReader::open(&path).unwrap();
    let total: u64 = whole.topics().iter().map(|t| t.message_count).sum();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.truncate(bytes.len() / 2);
    std::fs::write(&path, &bytes).unwrap();
    let log = LogReader::open(&path).expect("a truncated log is read as far as it goes");
    let damage = log.damage().expect("and says it is damaged");
    assert!(damage.messages_read < total, "{damage:?}");
    assert_eq!(log.raw().count() as u64, damage.messages_read, "reads stop where the damage begins");
    assert_eq!(damage.file_bytes, bytes.len() as u64);
    assert!(damage.intact_bytes < damage.file_bytes, "{damage:?}");
    assert!(damage.to_string().contains(&format!("of {}", bytes.len())), "{damage}");
}

#[test]
fn an_empty_or_foreign_file_is_not_an_mcap() {
    for (name, bytes) in [("empty.mcap", &b""[..]), ("ulog.mcap", &b"ULog\x01\x12\x35\x01"[..])] {
        let path = scratch(name);
        std::fs::write(&path, bytes).unwrap();
        let err = LogReader::open(&path).err().expect("refused");
        assert!(matches!(err, RecorderError::NotMcap { .. }), "{err:?}");
        assert!(err.to_string().contains(name) && err.to_string().contains("not an MCAP file"), "{err}");
    }
}

/// Reads `path` with `tests/python/read_mcap.py` in the repo's venv.
fn python_summary(path: &Path) -> serde_json::Value {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = repo.join(".venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run scripts/python-env.sh to create the Python test environment",
        python.display()
    );
    let output = Command::new(&python)
        .arg(repo.join("tests/python/read_mcap.py"))
        .arg(path)
        .output()
        .expect("run read_mcap.py");
    assert!(
        output.status.success(),
        "read_mcap.py failed ({}): {}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("read_mcap.py prints JSON")
}

#[test]
fn python_mcap_reader_agrees_with_ours() {
    let path = scratch("python.mcap");
    let flight = flight();
    record(&path, &flight);
    let python = python_summary(&path);
    let log = LogReader::open(&path).unwrap();

    let topics = python["topics"].as_object().expect("topics object");
    assert_eq!(topics.len(), log.topics().len(), "{python}");
    for ours in log.topics() {
        let theirs = &topics[&ours.topic];
        assert_eq!(theirs["schema_name"], ours.schema_name.as_str());
        assert_eq!(theirs["schema_encoding"], "jsonschema");
        assert_eq!(theirs["message_encoding"], "json");
        assert_eq!(theirs["count"], ours.message_count, "{}", ours.topic);
        // The summary's statistics are what Foxglove shows without scanning the file.
        assert_eq!(theirs["summary_count"], ours.message_count, "{}", ours.topic);
    }

    fn check<T: Message>(python: &serde_json::Value, log: &LogReader, topic: &str) {
        let ours = log.read::<T>(topic).unwrap();
        let theirs = &python["topics"][topic];
        let (first, last) = (&ours[0], &ours[ours.len() - 1]);
        assert_eq!(theirs["first"], serde_json::to_value(&first.message).unwrap());
        assert_eq!(theirs["last"], serde_json::to_value(&last.message).unwrap());
        // Python decodes to its own values; they must decode back to exactly ours.
        let first_back: T = serde_json::from_value(theirs["first"].clone()).unwrap();
        let last_back: T = serde_json::from_value(theirs["last"].clone()).unwrap();
        assert_eq!(format!("{first_back:?}"), format!("{:?}", first.message));
        assert_eq!(format!("{last_back:?}"), format!("{:?}", last.message));
        assert_eq!(theirs["first_log_time_ns"], first.log_time.as_micros() * 1_000);
        assert_eq!(theirs["last_log_time_ns"], last.log_time.as_micros() * 1_000);
    }
    check::<ImuSample>(&python, &log, "imu");
    check::<GpsFix>(&python, &log, "gps");
    check::<BaroSample>(&python, &log, "baro");
    check::<GroundTruth>(&python, &log, "ground_truth");
    check::<ActuatorOutputs>(&python, &log, "actuators");
    check::<SupervisorEvent>(&python, &log, "supervisor");
}

/// `kestrel run --record /dev/full`: the first chunk's write fails within the first second of
/// the run, and the error is on stderr (and on `sensor_health`, which the link sends as a
/// STATUSTEXT) while the vehicle still runs, not at the end: the line must come within a second
/// of the start, so within a second of the failure.
#[test]
fn kestrel_run_recording_to_a_full_disk_reports_the_write_error_within_a_second() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    use std::time::{Duration, Instant};
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config_dir = repo.join("config");
    let text = kestrel::LoadedConfig::load(&config_dir.join("sim.toml")).unwrap().merged_toml().unwrap();
    // No fixed ports (tests run in parallel): one link endpoint on an ephemeral local port.
    let link = "[actors.link]\ntype = \"link\"\n";
    assert!(text.contains(link), "sim.toml has a link");
    let text = text
        .replace(
            link,
            &format!("{link}params.endpoints = [{{ type = \"udp_in\", bind = \"127.0.0.1:0\" }}]\n"),
        )
        .replace("\"vehicles/", &format!("\"{}/vehicles/", config_dir.display()))
        .replace("\"worlds/", &format!("\"{}/worlds/", config_dir.display()));
    let graph = scratch("full-disk-graph.toml");
    std::fs::write(&graph, text).unwrap();
    let started = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .current_dir(repo)
        .env_remove("RUST_LOG")
        .args(["run", "--speedup", "1", "--duration", "4", "--record", "/dev/full", "--config"])
        .arg(&graph)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = BufReader::new(child.stderr.take().unwrap());
    let mut reported = None;
    let mut lines = Vec::new();
    for line in stderr.lines().map_while(Result::ok) {
        if reported.is_none() && line.contains("flight log write failed") {
            reported = Some(started.elapsed());
        }
        lines.push(line);
    }
    let status = child.wait().unwrap();
    let after = reported.unwrap_or_else(|| panic!("no write error reported: {status}\n{}", lines.join("\n")));
    let line = lines.iter().find(|l| l.contains("flight log write failed")).unwrap();
    println!(
        "figure: --record /dev/full: the write error reported {:.2} s after the start: {line}",
        after.as_secs_f64()
    );
    assert!(line.contains("/dev/full") && line.contains("No space left on device"), "{line}");
    assert!(after < Duration::from_secs(1), "reported {after:?} after the start");
}
