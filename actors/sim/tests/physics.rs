//! Physics acceptance tests: hover, free fall, motor lag, torque axes, ground, collisions.

use kestrel_proto::Time;
use kestrel_proto::messages::{ActuatorOutputs, MAX_MOTORS};
use kestrel_proto::units::GRAVITY_M_S2;
use kestrel_sim::{
    DragParams, InitialState, Obstacle, RigidBodyState, SimOptions, SimOutput, Simulator, VehicleParams,
    WindParams, World, hover_throttle,
};
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

fn armed(commands: impl IntoIterator<Item = f64>) -> ActuatorOutputs {
    let mut motors = [0.0; MAX_MOTORS];
    for (m, c) in motors.iter_mut().zip(commands) {
        *m = c;
    }
    ActuatorOutputs { time: Time::ZERO, armed: true, motors }
}

fn at(position_ned_m: [f64; 3]) -> RigidBodyState {
    RigidBodyState { position_ned_m: position_ned_m.into(), ..RigidBodyState::default() }
}

fn sim(vehicle: VehicleParams, world: World, body: RigidBodyState, actuators: ActuatorOutputs) -> Simulator {
    let options = SimOptions { initial: InitialState { body, actuators }, ..SimOptions::default() };
    Simulator::new(vehicle, world, options).expect("valid")
}

fn run_for(sim: &mut Simulator, seconds: f64) {
    let end = Time(sim.time().0 + (seconds * 1e6).round() as u64);
    sim.advance_to(end);
    sim.drain().for_each(drop);
}

#[test]
fn hover_throttle_holds_altitude_within_a_centimetre_for_ten_seconds() {
    for path in ["quad_x", "hexa_x", "octo_x"] {
        let file = format!("{}/../../config/vehicles/{path}.toml", env!("CARGO_MANIFEST_DIR"));
        let vehicle = VehicleParams::load(file.as_ref()).expect("shipped vehicle loads");
        let hover = hover_throttle(&vehicle);
        assert!(hover > 0.2 && hover < 0.7, "{path}: hover at {hover}");
        let mut s = sim(vehicle, World::default(), at([0.0, 0.0, -10.0]), armed([hover; MAX_MOTORS]));
        run_for(&mut s, 10.0);
        let drift = s.state().position_ned_m - Vector3::new(0.0, 0.0, -10.0);
        assert!(drift.norm() < 0.01, "{path}: drifted {drift}");
        assert!(!s.landed() && !s.crashed());
    }
}

#[test]
fn a_little_more_than_hover_throttle_climbs() {
    let vehicle = VehicleParams::default();
    let hover = hover_throttle(&vehicle);
    let mut s = sim(vehicle, World::default(), at([0.0, 0.0, -10.0]), armed([hover * 1.01; MAX_MOTORS]));
    run_for(&mut s, 2.0);
    assert!(s.state().position_ned_m.z < -10.0 - 0.15, "{}", s.state().position_ned_m);
}

#[test]
fn free_fall_matches_gravity() {
    let vehicle = VehicleParams {
        drag: DragParams { linear_n_per_m_s: 0.0, quadratic_n_per_m2_s2: 0.0, yaw_n_m_per_rad_s: 0.0 },
        ..VehicleParams::default()
    };
    let mut s = sim(vehicle, World::default(), at([0.0, 0.0, -100.0]), ActuatorOutputs::default());
    run_for(&mut s, 3.0);
    let (z, vz) = (s.state().position_ned_m.z, s.state().velocity_ned_m_s.z);
    assert!((vz - GRAVITY_M_S2 * 3.0).abs() < 1e-9, "v = {vz}");
    assert!((z - (-100.0 + 0.5 * GRAVITY_M_S2 * 9.0)).abs() < 1e-9, "z = {z}");
    assert!((s.ground_truth().acceleration_ned_m_s2[2] - GRAVITY_M_S2).abs() < 1e-6);
}

#[test]
fn drag_limits_the_fall_speed() {
    let mut s =
        sim(VehicleParams::default(), World::default(), at([0.0, 0.0, -2000.0]), ActuatorOutputs::default());
    run_for(&mut s, 30.0);
    let drag = DragParams::default();
    let v = s.state().velocity_ned_m_s.z;
    let drag_n = drag.linear_n_per_m_s * v + drag.quadratic_n_per_m2_s2 * v * v;
    assert!((drag_n - 1.5 * GRAVITY_M_S2).abs() < 0.01, "terminal speed {v}, drag {drag_n} N");
}

#[test]
fn steady_wind_carries_a_level_hovering_vehicle_downwind() {
    let world = World {
        wind: WindParams { steady_ned_m_s: [3.0, 0.0, 0.0], ..WindParams::default() },
        ..World::default()
    };
    let vehicle = VehicleParams::default();
    let hover = hover_throttle(&vehicle);
    let mut s = sim(vehicle, world, at([0.0, 0.0, -10.0]), armed([hover; 4]));
    run_for(&mut s, 60.0);
    let v = s.state().velocity_ned_m_s;
    assert!((v.x - 3.0).abs() < 0.05 && v.y.abs() < 1e-9, "{v}");
}

#[test]
fn a_motor_step_reaches_63_percent_at_the_time_constant() {
    let vehicle = VehicleParams::default();
    let tau_s = vehicle.motor.time_constant_s;
    let final_rad_s = vehicle.motor.commanded_speed_rad_s(0.5);
    let mut s = sim(vehicle, World::default(), at([0.0, 0.0, -10.0]), ActuatorOutputs::default());
    assert_eq!(s.motor_speeds_rad_s(), &[0.0; 4]);
    s.set_actuators(&armed([0.5; 4]));
    run_for(&mut s, tau_s);
    for &w in s.motor_speeds_rad_s() {
        let share = w / final_rad_s;
        assert!((share - (1.0 - (-1.0f64).exp())).abs() < 1e-9, "{share}");
    }
    run_for(&mut s, 10.0 * tau_s);
    assert!(s.motor_speeds_rad_s().iter().all(|w| (w / final_rad_s - 1.0).abs() < 1e-4));
}

#[test]
fn disarmed_outputs_stop_the_motors() {
    let vehicle = VehicleParams::default();
    let mut s = sim(vehicle, World::default(), at([0.0, 0.0, -10.0]), armed([0.5; 4]));
    s.set_actuators(&ActuatorOutputs { armed: false, ..armed([0.5; 4]) });
    run_for(&mut s, 1.0);
    assert!(s.motor_speeds_rad_s().iter().all(|&w| w < 1.0));
}

/// Differential motor commands for a roll, pitch or yaw torque on the quad-X, around hover.
fn differential(vehicle: &VehicleParams, axis: usize) -> ActuatorOutputs {
    let hover = hover_throttle(vehicle);
    armed(vehicle.frame.motors(vehicle.arm_length_m).map(|m| {
        let p = m.position_frd_m;
        let sign = match axis {
            0 => -p.y.signum(),
            1 => p.x.signum(),
            _ => m.spin.yaw_sign(),
        };
        hover * (1.0 + 0.05 * sign)
    }))
}

#[test]
fn differential_thrust_about_one_axis_turns_only_that_axis() {
    for axis in 0..3 {
        let vehicle = VehicleParams::default();
        let mut s = sim(
            vehicle.clone(),
            World::default(),
            at([0.0, 0.0, -10.0]),
            armed([hover_throttle(&vehicle); 4]),
        );
        s.set_actuators(&differential(&vehicle, axis));
        run_for(&mut s, 0.3);
        let w = s.state().angular_velocity_frd_rad_s;
        assert!(w[axis] > 0.02, "axis {axis}: ω = {w}");
        for other in (0..3).filter(|&i| i != axis) {
            assert!(w[other].abs() < 1e-9 * w[axis], "axis {axis}: ω = {w}");
        }
    }
}

#[test]
fn resting_on_the_ground_does_not_sink_and_is_landed() {
    let mut s =
        sim(VehicleParams::default(), World::default(), at([0.0, 0.0, 0.0]), ActuatorOutputs::default());
    s.advance_to(Time::from_secs_f64(5.0));
    assert_eq!(s.state().position_ned_m, Vector3::zeros());
    assert!(s.landed() && !s.crashed());
    let imu = s.drain().find_map(|o| if let SimOutput::Imu(m) = o { Some(m) } else { None }).unwrap();
    assert!((imu.accel_m_s2[2] + GRAVITY_M_S2).abs() < 0.5, "{imu:?}");
}

#[test]
fn take_off_and_touchdown_update_the_landed_flag() {
    let vehicle = VehicleParams::default();
    let hover = hover_throttle(&vehicle);
    let mut s = sim(vehicle, World::default(), at([0.0, 0.0, 0.0]), ActuatorOutputs::default());
    s.set_actuators(&armed([hover * 1.2; 4]));
    run_for(&mut s, 0.5);
    assert!(!s.landed() && s.state().position_ned_m.z < -0.1, "{}", s.state().position_ned_m);
    s.set_actuators(&armed([hover * 0.9; 4]));
    run_for(&mut s, 5.0);
    assert!(s.landed() && !s.crashed(), "z = {}", s.state().position_ned_m.z);
    assert_eq!(s.state().position_ned_m.z, 0.0);
}

#[test]
fn a_hard_impact_and_a_tip_over_are_crashes() {
    let mut dropped =
        sim(VehicleParams::default(), World::default(), at([0.0, 0.0, -5.0]), ActuatorOutputs::default());
    run_for(&mut dropped, 3.0);
    assert!(dropped.landed() && dropped.crashed());
    assert_eq!(dropped.state().position_ned_m.z, 0.0);

    let mut gentle =
        sim(VehicleParams::default(), World::default(), at([0.0, 0.0, -0.2]), ActuatorOutputs::default());
    run_for(&mut gentle, 1.0);
    assert!(gentle.landed() && !gentle.crashed());

    let tilted = RigidBodyState {
        attitude: UnitQuaternion::from_euler_angles(70f64.to_radians(), 0.0, 0.0),
        ..at([0.0, 0.0, -0.2])
    };
    let mut tipped = sim(VehicleParams::default(), World::default(), tilted, ActuatorOutputs::default());
    run_for(&mut tipped, 1.0);
    assert!(tipped.crashed());
}

#[test]
fn flying_through_a_box_counts_one_collision() {
    let world = World {
        obstacles: vec![Obstacle::Box {
            center_ned_m: [10.0, 0.0, -2.0],
            size_m: [2.0, 4.0, 4.0],
            yaw_deg: 0.0,
        }],
        ..World::default()
    };
    let vehicle = VehicleParams {
        drag: DragParams { linear_n_per_m_s: 0.0, quadratic_n_per_m2_s2: 0.0, yaw_n_m_per_rad_s: 0.0 },
        ..VehicleParams::default()
    };
    let hover = hover_throttle(&vehicle);
    let start = RigidBodyState { velocity_ned_m_s: Vector3::new(5.0, 0.0, 0.0), ..at([0.0, 0.0, -2.0]) };
    let mut s = sim(vehicle, world, start, armed([hover; 4]));
    assert!((s.clearance_m() - 9.0).abs() < 1e-9, "{}", s.clearance_m());
    run_for(&mut s, 1.0);
    assert_eq!(s.collisions(), 0);
    assert!((s.clearance_m() - 4.0).abs() < 1e-6, "{}", s.clearance_m());
    run_for(&mut s, 3.0);
    assert_eq!(s.collisions(), 1, "entering the box once counts once");
    assert_eq!(s.ground_truth().collisions, 1);
    assert!(s.clearance_m() > 8.0);
}

#[test]
fn a_bad_initial_state_is_an_error_not_a_panic() {
    let options = SimOptions {
        initial: InitialState { body: at([0.0, 0.0, 1.0]), ..InitialState::default() },
        ..SimOptions::default()
    };
    let err = Simulator::new(VehicleParams::default(), World::default(), options).unwrap_err();
    assert!(err.field.contains("initial.position_ned_m"), "{err}");
    let options = SimOptions { physics_substeps: 0, ..SimOptions::default() };
    assert!(Simulator::new(VehicleParams::default(), World::default(), options).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn never_below_ground_and_attitude_stays_unit_under_random_commands(
        commands in prop::collection::vec(prop::array::uniform4(0.0f64..1.0), 1..40),
        start_down_m in -20.0f64..0.0,
    ) {
        let mut s = sim(VehicleParams::default(), World::default(), at([0.0, 0.0, start_down_m]), ActuatorOutputs::default());
        for c in commands {
            s.set_actuators(&armed(c));
            for _ in 0..20 {
                s.step();
                let state = s.state();
                prop_assert!(state.position_ned_m.z <= 0.0, "{}", state.position_ned_m);
                prop_assert!((state.attitude.into_inner().norm() - 1.0).abs() < 1e-12);
                prop_assert!(state.velocity_ned_m_s.iter().all(|v| v.is_finite()));
            }
            s.drain().for_each(drop);
        }
    }
}
