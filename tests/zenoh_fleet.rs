//! A fleet over Zenoh: `kestrel run --config config/fleet-sim.toml --instance 0` and
//! `--instance 1` publish their NavState and VehicleStatus as `kestrel/kestrel-0/…` and
//! `kestrel/kestrel-1/…`, and one client that knows nothing of Kestrel's code (the Python
//! `eclipse-zenoh` package, tests/python/zenoh_fleet.py) decodes both vehicles' positions from
//! `kestrel/*/nav_state` and commands one of them, whose commander accepts and refuses the
//! commands as it does a ground station's. The shipped config has access control on
//! (config/zenoh/fleet-vehicle.json5): a client without credentials, a viewer that may not
//! command, and a ground station's command that names no listed sender all try to arm the
//! vehicle first, and it stays disarmed until the ground station arms it.
//!
//! The whole fleet runs in a network namespace of its own (`unshare --net` through a user
//! namespace), so the fixed ports (Zenoh's 7447 + N, the links' 14550, 18570 + N, 14580 + N) are
//! the test's alone.

mod support;
use support::sim_vehicle;

use serde_json::Value;
use sim_vehicle::{root, tail, temp_dir};

/// Command ids a Zenoh client may use (`kestrel_bridge::catalogue::FIRST_BRIDGED_COMMAND_ID`).
const FIRST_ID: u64 = 1 << 31;

#[test]
fn one_zenoh_subscriber_sees_two_instances_and_commands_one_as_a_ground_station_would() {
    let dir = temp_dir("zenoh-fleet");
    let script = r#"
        ip link set lo up || exit 90
        "$PYTHON" "$CLIENT" "$GCS" "$VIEWER" 90 kestrel-0=tcp/127.0.0.1:7447 kestrel-1=tcp/127.0.0.1:7448 \
            --command kestrel-1 \
            > "$DIR/client.out" 2> "$DIR/client.err" &
        client=$!
        for n in 0 1; do
            "$KESTREL" run --config "$CONFIG" --instance $n --speedup 2 --duration 300 --quiet \
                > "$DIR/kestrel$n.log" 2>&1 &
            eval "vehicle$n=\$!"
        done
        wait $client; c=$?
        kill -INT $vehicle0 $vehicle1
        wait $vehicle0; k0=$?
        wait $vehicle1; k1=$?
        echo "EXIT client=$c kestrel0=$k0 kestrel1=$k1"
    "#;
    let out = sim_vehicle::fleet_in_own_network(
        script,
        &dir,
        &[
            ("CLIENT", root().join("tests/python/zenoh_fleet.py")),
            ("CONFIG", root().join("config/fleet-sim.toml")),
            ("GCS", root().join("config/zenoh/fleet-gcs.json5")),
            ("VIEWER", root().join("config/zenoh/fleet-viewer.json5")),
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap_or_default();
    let client = read("client.out");
    println!("{client}");
    let logs = || {
        format!(
            "client stderr:\n{}\nkestrel 0:\n{}\nkestrel 1:\n{}",
            read("client.err"),
            tail(&read("kestrel0.log"), 20),
            tail(&read("kestrel1.log"), 20)
        )
    };
    assert!(stdout.trim_end().ends_with("EXIT client=0 kestrel0=0 kestrel1=0"), "{stdout}\n{}", logs());
    let summary: Value =
        serde_json::from_str(client.lines().last().unwrap_or_default()).expect("the client's JSON summary");
    let vehicles = &summary["vehicles"];
    for name in ["kestrel-0", "kestrel-1"] {
        let v = &vehicles[name];
        let nav_states = v["nav_states"].as_u64().unwrap_or(0);
        assert!(nav_states >= 5, "{name}: {v}");
        let encodings: Vec<&str> =
            v["encodings"].as_array().unwrap().iter().filter_map(Value::as_str).collect();
        assert!(encodings.contains(&"application/json;kestrel.NavState"), "{name}: {encodings:?}");
        assert!(encodings.contains(&"application/json;kestrel.VehicleStatus"), "{name}: {encodings:?}");
        // Every sample carries its capture time and its send time.
        let samples = nav_states + v["statuses"].as_u64().unwrap_or(0);
        assert!(v["timestamped"].as_u64().unwrap_or(0) >= samples, "{name}: {v}");
        assert!(v["attachments"].as_u64().unwrap_or(0) >= samples, "{name}: {v}");
    }
    // Instance 1 started 5 m east of instance 0 (`kestrel_sim::INSTANCE_SPACING_M`).
    let east = vehicles["kestrel-1"]["east_m_from_first"].as_f64().expect("east offset");
    assert!((east - 5.0).abs() < 1.0, "kestrel-1 is {east} m east of kestrel-0");

    // Refused before the ground station armed it: none answered, the vehicle never armed.
    let attempts = &summary["attempts"];
    for name in ["intruder", "viewer", "gcs_unstamped", "gcs_as_viewer"] {
        let a = &attempts[name];
        assert!(a["answered"] == false && a["armed"] == false, "{name}: {attempts}\n{}", logs());
    }
    assert_eq!(
        attempts["intruder"]["peers"], 0,
        "the vehicle refuses a client without credentials: {attempts}"
    );
    assert_eq!(attempts["viewer"]["peers"], 1, "the viewer logs in: {attempts}");
    assert!(attempts["viewer"]["nav_states_seen"].as_u64().unwrap_or(0) > 0, "and may watch: {attempts}");

    let results = &summary["results"];
    let takeoff = &results[(FIRST_ID + 1).to_string()];
    assert_eq!(takeoff["vehicle"], "kestrel-1", "{results}");
    assert!(takeoff["refusal"].as_str().is_some_and(|r| r.contains("not armed")), "{results}");
    let arm = &results[(FIRST_ID + 2).to_string()];
    assert!(arm["vehicle"] == "kestrel-1" && arm["refusal"].is_null(), "{results}");
    assert!(results.get("12").is_none(), "a command in the link's id range is never answered: {results}");
    assert_eq!(vehicles["kestrel-1"]["armed_seen"], true, "{}", logs());
    assert_eq!(vehicles["kestrel-0"]["armed_seen"], false, "only the commanded vehicle armed");
    let log1 = read("kestrel1.log");
    assert!(log1.contains("command id 12 is in the link's range"), "{}", tail(&log1, 30));
    // The bridge refused each of the ground station's three unstamped and three wrongly stamped
    // arms, and never saw the viewer's (stamped with the same id as the latter): Zenoh's access
    // control dropped those before the bridge.
    let lines = |text: &str| log1.lines().filter(|l| l.contains(text)).count();
    assert_eq!(lines("vehicle_command: it names no sender"), 3, "{}", tail(&log1, 30));
    let unlisted = lines("vehicle_command: sender 5b1d7e0c2a9f4e02 is not in command_sources");
    assert_eq!(unlisted, 3, "{}", tail(&log1, 30));
    // The take-off stamped an hour ahead was taken at its arrival (and answered, above).
    assert!(log1.contains("bridge clamped a time 3600."), "{}", tail(&log1, 30));
    std::fs::remove_dir_all(&dir).ok();
}
