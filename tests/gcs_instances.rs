//! Several vehicles on one machine, as PX4's multi-vehicle SITL runs them: `kestrel run
//! --instance 0` and `--instance 1` on the default config fly their missions at the same time,
//! and one ground station on UDP 14550 (pymavlink, tests/python/gcs_fleet.py) sees system ids 1
//! and 2, each with its own position and its own mission progress.
//!
//! The whole fleet runs in a network namespace of its own (`unshare --net` through a user
//! namespace), so the fixed ports (14550, 18570 + N, 14580 + N) are the test's alone.

mod support;
use support::sim_vehicle;

use sim_vehicle::{root, tail, temp_dir};

#[test]
fn two_instances_fly_missions_at_once_and_one_ground_station_sees_both() {
    let dir = temp_dir("instances");
    let script = r#"
        ip link set lo up || exit 90
        "$PYTHON" "$CLIENT" 120 > "$DIR/gcs.out" 2> "$DIR/gcs.err" &
        gcs=$!
        sleep 1
        for n in 0 1; do
            plan=$PLAN0; [ $n = 1 ] && plan=$PLAN1
            "$KESTREL" run --instance $n --mission "$plan" --auto --exit-on-land --speedup 4 \
                --duration 600 --quiet > "$DIR/kestrel$n.log" 2>&1 &
            eval "vehicle$n=\$!"
        done
        wait $vehicle0; k0=$?
        wait $vehicle1; k1=$?
        wait $gcs; g=$?
        echo "EXIT gcs=$g kestrel0=$k0 kestrel1=$k1"
    "#;
    let out = sim_vehicle::fleet_in_own_network(
        script,
        &dir,
        &[
            ("CLIENT", root().join("tests/python/gcs_fleet.py")),
            ("PLAN0", root().join("config/missions/square.plan")),
            ("PLAN1", root().join("config/missions/leg-40m.plan")),
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap_or_default();
    let gcs = read("gcs.out");
    println!("{gcs}");
    assert!(
        stdout.trim_end().ends_with("EXIT gcs=0 kestrel0=0 kestrel1=0"),
        "{stdout}\ngcs stderr:\n{}\nkestrel 0:\n{}\nkestrel 1:\n{}",
        read("gcs.err"),
        tail(&read("kestrel0.log"), 20),
        tail(&read("kestrel1.log"), 20)
    );
    let last = gcs.lines().last().expect("the ground station's summary");
    let summary: serde_json::Value = serde_json::from_str(last).expect("JSON summary");
    let systems = summary["systems"].as_object().expect("systems");
    assert_eq!(systems.keys().collect::<Vec<_>>(), ["1", "2"], "{last}");
    for (id, s) in systems {
        assert!(s["heartbeats"].as_u64().unwrap_or(0) >= 5, "system {id}: {s}");
        assert!(
            s["armed_seen"] == true && s["landed"] == true && s["disarmed_after_flight"] == true,
            "system {id} did not fly and land: {s}"
        );
        assert!(s["max_rel_alt_m"].as_f64().unwrap_or(0.0) > 5.0, "system {id}: {s}");
    }
    // Each flew its own mission: the square reports items 1..6 reached, the 40 m leg 1..3.
    let reached = |id: &str| systems[id]["reached"].as_array().map_or(0, Vec::len);
    assert!(reached("1") >= 5 && reached("2") >= 2, "{last}");
    // Instance 1 started 5 m east of instance 0 (`kestrel_sim::INSTANCE_SPACING_M`).
    let east = systems["2"]["east_m_from_first_of_system_1"].as_f64().expect("east offset");
    assert!((east - 5.0).abs() < 1.0, "instance 1 started {east} m east of instance 0");
    std::fs::remove_dir_all(&dir).ok();
}
