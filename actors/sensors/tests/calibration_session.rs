//! The ground-station calibration session closed around the simulator: the
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
    session.set_vehicle(true, kestrel_proto::messages::LandedState::OnGround);
    session.on_request(9, start(CalibrationStep::Gyro), sim.time());
    let refused = session.take_updates();
    assert!(
        matches!(&refused[0], CalibrationUpdate::Answer { id: 9, refusal: Some(r) } if r.contains("armed"))
    );
}

/// The ESC ranges of the unequal vehicle the ESC tests calibrate (µs).
const ESC_TRUTH_US: [[f64; 2]; 4] = [[1080.0, 1920.0], [1040.0, 1960.0], [1120.0, 1880.0], [1000.0, 2000.0]];

fn esc_simulator(esc_range_us: &[[f64; 2]]) -> Simulator {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/vehicles/quad_x.toml");
    let mut vehicle = VehicleParams::load(&path).expect("the default vehicle loads");
    vehicle.motor.esc_range_us = esc_range_us.to_vec();
    Simulator::new(vehicle, World::default(), SimOptions::default()).expect("simulator")
}

/// Runs the ESC calibration closed around the simulator for at most `limit_s`, its direct pulses
/// driving the simulated ESCs and their telemetry fed back; `interrupt` may act on the session
/// at each tick (its time in s). Returns every update.
fn run_esc(
    sim: &mut Simulator,
    session: &mut Session,
    limit_s: f64,
    mut interrupt: impl FnMut(&mut Session, &mut Simulator, f64),
) -> Vec<CalibrationUpdate> {
    session.on_esc(&sim.esc_telemetry());
    session.on_request(1, start(CalibrationStep::Esc), sim.time());
    let t0 = sim.time();
    let mut updates = session.take_updates();
    while sim.time().saturating_since(t0).as_secs_f64() < limit_s && session.running().is_some() {
        sim.set_calibration_motion(session.motion());
        sim.set_direct_pulses(session.esc_pulses_us().as_ref());
        sim.step();
        sim.drain().for_each(drop);
        let t_s = sim.time().saturating_since(t0).as_secs_f64();
        interrupt(session, sim, t_s);
        session.on_esc(&sim.esc_telemetry());
        session.on_tick(sim.time());
        updates.extend(session.take_updates());
    }
    sim.set_calibration_motion(session.motion());
    sim.set_direct_pulses(session.esc_pulses_us().as_ref());
    updates
}

fn results(updates: &[CalibrationUpdate]) -> Option<&Vec<(String, f64)>> {
    updates.iter().find_map(|u| match u {
        CalibrationUpdate::Results { params } => Some(params),
        _ => None,
    })
}

#[test]
fn the_esc_ramp_recovers_each_escs_own_range_with_the_propellers_off() {
    let mut sim = esc_simulator(&ESC_TRUTH_US);
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    let mut highest_m = 0.0f64;
    let updates = run_esc(&mut sim, &mut session, 90.0, |_, sim, _| {
        highest_m = highest_m.max(-sim.state().position_ned_m.z);
    });
    let params = results(&updates).unwrap_or_else(|| panic!("no result: {:?}", texts(&updates)));
    println!("{:?}", texts(&updates));
    assert_eq!(params.len(), 8, "{params:?}");
    for (i, [start, full]) in ESC_TRUTH_US.iter().enumerate() {
        let get = |name: String| params.iter().find(|(n, _)| *n == name).map(|(_, v)| *v).expect("named");
        let (min, max) = (get(format!("SERVO{}_MIN", i + 1)), get(format!("SERVO{}_MAX", i + 1)));
        println!("ESC {}: truth {start}..{full} µs, fitted {min}..{max} µs", i + 1);
        assert!((min - start).abs() <= 5.0 && (max - full).abs() <= 5.0, "ESC {}: {min}..{max}", i + 1);
    }
    assert!(texts(&updates).iter().any(|t| t.contains("REMOVE THE PROPELLERS")));
    assert!(highest_m < 0.01, "the vehicle lifted {highest_m} m: the propellers were on");
    assert_eq!(
        (session.running(), session.esc_pulses_us(), sim.calibration_motion()),
        (None, None, Motion::Idle)
    );
}

#[test]
fn an_esc_that_never_turns_is_refused_and_nothing_applied() {
    let mut truth = ESC_TRUTH_US;
    truth[2] = [2100.0, 2200.0]; // beyond the ramp: the motor never turns, as an unpowered ESC
    let mut sim = esc_simulator(&truth);
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    let updates = run_esc(&mut sim, &mut session, 90.0, |_, _, _| {});
    assert!(results(&updates).is_none());
    let failed = texts(&updates).into_iter().find(|t| t.contains("FAILED")).expect("a failure text");
    println!("dead ESC: {failed}");
    assert!(failed.contains("output 2") && failed.contains("never turned"), "{failed}");
}

#[test]
fn the_esc_ramp_stops_on_cancel_arm_request_lost_telemetry_and_is_refused_unless_it_may_run() {
    type Interrupt = fn(&mut Session, &mut Simulator, f64);
    let cases: [(&str, Interrupt, &str); 3] = [
        (
            "cancel",
            |s, sim, t| {
                if t > 5.0 && s.running().is_some() {
                    s.on_request(2, CalibrationRequest::Cancel, sim.time())
                }
            },
            "cancelled",
        ),
        (
            "arm",
            |s, _, t| {
                if t > 5.0 {
                    s.on_arm_request()
                }
            },
            "arming requested",
        ),
        (
            "armed",
            |s, _, t| {
                if t > 5.0 {
                    s.set_vehicle(true, kestrel_proto::messages::LandedState::OnGround)
                }
            },
            "vehicle armed",
        ),
    ];
    for (what, interrupt, expect) in cases {
        let mut sim = esc_simulator(&ESC_TRUTH_US);
        let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
        let updates = run_esc(&mut sim, &mut session, 90.0, interrupt);
        assert!(results(&updates).is_none(), "{what}");
        assert!(texts(&updates).iter().any(|t| t.contains(expect)), "{what}: {:?}", texts(&updates));
        assert_eq!((session.running(), session.esc_pulses_us()), (None, None), "{what}: pulses released");
        assert!(sim.time().as_secs_f64() < 7.0, "{what}: stopped at once");
    }

    // Telemetry that goes quiet mid-ramp stops it within the telemetry timeout.
    let mut sim = esc_simulator(&ESC_TRUTH_US);
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    session.on_esc(&sim.esc_telemetry());
    session.on_request(1, start(CalibrationStep::Esc), sim.time());
    let mut stopped_at = None;
    for tick in 0..4000u32 {
        sim.set_direct_pulses(session.esc_pulses_us().as_ref());
        sim.step();
        if tick < 2000 {
            session.on_esc(&sim.esc_telemetry());
        }
        session.on_tick(sim.time());
        if session.running().is_none() {
            stopped_at = Some(tick);
            break;
        }
    }
    let texts_now = session.take_updates();
    assert!(texts(&texts_now).iter().any(|t| t.contains("telemetry stopped")), "{:?}", texts(&texts_now));
    let after_s = f64::from(stopped_at.expect("stopped") - 2000) / 400.0;
    println!("telemetry lost: stopped {after_s} s after the last report");
    assert!(after_s <= 0.31, "{after_s}");

    // A ramp that outlasts its deadline fails and releases the pulses (here the margin is set
    // 50 s short of the ramp's 60.2 s, so the deadline falls 10.2 s in).
    let mut sim = esc_simulator(&ESC_TRUTH_US);
    let mut settings = SessionSettings::new(EARTH_FIELD_GAUSS);
    settings.esc_margin_s = -50.0;
    let mut session = Session::new(settings);
    let updates = run_esc(&mut sim, &mut session, 90.0, |_, _, _| {});
    assert!(results(&updates).is_none());
    assert!(texts(&updates).iter().any(|t| t.contains("ESC timed out")), "{:?}", texts(&updates));
    let ended_s = sim.time().as_secs_f64();
    println!("deadline: ended at {ended_s} s");
    assert!((10.2..10.25).contains(&ended_s), "{ended_s}");
    assert_eq!(session.esc_pulses_us(), None);

    // Refused: armed, in the air, without telemetry (PWM ESCs), while another calibration runs.
    let sim = esc_simulator(&ESC_TRUTH_US);
    let refusal = |session: &mut Session| {
        session.on_request(7, start(CalibrationStep::Esc), sim.time());
        match session.take_updates().first() {
            Some(CalibrationUpdate::Answer { id: 7, refusal: Some(r) }) => r.clone(),
            other => panic!("not refused: {other:?}"),
        }
    };
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    assert!(refusal(&mut session).contains("no ESC telemetry"));
    session.on_esc(&sim.esc_telemetry());
    session.set_vehicle(false, kestrel_proto::messages::LandedState::InAir);
    assert!(refusal(&mut session).contains("not landed"));
    session.set_vehicle(true, kestrel_proto::messages::LandedState::OnGround);
    assert!(refusal(&mut session).contains("armed"));
    session.set_vehicle(false, kestrel_proto::messages::LandedState::OnGround);
    session.on_request(8, start(CalibrationStep::Gyro), sim.time());
    session.take_updates();
    assert!(refusal(&mut session).contains("gyro calibration running"));
}

#[test]
fn pwm_escs_without_telemetry_get_max_until_the_battery_is_connected_then_the_disarmed_pulse() {
    let t = |s: f64| kestrel_proto::Time::from_secs_f64(s);
    let mut session = Session::new(SessionSettings::new(EARTH_FIELD_GAUSS));
    let answer = |session: &mut Session, id: u32, at: f64| {
        session.on_request(id, start(CalibrationStep::Esc), t(at));
        match session.take_updates().first() {
            Some(CalibrationUpdate::Answer { refusal, .. }) => refusal.clone(),
            other => panic!("no answer: {other:?}"),
        }
    };
    // No speed and no battery monitor: nothing to go by.
    let refusal = answer(&mut session, 1, 1.0).expect("refused");
    assert!(refusal.contains("no ESC telemetry") && refusal.contains("no battery voltage"), "{refusal}");
    // The battery connected: the ESCs would power up at an ordinary pulse (PX4: disconnect it).
    session.on_battery(16.2);
    let refusal = answer(&mut session, 2, 1.0).expect("refused");
    assert!(refusal.contains("disconnect the battery"), "{refusal}");
    session.on_battery(f64::NAN);
    assert!(answer(&mut session, 3, 1.0).is_some(), "a NaN voltage is no disconnected battery");

    // Disconnected: the maximum pulse, held until 5 s after the battery is connected.
    session.on_battery(0.0);
    assert_eq!(answer(&mut session, 4, 1.0), None);
    assert_eq!(session.motion(), Motion::PropsOff);
    let mut texts_seen = Vec::new();
    let mut released_at = None;
    for tick in 0..500u32 {
        let now_s = 1.0 + f64::from(tick) * 0.02;
        if now_s >= 4.0 {
            session.on_battery(16.2);
        }
        session.on_tick(t(now_s));
        texts_seen.extend(texts(&session.take_updates()).into_iter().map(str::to_owned));
        match session.esc_pulses_us() {
            Some(p) => assert_eq!(p, [2000.0; 8], "{now_s}"),
            None => {
                released_at = Some(now_s);
                break;
            }
        }
    }
    let released_at = released_at.expect("released");
    println!("PWM max-then-min: battery at 4.0 s, released at {released_at:.2} s; {texts_seen:?}");
    assert!((9.0..9.05).contains(&released_at), "{released_at}");
    assert!(texts_seen.iter().any(|t| t.contains("battery connected")));
    assert!(texts_seen.iter().any(|t| t.contains("ESC calibration done")));
    assert_eq!(session.running(), None);

    // A battery never connected: it fails after 20 s, released.
    session.on_battery(0.0);
    assert_eq!(answer(&mut session, 5, 100.0), None);
    session.on_request(6, CalibrationRequest::Cancel, t(100.5));
    assert_eq!(session.esc_pulses_us(), None, "cancelled");
    assert_eq!(answer(&mut session, 7, 101.0), None);
    let mut failed = None;
    for tick in 0..1200u32 {
        let now_s = 101.0 + f64::from(tick) * 0.02;
        session.on_tick(t(now_s));
        if texts(&session.take_updates()).iter().any(|t| t.contains("timeout waiting for the battery")) {
            failed = Some(now_s);
            break;
        }
    }
    let failed = failed.expect("failed");
    assert!((121.0..121.1).contains(&failed), "{failed}");
    assert_eq!(session.esc_pulses_us(), None);
}
