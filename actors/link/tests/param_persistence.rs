//! Parameter persistence through the receive path (`Shared::handle_frames`, what every endpoint
//! task calls): a burst of PARAM_SETs ends with the last value on disk, each set answered once a
//! file holding it is written; a disk that stalls never delays the answers to what arrives
//! meanwhile; a write that fails answers with the old value and why.

use std::sync::mpsc as std_mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use kestrel_link::config::{ParamKind, ParamSpec};
use kestrel_link::frame::{Frame, FrameParser};
use kestrel_link::hub::{Hub, Tx};
use kestrel_link::router::LinkId;
use kestrel_link::services::params::ParamTable;
use kestrel_link::transport::{ParamWriter, Shared, file_writer, param_writer_for};
use kestrel_link::vehicle::Vehicle;
use kestrel_proto::Clock;
use kestrel_proto::testing::ManualClock;
use mavlink::dialects::ardupilotmega::*;
use mavlink::{MavHeader, MavlinkVersion};
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;

/// `TEST_P0..TEST_P3`, valued 0..3, bounded 0..1000.
fn param_specs() -> Vec<ParamSpec> {
    (0..4)
        .map(|i| ParamSpec {
            name: format!("TEST_P{i}"),
            value: f64::from(i),
            min: 0.0,
            max: 1000.0,
            kind: ParamKind::Real32,
            unit: String::new(),
        })
        .collect()
}

/// A hub with four parameters behind one stream link whose output lands in the receiver, its
/// parameter file written by `write` on the writer thread.
fn shared<F>(write: F) -> (Shared, LinkId, mpsc::Receiver<Vec<u8>>)
where
    F: FnMut(&str) -> std::io::Result<()> + Send + 'static,
{
    let clock: Arc<dyn Clock> = Arc::new(ManualClock::default());
    let table = ParamTable::new(param_specs()).expect("valid parameters");
    let hub = Arc::new(Mutex::new(Hub::new(Vehicle::new(1, table, Duration::from_secs(5)))));
    let (tx, rx) = mpsc::channel(10_000);
    let id = hub.lock().expect("hub").add_link("test".into(), Tx::Stream(tx), None);
    let graph: Arc<dyn Fn(Vec<_>) + Send + Sync> = Arc::new(|_| {});
    let writer: ParamWriter =
        param_writer_for(&hub, graph.clone(), Arc::clone(&clock), write).expect("writer thread");
    let shared = Shared {
        hub,
        clock,
        shutdown: CancellationToken::new(),
        graph,
        param_writer: Some(Arc::new(writer)),
        endpoint: 0,
    };
    (shared, id, rx)
}

/// `msg` from a ground station (255/190), framed with the `mavlink` crate and parsed back.
fn frame(msg: &MavMessage) -> Frame {
    let mut bytes = Vec::new();
    let header = MavHeader { system_id: 255, component_id: 190, sequence: 0 };
    mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, msg).expect("serialise");
    let mut frames = Vec::new();
    FrameParser::new().push(&bytes, &mut frames);
    frames.pop().expect("one valid frame")
}

fn set(name: &str, value: f32) -> Frame {
    let mut s =
        PARAM_SET_DATA { param_value: value, target_system: 1, target_component: 1, ..Default::default() };
    s.param_id = name.into();
    s.param_type = MavParamType::MAV_PARAM_TYPE_REAL32;
    frame(&MavMessage::PARAM_SET(s))
}

fn read(name: &str) -> Frame {
    let mut r = PARAM_REQUEST_READ_DATA {
        param_index: -1,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    };
    r.param_id = name.into();
    frame(&MavMessage::PARAM_REQUEST_READ(r))
}

/// Every PARAM_VALUE the link sent, as `(name, value)`, and every STATUSTEXT.
fn answers(rx: &mut mpsc::Receiver<Vec<u8>>) -> (Vec<(String, f32)>, Vec<String>) {
    let mut frames = Vec::new();
    let mut parser = FrameParser::new();
    while let Ok(bytes) = rx.try_recv() {
        parser.push(&bytes, &mut frames);
    }
    let mut values = Vec::new();
    let mut texts = Vec::new();
    for f in &frames {
        match f.decode() {
            Ok(MavMessage::PARAM_VALUE(p)) => values.push((
                p.param_id.to_str().unwrap_or_default().trim_end_matches('\0').to_owned(),
                p.param_value,
            )),
            Ok(MavMessage::STATUSTEXT(t)) => {
                texts.push(t.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned())
            }
            _ => {}
        }
    }
    (values, texts)
}

fn values(rx: &mut mpsc::Receiver<Vec<u8>>) -> Vec<(String, f32)> {
    answers(rx).0
}

#[test]
fn a_burst_of_sets_is_persisted_with_the_last_value_winning() {
    let dir = std::env::temp_dir().join(format!("kestrel-param-burst-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("params.txt");
    let (shared, id, mut rx) = shared(file_writer(path.clone()));
    for i in 1..=300 {
        shared.handle_frames(id, &[set("TEST_P2", i as f32)]);
    }
    let writer = shared.param_writer.clone().expect("writer");
    writer.finish();
    let echoed = values(&mut rx);
    assert_eq!(echoed.len(), 300, "every set is answered once written");
    let wanted: Vec<(String, f32)> = (1..=300).map(|i| ("TEST_P2".to_owned(), i as f32)).collect();
    assert_eq!(echoed, wanted, "each set is answered with its own value, in order");
    let stats = writer.stats();
    let text = std::fs::read_to_string(&path).expect("the parameter file exists");
    println!("figure: 300 PARAM_SETs -> {} file writes ({} coalesced)", stats.written, stats.coalesced);
    assert!(text.lines().any(|l| l == "TEST_P2=300"), "{text}");
    assert_eq!(stats.submitted, 300);
    assert_eq!(stats.written + stats.coalesced, 300, "{stats:?}");
    assert_eq!(stats.failed, 0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_stalled_disk_does_not_delay_the_receive_path() {
    let (release, stalled) = std_mpsc::channel::<()>();
    let (wrote, written) = std_mpsc::channel::<String>();
    let (shared, id, mut rx) = shared(move |text: &str| {
        wrote.send(text.to_owned()).ok();
        // The disk takes until the test says so (an SD card mid-erase).
        stalled.recv().ok();
        Ok(())
    });
    shared.handle_frames(id, &[set("TEST_P0", 7.0)]);
    written.recv_timeout(Duration::from_secs(5)).expect("the first write started and is now stuck");

    let started = Instant::now();
    for i in 0..100 {
        shared.handle_frames(id, &[set("TEST_P0", 100.0 + i as f32)]);
    }
    shared.handle_frames(id, &[read("TEST_P3")]);
    let elapsed = started.elapsed();
    let stuck = values(&mut rx);
    assert_eq!(stuck, [("TEST_P3".to_owned(), 3.0)], "the read answered, no set before it is on disk");
    assert!(elapsed < Duration::from_millis(500), "the receive path waited for the disk: {elapsed:?}");
    println!("figure: 100 sets + 1 read handled in {elapsed:?} with the disk stalled");

    release.send(()).expect("release the first write");
    release.send(()).expect("release the second write");
    let writer = shared.param_writer.clone().expect("writer");
    writer.finish();
    let later: Vec<String> = written.try_iter().collect();
    assert_eq!(later.len(), 1, "the burst collapsed into one write: {later:?}");
    assert!(later[0].lines().any(|l| l == "TEST_P0=199"), "{later:?}");
    let echoed = values(&mut rx);
    assert_eq!(echoed.len(), 101, "every set answered once the disk let go: {echoed:?}");
    assert_eq!(echoed.last(), Some(&("TEST_P0".to_owned(), 199.0)));
}

#[test]
fn a_write_that_fails_answers_with_the_old_value_and_why() {
    let (wrote, written) = std_mpsc::channel::<String>();
    let (shared, id, mut rx) = shared(move |text: &str| {
        wrote.send(text.to_owned()).ok();
        Err(std::io::Error::from(std::io::ErrorKind::ReadOnlyFilesystem))
    });
    shared.handle_frames(id, &[set("TEST_P1", 50.0)]);
    let writer = shared.param_writer.clone().expect("writer");
    writer.finish();
    let (echoed, texts) = answers(&mut rx);
    assert_eq!(echoed, [("TEST_P1".to_owned(), 1.0)], "the value the file still holds");
    assert_eq!(texts, ["Param TEST_P1 not saved: read-only"]);
    // The set text, then the table as it is again (the value put back), each tried once.
    let tried: Vec<String> = written.try_iter().collect();
    assert_eq!(tried, ["TEST_P1=50\n", ""], "{tried:?}");
    shared.handle_frames(id, &[read("TEST_P1")]);
    assert_eq!(values(&mut rx), [("TEST_P1".to_owned(), 1.0)], "and a read says the same");
}
