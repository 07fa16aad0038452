//! RTL with the avoider in the loop: the way home, facing it, and a climb kept.

use kestrel_proto::Time;
use kestrel_proto::messages::{AvoidanceCommand, AvoidanceHealth, FlightMode, NavState, TrajectorySetpoint};

use super::fixtures::{at_north, avoidance, nav_heading, rtl_from_the_north, trajectory, velocity};
use crate::commander::{Commander, CommanderParams};

/// In RTL's return leg, 20 m north of home at the RTL altitude, with the avoider streaming
/// `frd` (stale when `stale`) from `stale_from` on; the nav heading follows the commanded yaw.
/// Returns the commander, the last setpoint and the time.
fn rtl_return(frd: [f64; 3], stale_from: Option<u64>, until: u64) -> (Commander, TrajectorySetpoint, u64) {
    let mut c = rtl_from_the_north();
    let (mut t, mut yaw, mut sp) = (2500, 0.0, TrajectorySetpoint::default());
    while t < until {
        t += 2500;
        c.on_nav(&at_north(t, yaw));
        c.on_avoidance(&avoidance(t, frd, stale_from.is_some_and(|s| t >= s)));
        sp = trajectory(c.update(Time(t)).target);
        yaw = sp.yaw_rad.expect("yaw");
    }
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
    (c, sp, t)
}

#[test]
fn rtl_flies_home_with_the_avoider_in_the_loop_facing_the_way_home() {
    // The avoider asks for 1 m/s to the right: once the nose faces home (south), right is west.
    let (c, sp, t) = rtl_return([0.0, 1.0, 0.0], None, 8_000_000);
    let speed = CommanderParams::default().rtl_speed_m_s;
    let yaw = sp.yaw_rad.expect("yaw");
    // Within a milliradian: the setpoint the bearing is taken from has moved a step west.
    assert!((yaw.abs() - std::f64::consts::PI).abs() < 1e-3, "the forward camera looks home: yaw {yaw}");
    let v = velocity(&sp);
    assert!((v[0] + speed).abs() < 1e-2 && (v[1] + 1.0).abs() < 1e-2 && v[2].abs() < 1e-6, "{v:?}");
    assert_eq!(c.status(Time(t)).last_refusal, None);
}

#[test]
fn rtl_started_facing_away_from_home_turns_before_it_flies_the_way_home() {
    // 20 m north of home facing north: home is behind. Until the nose is within 30° of south
    // the demand is a turn on the spot, with no horizontal velocity; then it flies home.
    let mut c = rtl_from_the_north();
    let (mut t, mut yaw) = (2500, 0.0);
    let mut flew_while_off = 0.0f64;
    let mut sp = TrajectorySetpoint::default();
    while t < 10_000_000 {
        t += 2500;
        c.on_nav(&at_north(t, yaw));
        c.on_avoidance(&avoidance(t, [0.0; 3], false));
        sp = trajectory(c.update(Time(t)).target);
        let off_home = (std::f64::consts::PI - yaw.abs()).abs();
        if off_home > 31f64.to_radians() {
            // The climb's setpoint is a position alone: no velocity demand at all.
            let [n, e, _] = sp.velocity_ned_m_s.map(|v| v.unwrap_or(0.0));
            flew_while_off = flew_while_off.max(n.hypot(e));
        }
        yaw = sp.yaw_rad.expect("yaw");
    }
    assert!(flew_while_off < 1e-9, "{flew_while_off} m/s with home out of view");
    let v = velocity(&sp);
    let speed = CommanderParams::default().rtl_speed_m_s;
    assert!((v[0] + speed).abs() < 1e-2 && v[1].abs() < 1e-2, "then home at the RTL speed: {v:?}");
}

#[test]
fn rtl_with_a_stale_avoider_slows_and_holds_and_says_why() {
    let (c, sp, t) = rtl_return([0.0; 3], Some(4_000_000), 9_000_000);
    assert_eq!(velocity(&sp), [0.0; 3], "held");
    assert!(c.avoidance_holding());
    let why = c.status(Time(t)).last_refusal.expect("says why");
    assert!(why.contains("avoidance stale"), "{why}");
}

#[test]
fn rtl_flies_home_at_the_height_an_avoider_climb_reached_not_back_down_onto_what_it_climbed_over() {
    // On the way home the avoider climbs 10 m over a tree taller than the RTL altitude (every
    // region blocked), then the climb ends with the vehicle above the tree's top. The forward
    // camera cannot see the top below: going back down to the RTL altitude would land on it.
    let mut c = rtl_from_the_north();
    let rtl_down = -CommanderParams::default().rtl_altitude_m;
    let top_down = rtl_down - 10.0;
    let (mut t, mut yaw, mut down) = (2500, 0.0, rtl_down);
    let mut sp = TrajectorySetpoint::default();
    while t < 17_000_000 {
        t += 2500;
        // Facing home from 4 s on; climbing at 1.5 m/s until 10 m up.
        let climbing = t > 4_000_000 && down > top_down;
        if climbing {
            down = (down - 1.5 * 0.0025).max(top_down);
        }
        c.on_nav(&NavState { position_ned_m: [20.0, 0.0, down], ..nav_heading(t, down, yaw) });
        let command = if climbing {
            let health = AvoidanceHealth { climbing: true, ..AvoidanceHealth::default() };
            AvoidanceCommand { health, ..avoidance(t, [0.0, 0.0, -1.5], false) }
        } else {
            avoidance(t, [0.0; 3], false)
        };
        c.on_avoidance(&command);
        sp = trajectory(c.update(Time(t)).target);
        yaw = sp.yaw_rad.expect("yaw");
    }
    assert!((down - top_down).abs() < 1e-9, "the climb reached the top: {down}");
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
    // Seconds after the climb ended: home at the reached height, not down at 2 m/s.
    let v = velocity(&sp);
    assert!(v[2].abs() < 0.05, "no descent on the way home: {v:?}");
    let sp_down = sp.position_ned_m[2].expect("down");
    assert!((sp_down - top_down).abs() < 0.35, "held {sp_down} m against {top_down} m");
    assert!(v[0] < -1.0, "and flying home: {v:?}");
}
