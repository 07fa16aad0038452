//! Live parameters through the whole default graph (`config/sim.toml`, lockstep, in-process):
//! the link restores a parameter file at start and sends each stored value to the actor that
//! declared it; the controller and the estimator apply theirs and declare back the values they
//! now use, recorded on `param_decl` — those locked while armed (a pulse range, a calibration)
//! included, since the vehicle boots disarmed.

use std::path::Path;
use std::time::Duration;

use kestrel::recorder::LogReader;
use kestrel::{LoadedConfig, Registry, RunOptions, run};
use kestrel_proto::messages::{ParamDecl, ParamSet};

/// The value `owner` declared for `name` in its last declaration answering a `ParamSet`.
fn answered(decls: &[ParamDecl], owner: &str, name: &str) -> Option<f64> {
    decls
        .iter()
        .filter(|d| d.owner == owner && !d.start)
        .filter_map(|d| d.params.iter().find(|p| p.name == name))
        .map(|p| p.value)
        .next_back()
}

#[test]
fn stored_gains_and_noises_reach_their_owners_at_start() {
    let dir = std::env::temp_dir().join(format!("kestrel-live-params-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let param_file = dir.join("params.txt");
    // MPC_THR_MAX 0.12 is inside its range but below the minimum thrust (0.08) plus 0.05: the
    // controller must refuse it and keep 0.9.
    // SERVO1_MAX and COMPASS_OFS_X are refused while armed, never at boot: the vehicle is disarmed.
    let stored = "MC_ROLLRATE_P=30\nEKF2_GPS_P_NOISE=3\nRTL_ALT_M=25\nMPC_THR_MAX=0.12\nSERVO1_MAX=1950\nCOMPASS_OFS_X=100\n";
    std::fs::write(&param_file, stored).expect("param file");
    let record = dir.join("params.mcap");

    let config_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("config");
    let mut config = LoadedConfig::load(&config_dir.join("sim.toml")).expect("config/sim.toml");
    let link = config.graph.actors.values_mut().find(|d| d.kind.get_ref() == "link").expect("a link");
    let mut params = toml::Table::new();
    params.insert("param_file".into(), param_file.display().to_string().into());
    // No sockets: the test needs only the graph side of the link.
    params.insert("endpoints".into(), toml::Value::Array(Vec::new()));
    link.params = Some(toml::Spanned::new(0..0, params));
    config.graph.record.topics =
        ["param_decl", "param_set"].iter().map(|t| toml::Spanned::new(0..0, (*t).to_owned())).collect();
    let options = RunOptions {
        duration: Some(Duration::from_secs(2)),
        speedup: Some(0.0),
        record: Some(record.clone()),
        ..Default::default()
    };
    let report = run(&config, &Registry::standard(), options).expect("the graph runs");
    assert!(report.supervisor_events.is_empty(), "{:?}", report.supervisor_events);

    let log = LogReader::open(&record).expect("log");
    let sets: Vec<(String, f64)> = log
        .read::<ParamSet>("param_set")
        .expect("param_set recorded")
        .into_iter()
        .map(|r| (r.message.name, r.message.value))
        .collect();
    for wanted in [("MC_ROLLRATE_P", 30.0), ("EKF2_GPS_P_NOISE", 3.0), ("RTL_ALT_M", 25.0)] {
        assert!(sets.iter().any(|(n, v)| n == wanted.0 && *v == wanted.1), "{wanted:?} not sent: {sets:?}");
    }
    let decls: Vec<ParamDecl> = log
        .read::<ParamDecl>("param_decl")
        .expect("param_decl recorded")
        .into_iter()
        .map(|r| r.message)
        .collect();
    let owners: Vec<&str> = decls.iter().filter(|d| d.start).map(|d| d.owner.as_str()).collect();
    for owner in ["estimator", "commander", "controller"] {
        assert!(owners.contains(&owner), "{owner} did not declare at start: {owners:?}");
    }
    assert_eq!(answered(&decls, "controller", "MC_ROLLRATE_P"), Some(30.0));
    assert_eq!(answered(&decls, "estimator", "EKF2_GPS_P_NOISE"), Some(3.0));
    assert_eq!(answered(&decls, "commander", "RTL_ALT_M"), Some(25.0));
    assert_eq!(answered(&decls, "sim", "SERVO1_MAX"), Some(1950.0));
    assert_eq!(answered(&decls, "sim", "COMPASS_OFS_X"), Some(100.0));
    // Locked while armed, across every owner of the graph: exactly the pulse ranges of the four
    // motors and the sensor calibration with the board trim (README, "Ground stations").
    let mut locked: Vec<&str> = decls
        .iter()
        .filter(|d| d.start)
        .flat_map(|d| d.params.iter().filter(|p| p.disarmed_only).map(|p| p.name.as_str()))
        .collect();
    locked.sort_unstable();
    locked.dedup();
    let mut wanted: Vec<String> =
        (1..=4).flat_map(|i| [format!("SERVO{i}_MIN"), format!("SERVO{i}_MAX")]).collect();
    for prefix in
        ["COMPASS_OFS_", "COMPASS_DIA_", "COMPASS_ODI_", "INS_ACCOFFS_", "INS_ACCSCAL_", "INS_GYROFFS_"]
    {
        wanted.extend(["X", "Y", "Z"].map(|axis| format!("{prefix}{axis}")));
    }
    wanted.extend(["AHRS_TRIM_X".to_owned(), "AHRS_TRIM_Y".to_owned()]);
    wanted.sort_unstable();
    assert_eq!(locked, wanted);
    assert_eq!(answered(&decls, "controller", "MPC_THR_MAX"), Some(0.9), "the refused value is not applied");
    std::fs::remove_dir_all(&dir).ok();
}
