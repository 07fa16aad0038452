//! The ground-station calibration session closed around the simulator (issue 19): the
//! [`Session`] asks for a motion, the simulator's person handles the vehicle so, its raw samples
//! go back to the session. Careful handling gives parameters; bad data — the vehicle held in one
//! orientation, shaken while it should stand still, a field 3× the Earth's — is refused with a
//! STATUSTEXT saying why and gives no parameters at all.

use kestrel_proto::messages::{
    ACCELCAL_FAILED, ACCELCAL_SUCCESS, CalibrationRequest, CalibrationStep, CalibrationUpdate, MagCalState,
    Motion,
};
use kestrel_sensors::calibration::{Session, SessionSettings};
use kestrel_sim::handling::Handling;
use kestrel_sim::{RawSample, SimOptions, Simulator, VehicleParams, World};

const EARTH_FIELD_GAUSS: f64 = 0.41;

fn simulator(handling: Handling, field_gauss: f64) -> Simulator {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/vehicles/quad_x_miscalibrated.toml");
    let vehicle = VehicleParams::load(&path).expect("the acceptance vehicle loads");
    let mut world = World::default();
    world.magnetic_field.total_intensity_gauss = field_gauss;
    let mut sim = Simulator::new(vehicle, world, SimOptions::default()).expect("simulator");
    sim.set_handling(handling);
    sim
}

/// Runs `request` to its end (at most `limit_s` of simulated time), answering the vehicle's
/// ACCELCAL_VEHICLE_POS requests as a ground station does; returns every update.
fn run(
    sim: &mut Simulator,
    session: &mut Session,
    request: CalibrationRequest,
    limit_s: f64,
) -> Vec<CalibrationUpdate> {
    let mut updates = Vec::new();
    let mut id = 1;
    session.on_request(id, request, sim.time());
    let end = sim.time() + std::time::Duration::from_secs_f64(limit_s);
    while sim.time() < end {
        for u in session.take_updates() {
            if let CalibrationUpdate::AccelPosition { position } = u
                && (1..=6).contains(&position)
            {
                id += 1;
                session.on_request(id, CalibrationRequest::AccelPosition { position }, sim.time());
            }
            updates.push(u);
        }
        if session.running().is_none() {
            break;
        }
        sim.set_calibration_motion(session.motion());
        sim.step();
        for raw in sim.drain_raw().collect::<Vec<_>>() {
            match raw {
                RawSample::Imu(s) => session.on_imu(&s),
                RawSample::Mag(s) => session.on_mag(&s),
            }
        }
        sim.drain().for_each(drop);
        if sim.time().0.is_multiple_of(100_000) {
            session.on_tick(sim.time());
        }
    }
    updates.extend(session.take_updates());
    sim.set_calibration_motion(session.motion());
    updates
}

fn texts(updates: &[CalibrationUpdate]) -> Vec<&str> {
    updates
        .iter()
        .filter_map(|u| match u {
            CalibrationUpdate::Text { text, .. } => Some(text.as_str()),
            _ => None,
        })
        .collect()
}

fn has_results(updates: &[CalibrationUpdate]) -> bool {
    updates.iter().any(|u| matches!(u, CalibrationUpdate::Results { .. }))
}

fn start(step: CalibrationStep) -> CalibrationRequest {
    CalibrationRequest::Start { step, autosave: true, delay_s: 0.0 }
}

#[test]
fn careful_handling_gives_every_result_and_the_session_ends_idle() {
    let mut sim = simulator(Handling::Careful, EARTH_FIELD_GAUSS);
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    let accel = run(&mut sim, &mut session, start(CalibrationStep::Accel), 30.0);
    assert!(has_results(&accel), "{:?}", texts(&accel));
    assert!(accel.contains(&CalibrationUpdate::AccelPosition { position: ACCELCAL_SUCCESS }));
    let mag = run(&mut sim, &mut session, start(CalibrationStep::Mag), 60.0);
    assert!(has_results(&mag), "{:?}", texts(&mag));
    assert!(
        mag.iter().any(|u| matches!(u, CalibrationUpdate::MagReport(r) if r.state == MagCalState::Success))
    );
    assert!(mag.iter().any(|u| matches!(u, CalibrationUpdate::MagProgress { .. })));
    assert_eq!(
        (session.running(), session.motion(), sim.calibration_motion()),
        (None, Motion::Idle, Motion::Idle)
    );
}

#[test]
fn a_compass_held_in_one_orientation_is_refused_and_nothing_applied() {
    let mut sim = simulator(Handling::OneOrientation, EARTH_FIELD_GAUSS);
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    let mag = run(&mut sim, &mut session, start(CalibrationStep::Mag), 60.0);
    assert!(!has_results(&mag));
    let failed = texts(&mag).into_iter().find(|t| t.contains("FAILED")).expect("a failure text");
    println!("one orientation: {failed}");
    assert!(failed.contains("one orientation"), "{failed}");
    // Noise about one orientation covers no direction: the progress never claims any.
    assert!(
        mag.iter().all(
            |u| !matches!(u, CalibrationUpdate::MagProgress { completion_pct, .. } if *completion_pct > 0)
        )
    );
}

#[test]
fn a_field_three_times_the_earths_is_refused_and_nothing_applied() {
    let mut sim = simulator(Handling::Careful, 3.0 * EARTH_FIELD_GAUSS);
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    let mag = run(&mut sim, &mut session, start(CalibrationStep::Mag), 60.0);
    assert!(!has_results(&mag));
    let failed = texts(&mag).into_iter().find(|t| t.contains("FAILED")).expect("a failure text");
    println!("3x field: {failed}");
    assert!(failed.contains("expected"), "{failed}");
}

#[test]
fn a_shaken_vehicle_is_refused_for_level_and_accelerometer_and_nothing_applied() {
    let mut sim = simulator(Handling::Shaking, EARTH_FIELD_GAUSS);
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    let level = run(&mut sim, &mut session, start(CalibrationStep::Level), 10.0);
    assert!(!has_results(&level));
    let failed = texts(&level).into_iter().find(|t| t.contains("FAILED")).expect("a failure text");
    println!("shaken level: {failed}");
    assert!(failed.contains("moved"), "{failed}");
    let accel = run(&mut sim, &mut session, start(CalibrationStep::Accel), 30.0);
    assert!(!has_results(&accel));
    assert!(accel.contains(&CalibrationUpdate::AccelPosition { position: ACCELCAL_FAILED }));
    // Armed, nothing starts.
    session.set_armed(true);
    session.on_request(9, start(CalibrationStep::Gyro), sim.time());
    let refused = session.take_updates();
    assert!(
        matches!(&refused[0], CalibrationUpdate::Answer { id: 9, refusal: Some(r) } if r.contains("armed"))
    );
}
