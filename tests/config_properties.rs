//! Mutated and arbitrary graph configs load or are refused with a located error, never panic
//! or abort; what loads passes the runtime's own range checks.

use std::path::Path;

use kestrel::LoadedConfig;
use kestrel_proto::bad_input::mutate;
use proptest::prelude::*;

const CONFIGS: [&str; 8] = [
    include_str!("../config/sim.toml"),
    include_str!("../config/sim-forest.toml"),
    include_str!("../config/perception-sim.toml"),
    include_str!("../config/navio2.toml"),
    include_str!("../config/bench-link.toml"),
    include_str!("../config/bench-sensors.toml"),
    include_str!("../config/bench-stereo-files.toml"),
    include_str!("../config/bench-estimator-replay.toml"),
];

fn path() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("config/mutated.toml")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_configs_load_or_are_refused_with_their_file(
        which in 0..CONFIGS.len(),
        edits in prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..6),
    ) {
        let text = String::from_utf8_lossy(&mutate(CONFIGS[which].as_bytes(), &edits)).into_owned();
        match LoadedConfig::parse(&path(), &text) {
            Ok(config) => prop_assert!(config.validate().is_ok()),
            Err(e) => prop_assert!(e.to_string().starts_with(&path().display().to_string()), "{e}"),
        }
    }

    #[test]
    fn arbitrary_text_is_no_config(text in ".{0,400}") {
        let _ = LoadedConfig::parse(&path(), &text);
    }
}
