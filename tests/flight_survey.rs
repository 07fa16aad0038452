//! QGroundControl's survey (config/missions/survey.plan, a `ComplexItem` with its camera
//! triggers) flown in-process in lockstep on the default quad over the empty world: the mission
//! completes, the vehicle passes over every transect end the survey's items name, and each
//! camera trigger item is reported as what it is on a graph without a capture output (a
//! STATUSTEXT saying so) rather than pretended.

mod support;

use std::time::Instant;

use kestrel::recorder::LogReader;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{GroundTruth, VehicleStatus};
use support::sim_vehicle::{plan_in_process, root, temp_dir};

/// How near (m, horizontally) the vehicle must pass each transect end: the waypoints'
/// acceptance radius is 2 m.
const PASS_M: f64 = 2.5;

#[test]
fn the_qgroundcontrol_survey_is_flown_over_every_transect() {
    let started = Instant::now();
    let dir = temp_dir("flight-survey");
    let record = dir.join("survey.mcap");
    let report = plan_in_process(
        &dir,
        "survey",
        "missions/survey.plan",
        "config/vehicles/quad_x.toml",
        None,
        Some(record.clone()),
    );
    assert_eq!(report["mission"]["items_total"], 12, "{report:#}");
    assert_eq!(report["flight"]["collisions"], 0, "{report:#}");

    // The transect ends, from the plan itself.
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root().join("config/missions/survey.plan")).unwrap())
            .unwrap();
    let home = &plan["mission"]["plannedHomePosition"];
    let frame = LocalFrame::new(Geodetic {
        lat_deg: home[0].as_f64().unwrap(),
        lon_deg: home[1].as_f64().unwrap(),
        alt_m: home[2].as_f64().unwrap(),
    });
    let survey = &plan["mission"]["items"][1]["TransectStyleComplexItem"]["Items"];
    let ends: Vec<[f64; 3]> = survey
        .as_array()
        .unwrap()
        .iter()
        .filter(|i| i["command"] == 16)
        .map(|i| {
            let p = &i["params"];
            frame.to_ned(Geodetic {
                lat_deg: p[4].as_f64().unwrap(),
                lon_deg: p[5].as_f64().unwrap(),
                alt_m: 0.0,
            })
        })
        .collect();
    assert_eq!(ends.len(), 8);

    let log = LogReader::open(&record).expect("the flight log");
    let truth = log.read::<GroundTruth>("ground_truth").expect("ground_truth");
    for (i, end) in ends.iter().enumerate() {
        let nearest = truth
            .iter()
            .map(|t| (t.message.position_ned_m[0] - end[0]).hypot(t.message.position_ned_m[1] - end[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(nearest < PASS_M, "transect point {i} passed {nearest:.2} m away");
    }
    let said: Vec<String> = log
        .read::<VehicleStatus>("vehicle_status")
        .expect("vehicle_status")
        .into_iter()
        .filter_map(|s| s.message.last_refusal)
        .collect();
    for seq in [3, 11] {
        let text = format!("Mission: {seq} camera trigger distance: no camera output");
        assert!(
            said.contains(&text),
            "no '{text}' among {:?}",
            said.iter().collect::<std::collections::BTreeSet<_>>()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!("survey flight: {:.1} s", started.elapsed().as_secs_f64());
}
