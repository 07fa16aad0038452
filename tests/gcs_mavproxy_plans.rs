//! MAVProxy's log and plan commands as an operator types them: tests/python/mavproxy_plans.py
//! drives `mavproxy.py` from the venv through an arm and disarm, `log list` and `log download
//! latest`, then `fence load`/`fence list`, `rally load`/`rally list` and `wp load`/`wp list`
//! of config/missions/survey.plan converted to the waypoint file MAVProxy loads; run against
//! `kestrel run` and ArduCopter SITL (when `KESTREL_ARDUCOPTER` names it, see
//! tests/support/arducopter.rs), and the test compares what MAVProxy printed and saved for each.
//!
//! What ArduCopter 4.7 does (SITL on `copter.parm`, MAVProxy's transcript): `log list` lists one
//! log and `log download latest` writes a DataFlash `.bin` that pymavlink's DFReader reads (its
//! parameters and the arming in it); each upload ends in "Got MISSION_ACK: TYPE_…: ACCEPTED";
//! the fence (10 items: an inclusion square, an exclusion circle and triangle, an inclusion
//! circle, a return point) and the rally points list back as loaded; the survey lists back with
//! the same commands and places, but ArduCopter keeps no NaN yaw (a waypoint's param4 lists as
//! 0), gives the camera and LAND items the frame it stores for items without a place (GLOBAL, 0)
//! and puts its own home in item 0 ([`ARDUCOPTER_SURVEY`]).
//!
//! Kestrel must list one log that MAVProxy downloads byte for byte as the file in its log
//! directory and that the `mcap` reader opens (armed at its start, disarmed at its end), and list
//! every plan back as loaded.
//!
//! ArduCopter runs at 5× here, not the harness's 10×: MAVProxy answers each MISSION_REQUEST
//! from its console loop, and at 10× on a loaded host ArduCopter's 8 s (its time) upload
//! timeout ran out before MAVProxy had sent 10 fence items.

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::{Value, json};
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "mavproxy_plans.py";
/// ArduCopter's speed-up with MAVProxy as its ground station (see the module docs).
const ARDUCOPTER_SPEEDUP: u32 = 5;
/// Items in each plan file the script loads.
const ITEMS: [(&str, u64); 3] = [("fence", 10), ("rally", 2), ("wp", 13)];
/// How ArduCopter's listed survey differs from the file loaded, as the script words it: home
/// (item 0) is its own; a NaN yaw is kept as 0 (waypoints 1, 2, 4 to 10); the two camera
/// triggers (3, 11) and the LAND (12) come back in frame 0 instead of 2.
const ARDUCOPTER_SURVEY: [&str; 3] = ["item 0: ", ": param4 0.0, loaded nan", ": frame, command (0, "];

fn results(v: &Value) -> &Value {
    let r = &v["results"];
    assert!(r.is_object(), "no results in {v:#}");
    r
}

/// What either stack must report: every upload ACCEPTED, as many items listed as loaded, the
/// fence and rally points listed back as loaded, one log downloaded whole.
fn assert_plans_and_log(stack: &str, r: &Value) {
    assert!(r["params"].as_u64().is_some_and(|n| n > 50), "{stack}: MAVProxy received {}", r["params"]);
    for (kind, n) in ITEMS {
        let plan = &r["plans"][kind];
        assert_eq!(
            (&plan["ack"], &plan["loaded"], &plan["listed"]),
            (&json!("ACCEPTED"), &json!(n), &json!(n)),
            "{stack}: {kind} {plan}"
        );
    }
    for kind in ["fence", "rally"] {
        assert_eq!(r["plans"][kind]["differences"], json!([]), "{stack}: {kind} listed as loaded");
    }
    let log = &r["log"];
    let entries = log["entries"].as_array().expect("entries");
    let newest = entries.last().unwrap_or_else(|| panic!("{stack}: no log listed: {log}"));
    assert_eq!(newest["id"], newest["last"], "{stack}: {log}");
    let (listed, got) = (newest["size"].as_u64().expect("size"), log["bytes"].as_u64().expect("bytes"));
    assert!(got >= listed, "{stack}: downloaded {got} of {listed} bytes");
}

#[test]
fn mavproxy_loads_and_lists_fence_rally_and_survey_and_downloads_the_log_as_from_arducopter() {
    let started = Instant::now();
    let dir = temp_dir("mavproxy-plans");
    let log_dir = dir.join("logs");
    let env = [("LOG_DIR", log_dir.display().to_string())];
    let kestrel = scripted_session(&dir, "mavproxy-plans", SCRIPT, &env, |port| {
        let graph = sim_config(&session_link(port, &dir));
        assert!(graph.contains("dir = \"sim/logs\""), "config/sim.toml's [record] dir");
        graph.replace("dir = \"sim/logs\"", &format!("dir = \"{}\"", log_dir.display()))
    });
    let ours = results(&kestrel);
    println!("kestrel half: {:.1} s", started.elapsed().as_secs_f64());
    assert_plans_and_log("kestrel", ours);
    assert_eq!(ours["plans"]["wp"]["differences"], json!([]), "kestrel: the survey listed as loaded");
    let log = &ours["log"];
    assert_eq!(log["entries"].as_array().map(Vec::len), Some(1), "one arming, one log: {log}");
    assert_eq!(
        (&log["format"], &log["equal"], &log["first_armed"], &log["last_armed"]),
        (&json!("mcap"), &json!(true), &json!(true), &json!(false)),
        "the download is the log on disk, the armed spell: {log}"
    );
    assert_eq!(log["bytes"], log["entries"][0]["size"], "{log}");
    assert!(log["topics"].as_u64().is_some_and(|n| n > 10), "{log}");

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session_at(&binary, SCRIPT, &[], ARDUCOPTER_SPEEDUP);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    let theirs = results(&ardu);
    assert_plans_and_log("arducopter", theirs);
    for kind in ["fence", "rally"] {
        assert_eq!(ours["plans"][kind], theirs["plans"][kind], "{kind}: kestrel against ArduCopter");
    }
    let survey = theirs["plans"]["wp"]["differences"].as_array().expect("differences");
    for difference in survey.iter().filter_map(Value::as_str) {
        assert!(
            ARDUCOPTER_SURVEY.iter().any(|known| difference.contains(known)),
            "ArduCopter's survey differs from the file other than as known: {difference}"
        );
    }
    println!("ArduCopter's survey as listed, against the file: {survey:?}");
    let their_log = &theirs["log"];
    assert_eq!(their_log["format"], "dataflash", "{their_log}");
    assert!(their_log["params"].as_u64().is_some_and(|n| n > 1000), "{their_log}");
    assert!(their_log["arm_events"].as_u64().is_some_and(|n| n >= 1), "{their_log}");
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
