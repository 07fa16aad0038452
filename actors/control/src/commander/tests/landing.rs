//! The land detector and ground contact: what counts as a touchdown and what never does.

use kestrel_proto::Time;
use kestrel_proto::messages::{Command, FlightMode, LandedState};

use super::fixtures::{at, cmd, full_battery, hovering, nav, ready};
use crate::commander::{Commander, CommanderParams};

#[test]
fn a_slow_descent_demand_in_the_air_is_not_ground_contact_and_a_firm_one_against_the_ground_is() {
    // Hovering still 5 m up in GUIDED: a demand to sink at 0.15 m/s (an avoider's "under") that
    // the vehicle follows too slowly to see is no ground; 1 m/s down while standing still is.
    for (down_m_s, disarms) in [(0.15, false), (1.0, true)] {
        let mut c = hovering();
        at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
        let mut t = 2000;
        while t < 8_000_000 && c.armed() {
            t += 2500;
            if (t - 2000) % 500_000 == 0 {
                at(&mut c, t, Command::VelocityNed { velocity_ned_m_s: [0.0, 0.0, down_m_s] })
                    .expect("velocity");
            }
            c.on_nav(&nav(Time(t), -5.0, true));
            c.update(Time(t));
        }
        assert_eq!(!c.armed(), disarms, "{down_m_s} m/s down demanded: armed {}", c.armed());
    }
}

#[test]
fn a_stale_nav_state_never_lets_the_land_detector_disarm_in_the_air() {
    let mut c = hovering();
    // NavStates stop: the stale-nav failsafe lands, and the frozen (zero) velocity of the last
    // NavState must not count as standing still on the ground.
    let mut t = 2000;
    while t < 5_000_000 {
        t += 20_000;
        c.update(Time(t));
    }
    assert_eq!(c.mode(), FlightMode::Land);
    assert_eq!(c.landed(), LandedState::Landing);
    assert!(c.armed(), "disarmed in the air on a stale NavState");
    // Fresh NavStates on the ground again: detected after land_detect_s, not at once.
    let resumed = t;
    while c.armed() && t < resumed + 3_000_000 {
        t += 2500;
        c.on_nav(&nav(Time(t), 0.0, true));
        c.update(Time(t));
    }
    assert!(!c.armed(), "fresh NavStates on the ground should disarm");
    assert!(t - resumed >= 1_000_000, "detected {} µs after NavStates resumed", t - resumed);
}

/// After a GPS loss the estimator measures the velocity from drag against the learnt wind; on
/// the ground that reads the wind as motion (1.5 m/s here). The land detector must leave it out
/// and end the landing on the vertical alone, or a windy touchdown would never disarm; a
/// GPS velocity that fast still keeps it from detecting.
#[test]
fn a_drag_measured_velocity_does_not_keep_the_land_detector_from_disarming() {
    for (from_drag, disarms) in [(true, true), (false, false)] {
        let mut c = hovering();
        at(&mut c, 2000, Command::SetMode(FlightMode::Land)).expect("land");
        let mut t = 2000;
        while c.armed() && t < 5_000_000 {
            t += 2500;
            let mut n = nav(Time(t), 0.0, false);
            n.velocity_ned_m_s = [0.0, 1.5, 0.0];
            n.valid.horizontal_velocity = true;
            n.valid.horizontal_velocity_from_drag = from_drag;
            c.on_nav(&n);
            c.update(Time(t));
        }
        assert_eq!(!c.armed(), disarms, "from drag {from_drag}: armed {}", c.armed());
    }
}

/// GUIDED, armed and told to take off to 5 m at t = 1 ms; then NavStates every 2.5 ms climb at
/// `climb_m_s` until `land_at_m` above home, where LAND arrives; from then on the vehicle slows
/// at 3 m/s², descends at 0.6 m/s to the ground and stands there. Returns the commander and the
/// time (µs) it disarmed, if it did within 30 s.
fn land_during_take_off(land_at_m: f64, climb_m_s: f64) -> (Commander, Option<u64>) {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::Guided)).expect("guided");
    cmd(&mut c, Command::Arm).expect("arm");
    cmd(&mut c, Command::Takeoff { altitude_m: 5.0 }).expect("takeoff");
    let (mut t, mut height_m, mut up_m_s, mut landing) = (1000_u64, 0.0_f64, climb_m_s, false);
    while t < 30_000_000 {
        t += 2500;
        let dt_s = 0.0025;
        if landing {
            up_m_s = (up_m_s - 3.0 * dt_s).max(-0.6);
        }
        height_m = (height_m + up_m_s * dt_s).max(0.0);
        if height_m == 0.0 && landing {
            up_m_s = 0.0;
        }
        let mut n = nav(Time(t), -height_m, true);
        n.velocity_ned_m_s[2] = -up_m_s;
        c.on_nav(&n);
        if !landing && height_m >= land_at_m {
            assert_eq!(at(&mut c, t, Command::SetMode(FlightMode::Land)), Ok(()));
            landing = true;
        }
        c.update(Time(t));
        if !c.armed() {
            return (c, Some(t));
        }
    }
    (c, None)
}

#[test]
fn land_in_the_take_off_climb_disarms_on_the_ground_below_and_above_the_airborne_height() {
    // Above the airborne height the land detector runs; below it, the vehicle never counted as
    // flying, yet LAND must still end on the ground disarmed (as PX4 and ArduPilot do).
    for land_at_m in [2.0, 0.3] {
        let (c, disarmed) = land_during_take_off(land_at_m, 1.0);
        let Some(t) = disarmed else {
            panic!("LAND at {land_at_m} m in the climb never disarmed: {:?}, {:?}", c.mode(), c.landed())
        };
        assert_eq!(c.landed(), LandedState::OnGround);
        assert!(t > 1_000_000, "LAND at {land_at_m} m disarmed at {t} µs, before touching down");
    }
}

/// Runs the commander on the ground (fresh NavStates every 10 ms) from `from_us` to `to_us`.
fn idle_on_the_ground(c: &mut Commander, from_us: u64, to_us: u64) {
    let mut t = from_us;
    while t < to_us {
        t += 10_000;
        c.on_nav(&nav(Time(t), 0.0, true));
        c.on_battery(&full_battery(Time(t)));
        c.update(Time(t));
    }
}

#[test]
fn armed_on_the_ground_without_a_take_off_disarms_after_disarm_delay() {
    let mut c = ready(true);
    cmd(&mut c, Command::Arm).expect("arm");
    idle_on_the_ground(&mut c, 1000, 9_900_000);
    assert!(c.armed(), "before DISARM_DELAY (10 s)");
    idle_on_the_ground(&mut c, 9_900_000, 10_200_000);
    assert!(!c.armed(), "10 s armed on the ground without a take-off");
    let status = c.status(Time(10_200_000));
    assert!(status.last_refusal.as_deref().is_some_and(|r| r.contains("DISARM_DELAY")), "{status:?}");
    // 0 switches it off.
    let mut c =
        Commander::new(CommanderParams { disarm_delay_s: 0.0, ..CommanderParams::default() }).expect("valid");
    c.on_nav(&nav(Time(1000), 0.0, true));
    c.on_battery(&full_battery(Time(1000)));
    cmd(&mut c, Command::Arm).expect("arm");
    idle_on_the_ground(&mut c, 1000, 30_000_000);
    assert!(c.armed());
}
