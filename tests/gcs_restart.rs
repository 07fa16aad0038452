//! A restart keeps what a ground station gave the vehicle: tests/python/gcs_restart.py uploads a
//! mission, a fence and rally points and sets parameters on `kestrel run` of config/sim.toml
//! (its `[state] dir`, here a directory of this test's own), downloads them, and after the test
//! stops the process and starts it again on the same config, downloads them again. Each
//! download must equal what was sent, field by field, before and after the restart.

mod support;
use support::sim_vehicle;

use std::time::{Duration, Instant};

use serde_json::Value;
use sim_vehicle::{kestrel_at_5x, python_client, sim_config, stop, tail, temp_dir};

#[test]
fn mission_fence_rally_and_parameters_survive_a_restart() {
    let started = Instant::now();
    let dir = temp_dir("restart");
    let (mut client, lines) = python_client("gcs_restart.py", |c| c);
    let first = lines.recv_timeout(Duration::from_secs(15)).unwrap_or_default();
    let port: u16 = first.strip_prefix("PORT ").and_then(|p| p.trim().parse().ok()).expect("client port");
    // No param_file: the parameters live in the state directory too.
    let link = format!(
        "params.system_id = 1\nparams.endpoints = [ {{ type = \"udp_out\", address = \"127.0.0.1:{port}\" }} ]\n"
    );
    let config_path = dir.join("restart.toml");
    std::fs::write(&config_path, sim_config(&link)).expect("config");
    let log = |n: u32| dir.join(format!("restart-{n}.log"));
    let mut kestrel = kestrel_at_5x(&dir, &config_path, &log(1), "600");
    let mut transcript = Vec::new();
    let mut restarted = false;
    let status = loop {
        while let Ok(line) = lines.recv_timeout(Duration::from_millis(50)) {
            println!("  {line}");
            if line == "RESTART" {
                assert!(stop(&mut kestrel, "first run").success(), "first run\n{}", tail_of(&log(1)));
                kestrel = kestrel_at_5x(&dir, &config_path, &log(2), "600");
                restarted = true;
            }
            transcript.push(line);
        }
        if let Some(status) = client.0.try_wait().expect("client status") {
            transcript.extend(lines.try_iter());
            break status;
        }
        assert!(started.elapsed() < Duration::from_secs(150), "client did not finish");
    };
    assert!(
        status.success() && restarted,
        "client {status:?}\n{}",
        tail_of(&log(if restarted { 2 } else { 1 }))
    );
    assert!(stop(&mut kestrel, "second run").success(), "second run\n{}", tail_of(&log(2)));
    let result: Value = serde_json::from_str(transcript.last().expect("a result")).expect("JSON");
    let r = &result["results"];
    for plan in ["mission", "fence", "rally"] {
        let sent = &r["sent"][plan];
        assert!(sent.as_array().is_some_and(|a| !a.is_empty()), "{plan}: {r:#}");
        assert_eq!(&r["before"]["plans"][plan], sent, "{plan} downloaded before the restart");
        assert_eq!(&r["after"]["plans"][plan], sent, "{plan} downloaded after the restart");
    }
    for (name, value) in r["params_set"].as_object().expect("params") {
        assert_eq!(&r["before"]["params"][name], value, "{name} before");
        assert_eq!(&r["after"]["params"][name], value, "{name} after the restart");
    }
    println!("restart test took {:.1} s", started.elapsed().as_secs_f64());
}

fn tail_of(path: &std::path::Path) -> String {
    tail(&std::fs::read_to_string(path).unwrap_or_default(), 30)
}
