//! What the avoider adds around table 3.1: climbing when every region is blocked (thesis §6),
//! slowing for an unknown centre (the textureless wall, §4.2.3), stopping for a blocked centre
//! the table has no row for, and the low-pass on the output (§3.3.9).

mod scenes;

use kestrel_avoider::{Avoider, AvoiderParams};
use scenes::{at, blocked, clear_grid, flying_north, grid};

const EVERYWHERE: [(usize, usize); 9] =
    [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (2, 0), (2, 1), (2, 2)];

fn unfiltered(speed_m_s: f64) -> Avoider {
    let mut avoider =
        Avoider::thesis(AvoiderParams { filter_time_constant_s: 0.0, ..AvoiderParams::default() })
            .expect("builds");
    avoider.set_setpoint(&flying_north(0.0, speed_m_s)).expect("valid setpoint");
    avoider
}

#[test]
fn all_blocked_stops_and_climbs_until_the_centre_clears() {
    let mut avoider = unfiltered(4.0);
    let climb = avoider.update(at(0.0), &clear_grid(0.0, blocked(&EVERYWHERE))).expect("valid");
    assert!(climb.health.climbing);
    assert_eq!(climb.velocity_frd_m_s, [-4.0, 0.0, -1.5], "stop forward progress, climb at 1.5 m/s");

    // Climbing past the wall's top: the top row clears, the centre thins out but stays above
    // the exit share (0.3): keep climbing.
    let mut near = blocked(&EVERYWHERE);
    near[0] = [0.0; 3];
    near[1][1] = 0.4;
    let still = avoider.update(at(0.1), &clear_grid(0.1, near)).expect("valid");
    assert!(still.health.climbing, "{:?}", still.health);
    assert_eq!(still.velocity_frd_m_s, [-4.0, 0.0, -1.5]);

    // The centre clears: the climb ends and the rule base steers again.
    near[1][1] = 0.1;
    let over = avoider.update(at(0.2), &clear_grid(0.2, near)).expect("valid");
    assert!(!over.health.climbing && !over.health.centre_blocked, "{:?}", over.health);
    assert!(over.velocity_frd_m_s[2] > -0.5, "no more climb: {:?}", over.velocity_frd_m_s);
}

#[test]
fn unknown_side_regions_leave_no_way_out_but_an_unknown_view_is_no_wall() {
    // A textured obstacle ahead, nothing measurable around it: climb.
    let mut invalid = [[0.9; 3]; 3];
    invalid[1][1] = 0.0;
    let mut avoider = unfiltered(3.0);
    let command = avoider.update(at(0.0), &grid(0.0, blocked(&[(1, 1)]), invalid)).expect("valid");
    assert!(command.health.climbing, "{:?}", command.health);

    // Nothing measurable anywhere (darkness, fog, open sky): slow down, do not climb blind.
    let mut avoider = unfiltered(3.0);
    let command = avoider.update(at(0.0), &grid(0.0, [[0.0; 3]; 3], [[0.95; 3]; 3])).expect("valid");
    assert!(!command.health.climbing && command.health.unknown_centre_slowdown, "{:?}", command.health);
    assert!((command.velocity_frd_m_s[0] + 0.7 * 3.0).abs() < 1e-9, "{:?}", command.velocity_frd_m_s);
}

#[test]
fn a_textureless_centre_slows_the_vehicle_and_is_reported() {
    let speed = 4.0;
    let mut invalid = [[0.05; 3]; 3];
    let textured = unfiltered(speed).update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid");
    assert!(textured.velocity_frd_m_s[0].abs() < 5e-3, "a textured empty view: no correction");

    // The wall of thesis §4.2.3: no disparity in the centre, so no near pixel either.
    invalid[1][1] = 0.95;
    let wall = unfiltered(speed).update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid");
    assert!(wall.health.unknown_centre_slowdown);
    assert_eq!(wall.health.unknown_regions, [[false; 3], [false, true, false], [false; 3]]);
    let kept = speed + wall.velocity_frd_m_s[0];
    assert!((kept - 0.3 * speed).abs() < 1e-9, "keeps 30% of {speed} m/s, got {kept} m/s");
    assert!(wall.velocity_frd_m_s[1].abs() < 5e-3 && wall.velocity_frd_m_s[2].abs() < 5e-3);

    // An unknown side region is reported but does not slow the vehicle.
    invalid[1][1] = 0.05;
    invalid[1][0] = 0.95;
    let side = unfiltered(speed).update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid");
    assert!(side.health.unknown_regions[1][0] && !side.health.unknown_centre_slowdown);
    assert!(side.velocity_frd_m_s[0].abs() < 5e-3);
}

#[test]
fn a_blocked_centre_alone_stops_forward_progress() {
    // Table 3.1 has no row for a pole straight ahead with a clear view around it; every rule
    // fires at e^-8 and the rule base alone would barely brake.
    let mut avoider = unfiltered(5.0);
    let command = avoider.update(at(0.0), &clear_grid(0.0, blocked(&[(1, 1)]))).expect("valid");
    assert!(command.fuzzy.vy_forward > -0.1, "the rule base alone: {:?}", command.fuzzy);
    assert!(command.health.centre_blocked && !command.health.climbing);
    assert_eq!(command.velocity_frd_m_s[0], -5.0);
    assert!(command.velocity_frd_m_s[1].abs() < 5e-3 && command.velocity_frd_m_s[2].abs() < 5e-3);
}

#[test]
fn the_low_pass_step_response_follows_its_time_constant() {
    let tau = 0.5;
    let dt = 0.05;
    let mut avoider =
        Avoider::thesis(AvoiderParams { filter_time_constant_s: tau, ..AvoiderParams::default() })
            .expect("builds");
    avoider.set_setpoint(&flying_north(0.0, 5.0)).expect("valid setpoint");
    let first = avoider.update(at(0.0), &clear_grid(0.0, [[0.0; 3]; 3])).expect("valid");
    assert!(first.velocity_frd_m_s.iter().all(|v| v.abs() < 5e-3), "seeded at the first target");

    // An obstacle ahead and to the left from the next frame on. The filter applies each frame's
    // target over the interval before it, so the response is u·(1 − e^(−t/τ)) from t = 0.
    let near = blocked(&[(1, 0), (1, 1)]);
    let mut at_tau = [0.0; 3];
    for k in 1..=60 {
        let t = k as f64 * dt;
        let command = avoider.update(at(t), &clear_grid(t, near)).expect("valid");
        let target = [-5.0, command.fuzzy.vx_right * 5.0, -command.fuzzy.vz_up * 5.0];
        let start = first.velocity_frd_m_s;
        let share = 1.0 - (-t / tau).exp();
        for axis in 0..3 {
            let expected = start[axis] + share * (target[axis] - start[axis]);
            let got = command.velocity_frd_m_s[axis];
            assert!((got - expected).abs() < 1e-9, "t = {t} s, axis {axis}: {got} vs {expected}");
        }
        if k == 10 {
            at_tau = command.velocity_frd_m_s;
        }
    }
    // One time constant after the step: 63.2% of the way.
    assert!((at_tau[0] / -5.0 - 0.632_12).abs() < 1e-3, "{at_tau:?}");
}
