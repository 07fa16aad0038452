//! Whole flights through the commander: a QGroundControl mission around home with RTL, and
//! take-off/land. NavState is the simulator's truth (see `common`); the estimator is not in
//! this loop.

mod common;

use common::Flight;
use kestrel_control::{CommanderParams, load_plan};
use kestrel_proto::geo::Geodetic;
use kestrel_proto::messages::{Command, FlightMode, MissionItem};
use nalgebra::Vector3;

#[test]
fn takeoff_fly_a_four_waypoint_square_return_land_and_disarm() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/missions/square.plan");
    let mission = load_plan(&path).expect("mission loads");
    let mut f = Flight::new(CommanderParams::default());
    let frame = kestrel_proto::geo::LocalFrame::new(f.l.sim.world().home.geodetic());
    let corners: Vec<Vector3<f64>> = mission
        .items
        .iter()
        .filter_map(|item| match item {
            MissionItem::Waypoint { point, .. } => {
                let ned =
                    frame.to_ned(Geodetic { lat_deg: point.lat_deg, lon_deg: point.lon_deg, alt_m: 20.0 });
                Some(Vector3::new(ned[0], ned[1], -point.alt_m))
            }
            _ => None,
        })
        .collect();
    assert_eq!(corners.len(), 4);
    f.commander.on_mission(mission).expect("mission accepted");
    f.command(Command::SetMode(FlightMode::Auto)).expect("auto");
    f.command(Command::Arm).expect("pre-arm checks pass");
    let (mut max_cross_track, mut max_speed, mut t) = (0.0f64, 0.0f64, 0.0);
    let mut took_off = false;
    let done = f.run_until(180.0, |f| {
        t += 0.0025;
        let p = f.l.position();
        took_off |= f.height() > 1.0;
        let status = f.commander.status(f.now());
        // Cross-track error along the square's legs (corner 1 → 2 → 3 → 4), once on them.
        if status.mode == FlightMode::Auto && status.mission.reached >= 2 && status.mission.reached <= 4 {
            let i = status.mission.reached as usize - 2;
            let (a, b) = (corners[i], corners[i + 1]);
            let along = (p - a).dot(&(b - a).normalize()).clamp(0.0, (b - a).norm());
            max_cross_track = max_cross_track.max((p - (a + (b - a).normalize() * along)).norm());
        }
        max_speed = max_speed.max(f.l.sim.state().velocity_ned_m_s.xy().norm());
        took_off && !f.commander.armed()
    });
    let status = f.commander.status(f.now());
    let landing = f.l.position().xy().norm();
    println!(
        "square mission: done {done} after {t:.1} s; items {}/{}; max cross-track {max_cross_track:.2} m; \
         max speed {max_speed:.2} m/s; landed {landing:.3} m from home",
        status.mission.reached, status.mission.total
    );
    assert!(done, "did not land and disarm: {status:?}");
    assert!(status.mission.completed && status.mission.reached == 6, "{status:?}");
    assert!(landing < 1.0, "landed {landing} m from home");
    assert!(f.l.sim.landed() && !f.l.sim.crashed() && f.l.sim.collisions() == 0);
    assert!(max_speed < 5.5, "cruise speed exceeded: {max_speed}");
    assert!(f.commander.failsafe_log().is_empty(), "{:?}", f.commander.failsafe_log());
}

#[test]
fn takeoff_then_land_disarms_on_touchdown() {
    let mut f = Flight::new(CommanderParams::default());
    f.command(Command::SetMode(FlightMode::PosHold)).expect("poshold");
    f.command(Command::Arm).expect("armed");
    f.command(Command::Takeoff { altitude_m: 5.0 }).expect("takeoff");
    assert!(f.run_until(15.0, |f| (f.height() - 5.0).abs() < 0.1), "did not reach 5 m");
    f.run(2.0);
    assert!((f.height() - 5.0).abs() < 0.1);
    f.command(Command::Land).expect("land");
    assert!(f.run_until(20.0, |f| !f.commander.armed()), "did not disarm");
    assert!(f.l.sim.landed() && !f.l.sim.crashed());
    assert!(f.l.position().xy().norm() < 0.2);
}
