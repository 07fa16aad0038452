//! Mutated vehicle and world files (the files a graph's `sim` actor names) load or are refused
//! naming the field, never panic or abort.

use std::path::{Path, PathBuf};

use kestrel_proto::bad_input::mutate;
use kestrel_sim::{VehicleParams, World};
use proptest::prelude::*;

const VEHICLES: [&str; 3] = [
    include_str!("../../../config/vehicles/quad_x.toml"),
    include_str!("../../../config/vehicles/hexa_x.toml"),
    include_str!("../../../config/vehicles/octo_x.toml"),
];
const WORLDS: [&str; 4] = [
    include_str!("../../../config/worlds/empty.toml"),
    include_str!("../../../config/worlds/forest.toml"),
    include_str!("../../../config/worlds/obstacles.toml"),
    include_str!("../../../config/worlds/wall-textured.toml"),
];

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sim-file-properties");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(format!("{}-{name}", std::process::id()))
}

fn edits() -> impl Strategy<Value = Vec<(u8, usize, u8)>> {
    prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..6)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_vehicle_files_load_or_are_refused(which in 0..VEHICLES.len(), edits in edits()) {
        let path = scratch("vehicle.toml");
        std::fs::write(&path, mutate(VEHICLES[which].as_bytes(), &edits)).unwrap();
        let _ = VehicleParams::load(&path);
    }

    #[test]
    fn mutated_world_files_load_or_are_refused(which in 0..WORLDS.len(), edits in edits()) {
        let path = scratch("world.toml");
        std::fs::write(&path, mutate(WORLDS[which].as_bytes(), &edits)).unwrap();
        let _ = World::load(&path);
    }
}
