//! CIRCLE, DO_ORBIT and BRAKE flown closed loop through the commander, the controller and the
//! simulator in lockstep at 400 Hz. NavState is the simulator's truth (see `common`). Measured
//! figures are printed (`cargo test -p kestrel-control --test modes -- --nocapture`).

mod common;

use common::Flight;
use kestrel_control::CommanderParams;
use kestrel_proto::messages::{
    CalibrationStatus, CalibrationStep, Command, FlightMode, LandedState, MotorTestThrottle, OrbitYaw,
};
use nalgebra::Vector2;

/// Armed in GUIDED and up at `height_m`, holding.
fn airborne(height_m: f64) -> Flight {
    let mut f = Flight::new(CommanderParams::default());
    f.command(Command::Arm).expect("pre-arm checks pass");
    f.command(Command::Takeoff { altitude_m: height_m }).expect("take-off");
    assert!(f.run_until(30.0, |f| f.height() > height_m - 0.3), "did not climb");
    f.run(3.0);
    assert_eq!(f.commander.status(f.now()).landed, LandedState::InAir);
    f
}

/// Flies `seconds` and returns the RMS and worst distance from a `radius_m` circle round
/// `centre` (m), the mean angular rate about it (rad/s, clockwise positive) and the worst
/// heading error from the centre's bearing (rad).
fn fly_circle(f: &mut Flight, centre: Vector2<f64>, radius_m: f64, seconds: f64) -> (f64, f64, f64, f64) {
    let (mut sq, mut worst, mut n) = (0.0, 0.0f64, 0.0);
    let mut yaw_worst = 0.0f64;
    let bearing = |f: &Flight| {
        let p = f.l.position().xy() - centre;
        p.y.atan2(p.x)
    };
    let (mut last, mut turned) = (bearing(f), 0.0);
    f.run_until(seconds, |f| {
        let p = f.l.position().xy();
        let e = (p - centre).norm() - radius_m;
        sq += e * e;
        worst = worst.max(e.abs());
        n += 1.0;
        let b = bearing(f);
        turned += (b - last + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        last = b;
        let (_, _, yaw) = f.l.sim.state().attitude.euler_angles();
        let to_centre = (centre - p).y.atan2((centre - p).x);
        let err =
            (yaw - to_centre + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        yaw_worst = yaw_worst.max(err.abs());
        false
    });
    ((sq / n).sqrt(), worst, turned / seconds, yaw_worst)
}

#[test]
fn circle_mode_flies_ardupilots_default_ten_metre_circle_at_twenty_degrees_a_second() {
    let mut f = airborne(10.0);
    let start = f.l.position().xy();
    let (_, _, yaw) = f.l.sim.state().attitude.euler_angles();
    f.command(Command::SetMode(FlightMode::Circle)).expect("CIRCLE");
    // ArduCopter's centre: CIRCLE_RADIUS ahead of the vehicle along its heading.
    let centre = start + Vector2::new(yaw.cos(), yaw.sin()) * 10.0;
    // The ramp to the rate: 0.35 rad/s at 0.25 rad/s², under 2 s; one turn after it.
    f.run(3.0);
    let (rms, worst, rate, yaw_worst) = fly_circle(&mut f, centre, 10.0, 18.0);
    println!(
        "CIRCLE defaults: RMS radius error {rms:.3} m, worst {worst:.3} m, rate {:.2} deg/s, worst nose-off-centre {:.1} deg",
        rate.to_degrees(),
        yaw_worst.to_degrees()
    );
    assert!(rms < 0.3 && worst < 0.6, "RMS {rms} m, worst {worst} m");
    assert!((rate.to_degrees() - 20.0).abs() < 1.0, "rate {} deg/s", rate.to_degrees());
    assert!(yaw_worst < 10f64.to_radians(), "nose {} deg off the centre", yaw_worst.to_degrees());
    assert!((f.height() - 10.0).abs() < 0.3, "height {}", f.height());
}

#[test]
fn do_orbit_circles_its_centre_at_the_commanded_speed_and_direction() {
    let mut f = airborne(8.0);
    // Radius 6 m counter-clockwise (negative) at 2 m/s round a centre 6 m north: the vehicle is
    // on the circle already; ω = 2 / 6 rad/s, within sqrt(0.5 · 2.5 · 6) = 2.74 m/s.
    let here = f.l.position();
    let centre = Vector2::new(here.x + 6.0, here.y);
    f.command(Command::Orbit {
        radius_m: -6.0,
        speed_m_s: Some(2.0),
        yaw: OrbitYaw::FaceCentre,
        centre_ne_m: Some([centre.x, centre.y]),
        centre_down_m: Some(-8.0),
    })
    .expect("orbit");
    assert_eq!(f.commander.status(f.now()).mode, FlightMode::Circle);
    f.run(4.0);
    let (rms, worst, rate, yaw_worst) = fly_circle(&mut f, centre, 6.0, 20.0);
    println!(
        "DO_ORBIT r -6 m at 2 m/s: RMS radius error {rms:.3} m, worst {worst:.3} m, rate {rate:.3} rad/s, worst nose-off-centre {:.1} deg",
        yaw_worst.to_degrees()
    );
    assert!(rms < 0.3 && worst < 0.6, "RMS {rms} m, worst {worst} m");
    assert!((rate + 2.0 / 6.0).abs() < 0.02, "rate {rate} rad/s, wanted -0.333 (counter-clockwise)");
    assert!(yaw_worst < 10f64.to_radians());
}

#[test]
fn orbits_are_refused_on_the_ground_and_out_of_range_and_brake_refuses_to_arm() {
    let mut f = Flight::new(CommanderParams::default());
    let orbit = |radius_m| Command::Orbit {
        radius_m,
        speed_m_s: None,
        yaw: OrbitYaw::FaceCentre,
        centre_ne_m: None,
        centre_down_m: None,
    };
    let why = f.command(orbit(10.0)).expect_err("not flying");
    assert!(why.0.contains("not flying"), "{why:?}");
    f.command(Command::SetMode(FlightMode::Brake)).expect("BRAKE may be chosen on the ground");
    let why = f.command(Command::Arm).expect_err("BRAKE does not arm, as ArduCopter");
    assert!(why.0.contains("Brake"), "{why:?}");
    f.command(Command::SetMode(FlightMode::Guided)).expect("GUIDED");
    let mut f = airborne(6.0);
    assert!(f.command(orbit(f64::INFINITY)).is_err());
    assert!(f.command(orbit(1000.0)).expect_err("outside the fence").0.contains("radius"));
    let far = Command::Orbit {
        radius_m: 10.0,
        speed_m_s: None,
        yaw: OrbitYaw::FaceCentre,
        centre_ne_m: Some([295.0, 0.0]),
        centre_down_m: None,
    };
    assert!(f.command(far).is_err(), "a circle crossing the 300 m fence");
    let backwards = Command::Orbit {
        radius_m: 5.0,
        speed_m_s: Some(-1.0),
        yaw: OrbitYaw::FaceCentre,
        centre_ne_m: None,
        centre_down_m: None,
    };
    assert!(f.command(backwards).is_err());
    assert_eq!(f.commander.status(f.now()).mode, FlightMode::Guided, "refusals leave the mode");
}

#[test]
fn brake_stops_from_five_metres_a_second_within_the_tilt_limited_distance_and_holds() {
    let mut f = airborne(10.0);
    // A GUIDED velocity is repeated, as MAVSDK's offboard does, or it times out to a hold.
    for _ in 0..16 {
        f.command(Command::VelocityNed { velocity_ned_m_s: [5.0, 0.0, 0.0] }).expect("velocity");
        f.run(0.5);
    }
    assert!(f.l.sim.state().velocity_ned_m_s.x > 4.9, "did not reach 5 m/s");
    let from = f.l.position();
    let v0 = f.l.sim.state().velocity_ned_m_s.xy().norm();
    f.command(Command::SetMode(FlightMode::Brake)).expect("BRAKE");
    let mut t = 0.0;
    let mut stopped_at = None;
    let mut furthest = 0.0f64;
    f.run_until(10.0, |f| {
        t += 0.0025;
        furthest = furthest.max((f.l.position() - from).xy().norm());
        if stopped_at.is_none() && f.l.sim.state().velocity_ned_m_s.xy().norm() < 0.1 {
            stopped_at = Some(t);
        }
        false
    });
    let at_rest = f.l.position();
    f.run(10.0);
    let drift = (f.l.position() - at_rest).norm();
    // Reference: v² / (2 a) with a = g·tan(30°) = 5.66 m/s² (ANGLE_MAX 30° caps BRAKE's 7.5 m/s²),
    // 2.21 m from 5 m/s, in v / a = 0.88 s; the attitude loop's lag adds to both.
    let ideal = v0 * v0 / (2.0 * 9.80665 * 30f64.to_radians().tan());
    let stopped = stopped_at.unwrap_or(f64::INFINITY);
    println!(
        "BRAKE from {v0:.2} m/s: stopped (< 0.1 m/s) after {stopped:.2} s, {furthest:.2} m (ideal {ideal:.2} m); drift over the next 10 s {drift:.3} m"
    );
    assert!(furthest < 1.5 * ideal, "{furthest} m to stop, ideal {ideal} m");
    assert!(stopped < 2.5, "stopped after {stopped} s");
    assert!(drift < 0.1, "drifted {drift} m while holding");
    assert!((f.height() - 10.0).abs() < 0.3, "height {}", f.height());
}

#[test]
fn reboot_is_taken_disarmed_and_forced_only_on_the_ground() {
    let mut f = Flight::new(CommanderParams::default());
    f.command(Command::Reboot { force: false }).expect("disarmed: taken");
    f.command(Command::Arm).expect("pre-arm checks pass");
    assert!(f.command(Command::Reboot { force: false }).expect_err("armed").0.contains("armed"));
    assert!(f.commander.armed());
    f.command(Command::Reboot { force: true }).expect("forced on the ground: taken");
    assert!(!f.commander.armed(), "a forced reboot disarms first");
    let mut f = airborne(5.0);
    assert!(f.command(Command::Reboot { force: false }).expect_err("armed").0.contains("armed"));
    assert!(f.command(Command::Reboot { force: true }).expect_err("flying").0.contains("flying"));
    assert!(f.commander.armed(), "the refusals changed nothing");
}

#[test]
fn motor_test_is_taken_only_disarmed_landed_and_where_something_spins_them() {
    let test =
        Command::MotorTest { first: 1, count: 1, throttle: MotorTestThrottle::Share(0.1), duration_s: 0.5 };
    let mut f = Flight::new(CommanderParams::default());
    assert!(f.command(test).expect_err("no runner").0.contains("nothing in this graph"));
    let now = f.now();
    let status = |running| CalibrationStatus { time: now, missing: Vec::new(), running };
    f.commander.on_calibration(&status(Some(CalibrationStep::Mag)));
    assert!(f.command(test).expect_err("calibrating").0.contains("calibration running"));
    f.commander.on_calibration(&status(None));
    f.command(test).expect("disarmed on the ground with a runner: taken");
    let mut f = airborne(5.0);
    f.commander.on_calibration(&CalibrationStatus { time: f.now(), missing: Vec::new(), running: None });
    assert!(f.command(test).expect_err("armed").0.contains("armed"));
    assert!(f.commander.armed(), "the refusal changed nothing");
}
