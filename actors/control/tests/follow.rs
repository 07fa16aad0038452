//! FOLLOW flown closed loop through the commander, the controller and the simulator in lockstep
//! at 400 Hz, after a target that reports itself as FOLLOW_TARGET does (position, velocity,
//! heading and heading rate) five times a second. NavState is the simulator's truth (see
//! `common`). Measured figures are printed
//! (`cargo test -p kestrel-control --test follow -- --nocapture`).

mod common;

use common::Flight;
use kestrel_control::CommanderParams;
use kestrel_control::commander::{FollowParams, OffsetFrame, TARGET_TIMEOUT_S};
use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{Command, FlightMode, FollowSource, FollowTarget, LandedState};
use nalgebra::Vector2;

/// The target's speed (m/s) and its turn rate in the turn (rad/s): a quarter turn in 6 s on a
/// radius of 3 / (π/12) = 11.5 m.
const SPEED_M_S: f64 = 3.0;
const TURN_RATE_RAD_S: f64 = std::f64::consts::PI / 12.0;
/// Reports a second.
const REPORT_HZ: f64 = 5.0;

/// A ground target: north at 3 m/s for `straight_s`, a right quarter turn, then east.
#[derive(Clone, Copy, Debug)]
struct Target {
    position_ne_m: Vector2<f64>,
    heading_rad: f64,
    rate_rad_s: f64,
}

impl Target {
    fn at(straight_s: f64, t: f64) -> Target {
        let turn_s = std::f64::consts::FRAC_PI_2 / TURN_RATE_RAD_S;
        if t <= straight_s {
            return Target {
                position_ne_m: Vector2::new(SPEED_M_S * t, 0.0),
                heading_rad: 0.0,
                rate_rad_s: 0.0,
            };
        }
        let r = SPEED_M_S / TURN_RATE_RAD_S;
        let start = Vector2::new(SPEED_M_S * straight_s, 0.0);
        let centre = start + Vector2::new(0.0, r);
        let u = (t - straight_s).min(turn_s);
        let a = TURN_RATE_RAD_S * u;
        let on_turn = centre + r * Vector2::new(a.sin(), -a.cos());
        if t - straight_s <= turn_s {
            return Target { position_ne_m: on_turn, heading_rad: a, rate_rad_s: TURN_RATE_RAD_S };
        }
        let after = t - straight_s - turn_s;
        Target {
            position_ne_m: on_turn + Vector2::new(0.0, SPEED_M_S * after),
            heading_rad: std::f64::consts::FRAC_PI_2,
            rate_rad_s: 0.0,
        }
    }

    fn velocity(&self) -> [f64; 3] {
        [SPEED_M_S * self.heading_rad.cos(), SPEED_M_S * self.heading_rad.sin(), 0.0]
    }

    /// Its report, `up_m` above home, as the link decodes a FOLLOW_TARGET with every bit set.
    fn report(&self, frame: &LocalFrame, up_m: f64) -> FollowTarget {
        let g = frame.to_geodetic([self.position_ne_m.x, self.position_ne_m.y, -up_m]);
        FollowTarget {
            system_id: 17,
            source: FollowSource::FollowTarget,
            lat_deg: g.lat_deg,
            lon_deg: g.lon_deg,
            alt_amsl_m: g.alt_m,
            alt_above_home_m: None,
            velocity_ned_m_s: self.velocity(),
            acceleration_ned_m_s2: [0.0; 3],
            heading_rad: Some(self.heading_rad),
            heading_rate_rad_s: self.rate_rad_s,
        }
    }
}

fn params(follow: FollowParams) -> CommanderParams {
    CommanderParams { follow, ..CommanderParams::default() }
}

/// Armed in GUIDED and up at `height_m`, holding.
fn airborne(p: CommanderParams, height_m: f64) -> Flight {
    let mut f = Flight::new(p);
    f.command(Command::Arm).expect("pre-arm checks pass");
    f.command(Command::Takeoff { altitude_m: height_m }).expect("take-off");
    assert!(f.run_until(30.0, |f| f.height() > height_m - 0.3), "did not climb");
    f.run(3.0);
    assert_eq!(f.commander.status(f.now()).landed, LandedState::InAir);
    f
}

fn frame(f: &Flight) -> LocalFrame {
    LocalFrame::new(f.l.sim.world().home.geodetic())
}

/// Flies `seconds` from `t0` (the target's clock) with a report every 1/REPORT_HZ s while
/// `reporting(t)`; `watch` sees the flight and the target's true state each step.
fn fly_after(
    f: &mut Flight,
    straight_s: f64,
    t0: f64,
    seconds: f64,
    reporting: impl Fn(f64) -> bool,
    mut watch: impl FnMut(&Flight, f64, &Target),
) {
    let frame = frame(f);
    let steps = (seconds * 400.0).round() as usize;
    let every = (400.0 / REPORT_HZ).round() as usize;
    for i in 0..steps {
        let t = t0 + i as f64 / 400.0;
        let target = Target::at(straight_s, t);
        if i % every == 0 && reporting(t) {
            f.command(Command::FollowTarget(target.report(&frame, 10.0))).expect("a report is never refused");
        }
        f.step();
        watch(f, t, &target);
    }
}

#[test]
fn follow_keeps_five_metres_behind_a_target_at_three_metres_a_second_straight_and_through_a_turn() {
    // FOLL_OFS_TYPE 1, 5 m behind at the target's height; FOLL_YAW_BEHAVE 1 (face the target).
    let follow = FollowParams {
        enabled: true,
        offset_m: [-5.0, 0.0, 0.0],
        offset_frame: OffsetFrame::Relative,
        ..FollowParams::default()
    };
    let mut f = airborne(params(follow), 10.0);
    let straight_s = 25.0;
    // The target starts 5 m ahead of the vehicle, so the point flown starts where it is.
    let start = f.l.position();
    assert!(start.xy().norm() < 0.5, "took off over home: {start}");
    f.command(Command::FollowTarget(Target::at(straight_s, 0.0).report(&frame(&f), 10.0))).expect("report");
    f.command(Command::SetMode(FlightMode::Follow)).expect("FOLLOW with FOLL_ENABLE 1");
    let mut straight = (0.0, 0.0f64, 0.0);
    let mut turning = (0.0, 0.0f64, 0.0);
    let mut facing_worst = 0.0f64;
    fly_after(
        &mut f,
        straight_s,
        0.0,
        straight_s + 6.0 + 10.0,
        |_| true,
        |f, t, target| {
            let h = target.heading_rad;
            let ideal = target.position_ne_m - 5.0 * Vector2::new(h.cos(), h.sin());
            let e = (f.l.position().xy() - ideal).norm();
            // Settled on the straight (after 8 s), and from the turn's start to 4 s after it ends.
            let bucket = if (8.0..straight_s).contains(&t) {
                Some(&mut straight)
            } else if t >= straight_s && t < straight_s + 10.0 {
                Some(&mut turning)
            } else {
                None
            };
            if let Some((sq, worst, n)) = bucket {
                *sq += e * e;
                *worst = worst.max(e);
                *n += 1.0;
            }
            if t >= 8.0 {
                let to_target = target.position_ne_m - f.l.position().xy();
                let (_, _, yaw) = f.l.sim.state().attitude.euler_angles();
                let err = (yaw - to_target.y.atan2(to_target.x) + std::f64::consts::PI)
                    .rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                facing_worst = facing_worst.max(err.abs());
            }
        },
    );
    let rms = |(sq, _, n): (f64, f64, f64)| (sq / n).sqrt();
    println!(
        "FOLLOW 5 m behind at 3 m/s: straight RMS {:.2} m (worst {:.2} m); turn of radius 11.5 m RMS {:.2} m \
         (worst {:.2} m); nose off the target by at most {:.1}°; height {:.2} m",
        rms(straight),
        straight.1,
        rms(turning),
        turning.1,
        facing_worst.to_degrees(),
        f.height()
    );
    assert_eq!(f.commander.mode(), FlightMode::Follow);
    assert!(rms(straight) < 0.5 && straight.1 < 1.0, "straight: {straight:?}");
    assert!(rms(turning) < 1.5 && turning.1 < 3.0, "turn: {turning:?}");
    assert!(facing_worst < 20f64.to_radians(), "nose {:.1}° off the target", facing_worst.to_degrees());
    assert!((f.height() - 10.0).abs() < 0.5, "height {}", f.height());
}

#[test]
fn follow_stops_and_holds_when_the_reports_stop_and_when_the_target_is_beyond_foll_dist_max() {
    let follow = FollowParams { enabled: true, ..FollowParams::default() };
    let mut f = airborne(params(follow), 10.0);
    let straight_s = 1000.0;
    // All-zero offsets: the vehicle keeps its place 5 m behind, taken on entry.
    let frame = frame(&f);
    f.command(Command::FollowTarget(Target::at(straight_s, 0.0).report(&frame, 10.0))).expect("report");
    let here = f.l.position();
    f.command(Command::SetMode(FlightMode::Follow)).expect("FOLLOW");
    // Reports for 12 s, then none: the vehicle flies on the prediction for 3 s, then stops.
    let mut lost_at = None;
    fly_after(
        &mut f,
        straight_s,
        0.0,
        12.0 + TARGET_TIMEOUT_S + 6.0,
        |t| t < 12.0,
        |f, t, _| {
            if lost_at.is_none() && t >= 12.0 + TARGET_TIMEOUT_S {
                lost_at = Some(f.l.position());
            }
        },
    );
    let lost_at = lost_at.expect("ran past the timeout");
    let stopped = f.l.position();
    f.run(5.0);
    let drift = (f.l.position() - stopped).norm();
    let run_on = (stopped - lost_at).xy().norm();
    // On the last report's prediction until the timeout: the target's 15 m/s·s.
    let flown = (lost_at - here).x;
    println!(
        "FOLLOW target lost: followed {flown:.1} m north, stopped {run_on:.2} m after the 3 s timeout, \
         then drifted {drift:.2} m in 5 s"
    );
    assert!((flown - SPEED_M_S * (12.0 + TARGET_TIMEOUT_S)).abs() < 1.5, "flew {flown} m on the prediction");
    // 3 m/s at the waypoint acceleration 2.5 m/s²: 1.8 m, plus the controller's lag.
    assert!(run_on < 4.0, "stopped {run_on} m on");
    assert!(drift < 0.3, "held within {drift} m");
    assert_eq!(f.commander.mode(), FlightMode::Follow, "FOLLOW holds; it does not change mode");
    assert!(f.commander.status(f.now()).last_refusal.is_some_and(|s| s.contains("target lost")));

    // A fresh report 150 m away: beyond FOLL_DIST_MAX (100 m), not followed.
    let far = Target {
        position_ne_m: f.l.position().xy() + Vector2::new(150.0, 0.0),
        heading_rad: 0.0,
        rate_rad_s: 0.0,
    };
    let before = f.l.position();
    for _ in 0..10 {
        f.command(Command::FollowTarget(far.report(&frame, 10.0))).expect("report");
        f.run(0.5);
    }
    let moved = (f.l.position() - before).norm();
    println!("FOLLOW target 150 m away: moved {moved:.2} m");
    assert!(moved < 0.3, "moved {moved} m towards a target beyond FOLL_DIST_MAX");
    assert!(f.commander.status(f.now()).last_refusal.is_some_and(|s| s.contains("FOLL_DIST_MAX")));
}

#[test]
fn follow_is_refused_without_foll_enable_and_does_not_arm() {
    let mut f = Flight::new(CommanderParams::default());
    f.command(Command::SetMode(FlightMode::Follow)).expect_err("FOLL_ENABLE is 0");
    let mut f = Flight::new(params(FollowParams { enabled: true, ..FollowParams::default() }));
    f.command(Command::SetMode(FlightMode::Follow)).expect("enabled, no target needed");
    let why = f.command(Command::Arm).expect_err("FOLLOW does not arm");
    assert!(why.0.contains("Follow"), "{why}");
}
