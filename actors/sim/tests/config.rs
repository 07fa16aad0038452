//! The shipped vehicle and world files load; bad files fail with errors naming file and field.

use std::path::{Path, PathBuf};

use kestrel_proto::frame_layout::FrameLayout;
use kestrel_sim::sensors::RangefinderParams;
use kestrel_sim::{ConfigError, Obstacle, VehicleParams, World, hover_throttle};

fn config(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config").join(relative)
}

fn scratch(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kestrel-sim-config-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write");
    path
}

#[test]
fn shipped_vehicles_load_and_can_hover() {
    for (file, frame) in
        [("quad_x", FrameLayout::QuadX), ("hexa_x", FrameLayout::HexaX), ("octo_x", FrameLayout::OctoX)]
    {
        let vehicle = VehicleParams::load(&config(&format!("vehicles/{file}.toml"))).expect(file);
        assert_eq!(vehicle.frame, frame);
        assert!(hover_throttle(&vehicle) < 0.7, "{file}");
    }
    let quad = VehicleParams::load(&config("vehicles/quad_x.toml")).expect("quad");
    // A second IMU is the Navio2's (absent by default: a board with one); the rest is the
    // defaults in code, written out.
    let second = quad.sensors.imu2.as_ref().expect("quad_x.toml has the Navio2's second IMU");
    assert_eq!(second.rate_hz, quad.sensors.imu.rate_hz);
    // Its rangefinders are TFmini Pluses, the defaults of a rangefinder table (absent by
    // default: an airframe without them).
    assert_eq!(quad.sensors.rangefinder_up, Some(RangefinderParams::default()));
    assert_eq!(quad.sensors.rangefinder_down, Some(RangefinderParams::default()));
    let mut bare = quad.clone();
    bare.sensors.imu2 = None;
    bare.sensors.rangefinder_up = None;
    bare.sensors.rangefinder_down = None;
    assert_eq!(bare, VehicleParams::default(), "quad_x.toml documents the defaults in code");
}

#[test]
fn shipped_worlds_load_with_moratuwa_as_home() {
    let empty = World::load(&config("worlds/empty.toml")).expect("empty");
    assert_eq!(empty, World::default(), "empty.toml documents the defaults in code");
    let course = World::load(&config("worlds/obstacles.toml")).expect("obstacles");
    assert_eq!(course.home, empty.home);
    assert!((course.home.lat_deg - 6.79710).abs() < 1e-9 && (course.home.lon_deg - 79.90170).abs() < 1e-9);
    assert!(course.obstacles.iter().any(|o| matches!(o, Obstacle::Wall { textured: false, .. })));
    assert!(course.obstacles.iter().any(|o| matches!(o, Obstacle::Cylinder { .. })));
    assert!(course.obstacles.iter().any(|o| matches!(o, Obstacle::Box { .. })));
}

#[test]
fn an_out_of_range_field_names_the_file_and_the_field() {
    let path = scratch("negative_mass.toml", "mass_kg = -1.5\n");
    let err = VehicleParams::load(&path).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, ConfigError::Invalid { .. }));
    assert!(text.contains("negative_mass.toml") && text.contains("mass_kg"), "{text}");

    let path = scratch("slow_motor.toml", "[motor]\ntime_constant_s = 0.0\n");
    let text = VehicleParams::load(&path).unwrap_err().to_string();
    assert!(text.contains("motor.time_constant_s"), "{text}");

    let path = scratch("bad_gps.toml", "[sensors.gps]\nrate_hz = -5.0\n");
    let text = VehicleParams::load(&path).unwrap_err().to_string();
    assert!(text.contains("sensors.gps.rate_hz"), "{text}");

    let path = scratch(
        "flat_iron.toml",
        "[sensors.mag]\nsoft_iron = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]\n",
    );
    let text = VehicleParams::load(&path).unwrap_err().to_string();
    assert!(text.contains("sensors.mag.soft_iron") && text.contains("singular"), "{text}");

    let path = scratch("dead_axis.toml", "[sensors.imu]\naccel_scale = [1.0, 0.0, 1.0]\n");
    let text = VehicleParams::load(&path).unwrap_err().to_string();
    assert!(text.contains("sensors.imu.accel_scale"), "{text}");

    let path =
        scratch("short_lidar.toml", "[sensors.rangefinder_down]\nmin_range_m = 0.5\nmax_range_m = 0.4\n");
    let text = VehicleParams::load(&path).unwrap_err().to_string();
    assert!(
        text.contains("short_lidar.toml") && text.contains("sensors.rangefinder_down.min_range_m"),
        "{text}"
    );

    let path = scratch("board.toml", "[sensors]\nboard_rotation_deg = [0.0, 200.0, 0.0]\n");
    let text = VehicleParams::load(&path).unwrap_err().to_string();
    assert!(text.contains("sensors.board_rotation_deg"), "{text}");

    let path = scratch("weak.toml", "mass_kg = 10.0\n");
    let text = VehicleParams::load(&path).unwrap_err().to_string();
    assert!(text.contains("not enough to lift"), "{text}");

    let path = scratch(
        "bad_tree.toml",
        "[[obstacles]]\nkind = \"cylinder\"\nbase_ne_m = [1.0, 2.0]\nradius_m = -1.0\nheight_m = 3.0\n",
    );
    let text = World::load(&path).unwrap_err().to_string();
    assert!(text.contains("bad_tree.toml") && text.contains("obstacles[0].radius_m"), "{text}");
}

#[test]
fn typos_and_missing_files_are_errors_naming_the_file() {
    let path = scratch("typo.toml", "mass_kgs = 1.5\n");
    let err = VehicleParams::load(&path).unwrap_err();
    assert!(matches!(err, ConfigError::Parse { .. }), "{err}");
    assert!(err.to_string().contains("typo.toml") && err.to_string().contains("mass_kgs"), "{err}");

    let path = scratch("unknown_kind.toml", "[[obstacles]]\nkind = \"pyramid\"\n");
    assert!(matches!(World::load(&path), Err(ConfigError::Parse { .. })));

    let missing = Path::new("/nonexistent/kestrel/vehicle.toml");
    let err = VehicleParams::load(missing).unwrap_err();
    assert!(
        matches!(err, ConfigError::Read { .. })
            && err.to_string().contains("/nonexistent/kestrel/vehicle.toml")
    );
}

#[test]
fn the_fault_example_holds_every_kind_and_bad_entries_name_file_line_and_field() {
    let world = World::load(&config("worlds/faults-example.toml")).expect("faults-example");
    let mut kinds: Vec<&str> = world.faults.iter().map(|f| f.kind.name()).collect();
    kinds.sort_unstable();
    let mut expected: Vec<&str> = kestrel_sim::faults::KINDS.to_vec();
    expected.sort_unstable();
    assert_eq!(kinds, expected);
    assert_eq!(
        World { faults: Vec::new(), ..world },
        World::load(&config("worlds/empty.toml")).expect("empty")
    );

    let path = scratch(
        "bad_fault.toml",
        "[[faults]]\nat_s = 1.0\nkind = \"gps_off\"\n\n[[faults]]\nat_s = 2.0\nkind = \"motor_weak\"\n\
         motor = 1\nthrust = 1.5\n",
    );
    let err = World::load(&path).unwrap_err();
    assert!(matches!(err, ConfigError::InvalidAt { line: 5, .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("bad_fault.toml:5") && text.contains("faults[1].thrust"), "{text}");

    let path = scratch("nan_fault.toml", "[[faults]]\nat_s = nan\nkind = \"imu_stop\"\n");
    let text = World::load(&path).unwrap_err().to_string();
    assert!(text.contains("nan_fault.toml:1") && text.contains("faults[0].at_s"), "{text}");
}
