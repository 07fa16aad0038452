//! What the avoider adds around table 3.1: climbing when every region is blocked (thesis §6),
//! stopping for an unknown view ahead (the textureless wall, §4.2.3), stopping and sidestepping
//! for a blocked centre the table has no row for, capping the forward speed by the nearest
//! depth ahead, and the low-pass on the output (§3.3.9).

mod memory_scenes;
mod scenes;

use kestrel_avoider::{Avoider, AvoiderParams};
use memory_scenes::{nav_at, with_sectors};
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

    // The centre clears: the climb goes on for its 1 m margin (1 m at 1.5 m/s: 0.67 s), then
    // ends and the rule base steers again.
    near[1][1] = 0.1;
    let margin = avoider.update(at(0.2), &clear_grid(0.2, near)).expect("valid");
    assert!(margin.health.climbing && !margin.health.centre_blocked, "{:?}", margin.health);
    assert_eq!(margin.velocity_frd_m_s, [-4.0, 0.0, -1.5]);
    let still = avoider.update(at(0.85), &clear_grid(0.85, near)).expect("valid");
    assert!(still.health.climbing, "0.65 s after: {:?}", still.health);
    let over = avoider.update(at(0.9), &clear_grid(0.9, near)).expect("valid");
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

    // Nothing measurable anywhere (darkness, fog): stop, do not climb blind.
    let mut avoider = unfiltered(3.0);
    let command = avoider.update(at(0.0), &grid(0.0, [[0.0; 3]; 3], [[0.95; 3]; 3])).expect("valid");
    assert!(!command.health.climbing && command.health.unknown_centre_slowdown, "{:?}", command.health);
    assert!((command.velocity_frd_m_s[0] + 3.0).abs() < 1e-9, "{:?}", command.velocity_frd_m_s);
}

#[test]
fn a_textureless_wall_ahead_stops_the_vehicle_but_sky_in_the_centre_does_not() {
    let speed = 4.0;
    let mut invalid = [[0.05; 3]; 3];
    let textured = unfiltered(speed).update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid");
    assert!(!textured.health.unknown_centre_slowdown);

    // Level flight in the open: the upper half of the centre is sky (no disparity), the ground
    // below the path is textured. Not a wall: no slow-down.
    invalid[0] = [0.99; 3];
    invalid[1][1] = 0.9;
    invalid[2][1] = 0.3;
    let sky = unfiltered(speed).update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid");
    assert!(!sky.health.unknown_centre_slowdown, "{:?}", sky.health);
    assert!(sky.health.unknown_regions[1][1]);
    let sky_cap = sky.health.forward_cap_m_s.expect("the ground ahead has depth");
    assert!((sky.velocity_frd_m_s[0] - (sky_cap - speed).min(0.0)).abs() < 5e-3, "{sky:?}");

    // The wall of thesis §4.2.3: no disparity in the centre, and the ground below the path is
    // hidden behind it too.
    invalid[2][1] = 0.95;
    let wall = unfiltered(speed).update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid");
    assert!(wall.health.unknown_centre_slowdown);
    assert!(wall.health.unknown_regions[1][1] && wall.health.unknown_regions[2][1]);
    assert!((wall.velocity_frd_m_s[0] + speed).abs() < 1e-9, "stops: {:?}", wall.velocity_frd_m_s);
    assert!(wall.velocity_frd_m_s[1].abs() < 5e-3 && wall.velocity_frd_m_s[2].abs() < 5e-3);

    // A configured share of the speed is kept instead, if asked for.
    let mut keep = Avoider::thesis(AvoiderParams {
        filter_time_constant_s: 0.0,
        unknown_speed_share: 0.3,
        ..AvoiderParams::default()
    })
    .expect("builds");
    keep.set_setpoint(&flying_north(0.0, speed)).expect("valid setpoint");
    let slow = keep.update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid");
    assert!((speed + slow.velocity_frd_m_s[0] - 0.3 * speed).abs() < 1e-9, "{:?}", slow.velocity_frd_m_s);
}

#[test]
fn the_forward_speed_is_capped_to_stop_short_of_the_nearest_depth_ahead() {
    // Few near pixels, but a depth 4.5 m ahead in the centre: with the defaults (stop 2 m
    // short, 2 m/s², 0.3 s) v = −0.6 + √(0.36 + 2·2·2.5) = 2.622 m/s.
    let speed = 4.0;
    let mut near = [[0.0; 3]; 3];
    near[1][1] = 0.1;
    let command = unfiltered(speed).update(at(0.0), &clear_grid(0.0, near)).expect("valid");
    let cap = command.health.forward_cap_m_s.expect("capped");
    let expected = -0.6 + (0.36f64 + 10.0).sqrt();
    assert!((cap - expected).abs() < 1e-9, "{cap} vs {expected}");
    assert!((speed + command.velocity_frd_m_s[0] - expected).abs() < 1e-9, "{:?}", command.velocity_frd_m_s);
    assert!(!command.health.centre_blocked, "4.5 m is beyond the 4 m sidestep distance");

    // Flying slower than the cap: no correction.
    let slow = unfiltered(2.0).update(at(0.0), &clear_grid(0.0, near)).expect("valid");
    assert!(slow.velocity_frd_m_s[0].abs() < 5e-3, "{:?}", slow.velocity_frd_m_s);

    // Inside the stop distance: stop.
    let mut close = clear_grid(0.0, near);
    close.regions[1][1].nearest_m = Some(1.5);
    let stop = unfiltered(speed).update(at(0.0), &close).expect("valid");
    assert_eq!(stop.health.forward_cap_m_s, Some(0.0));
    assert!((stop.velocity_frd_m_s[0] + speed).abs() < 1e-9);
}

#[test]
fn a_blocked_centre_alone_stops_forward_progress_and_sidesteps_to_the_freer_side() {
    // Table 3.1 has no row for a pole straight ahead with a clear view around it; every rule
    // fires at e^-8 and the rule base alone would barely brake.
    let mut avoider = unfiltered(5.0);
    let command = avoider.update(at(0.0), &clear_grid(0.0, blocked(&[(1, 1)]))).expect("valid");
    assert!(command.fuzzy.vy_forward > -0.1, "the rule base alone: {:?}", command.fuzzy);
    assert!(command.health.centre_blocked && !command.health.climbing);
    assert_eq!(command.velocity_frd_m_s[0], -5.0);
    // A full tie between the sides: right, by convention, at the sidestep speed.
    assert_eq!(command.health.sidestep_m_s, 1.0);
    assert!((command.velocity_frd_m_s[1] - 1.0).abs() < 1e-9 && command.velocity_frd_m_s[2].abs() < 5e-3);

    // A few near pixels on the right: left (the rule base already leans that way).
    let mut near = blocked(&[(1, 1)]);
    near[0][2] = 0.1;
    near[1][2] = 0.1;
    let left = unfiltered(5.0).update(at(0.0), &clear_grid(0.0, near)).expect("valid");
    assert!(left.velocity_frd_m_s[1] < -1.4, "{:?}", left.velocity_frd_m_s);

    // Equal loads, but the left side's nearest depth is closer: right.
    let mut tie = clear_grid(0.0, blocked(&[(1, 1)]));
    tie.regions[1][0].nearest_m = Some(6.0);
    let right = unfiltered(5.0).update(at(0.0), &tie).expect("valid");
    assert!((right.velocity_frd_m_s[1] - 1.0).abs() < 1e-9, "{:?}", right.velocity_frd_m_s);

    // Once under way the side is kept while the path stays blocked, even if the other side now
    // looks a little freer (the obstacle slides across the view); it ends when the path clears.
    let mut avoider = unfiltered(5.0);
    avoider.update(at(0.0), &clear_grid(0.0, blocked(&[(1, 1)]))).expect("valid");
    let mut right_nearer = clear_grid(0.1, blocked(&[(1, 1)]));
    right_nearer.regions[1][2].nearest_m = Some(6.0);
    let kept = avoider.update(at(0.1), &right_nearer).expect("valid");
    assert!((kept.velocity_frd_m_s[1] - 1.0).abs() < 1e-9, "kept right: {:?}", kept.velocity_frd_m_s);
    let clear = avoider.update(at(0.2), &clear_grid(0.2, [[0.0; 3]; 3])).expect("valid");
    assert_eq!(clear.health.sidestep_m_s, 0.0);
    assert!(clear.velocity_frd_m_s[1].abs() < 5e-3);
}

#[test]
fn a_thin_trunk_within_the_sidestep_distance_blocks_the_path() {
    // A few near pixels only (a thin trunk), but 3 m ahead: stop and sidestep.
    let mut near = [[0.0; 3]; 3];
    near[1][1] = 0.2;
    let mut trunk = clear_grid(0.0, near);
    trunk.regions[1][1].nearest_m = Some(3.0);
    let command = unfiltered(3.0).update(at(0.0), &trunk).expect("valid");
    assert!(command.health.centre_blocked, "{:?}", command.health);
    assert_eq!(command.velocity_frd_m_s[0], -3.0);
    assert_eq!(command.health.sidestep_m_s, 1.0);
}

#[test]
fn a_trunk_passed_out_of_view_closes_its_side_to_the_sidestep_and_limits_the_slide() {
    // Flying north past a trunk seen 45° ahead-right at 2 m; 1.4 m on it is abeam right, out
    // of view, and a pole straight ahead blocks the path with the sides tied: the sidestep goes
    // left, where by convention it would go right.
    let fly = |avoider: &mut Avoider| {
        avoider.set_pose(&nav_at(0.0, 0.0, 0.0));
        avoider.update(at(0.0), &with_sectors(clear_grid(0.0, [[0.0; 3]; 3]), &[(9, 2.0)])).expect("valid");
        avoider.set_pose(&nav_at(0.5, 1.4, 0.0));
        avoider
            .update(at(0.5), &with_sectors(clear_grid(0.5, blocked(&[(1, 1)])), &[(0, 3.0)]))
            .expect("valid")
    };
    let mut remembering = unfiltered(3.0);
    let command = fly(&mut remembering);
    assert!(remembering.remembered() >= 2, "the trunk and the pole: {}", remembering.remembered());
    assert_eq!(command.health.sidestep_m_s, -1.0, "{:?}", command.health);

    // Without the memory: right, into the trunk.
    let mut forgetting = Avoider::thesis(AvoiderParams {
        filter_time_constant_s: 0.0,
        memory_time_s: 0.0,
        ..AvoiderParams::default()
    })
    .expect("builds");
    forgetting.set_setpoint(&flying_north(0.0, 3.0)).expect("valid setpoint");
    assert_eq!(fly(&mut forgetting).health.sidestep_m_s, 1.0);

    // A pole ahead, a little on the left, so the rule base steers right; something 3 m away on
    // the left closes that side too, so the vehicle slides right with the trunk abeam right
    // 1.2 m away: the slide towards it is limited to what stops 1 m short (0.2 m of room:
    // 0.55 m/s).
    let mut avoider = unfiltered(3.0);
    avoider.set_pose(&nav_at(0.0, 0.0, 0.0));
    // Seen at 55° and 1.2 m / sin 55° = 1.465 m: 0.84 m ahead and 1.2 m to the right.
    avoider.update(at(0.0), &with_sectors(clear_grid(0.0, [[0.0; 3]; 3]), &[(11, 1.465)])).expect("valid");
    avoider.set_pose(&nav_at(0.5, 0.84, 0.0));
    let mut near = blocked(&[(1, 1)]);
    near[0][0] = 0.1;
    near[1][0] = 0.1;
    let mut grid = with_sectors(clear_grid(0.5, near), &[(0, 3.0)]);
    grid.regions[1][0].nearest_m = Some(3.0);
    let steer = avoider.update(at(0.5), &grid).expect("valid");
    assert!(steer.fuzzy.vx_right > 0.2, "the rule base steers right: {:?}", steer.fuzzy);
    assert!(steer.health.sidestep_m_s > 0.0, "{:?}", steer.health);
    assert!(steer.health.memory_limited, "{:?}", steer.velocity_frd_m_s);
    let (sin, cos) = 90f64.to_radians().sin_cos();
    let towards = (3.0 + steer.velocity_frd_m_s[0]) * cos + steer.velocity_frd_m_s[1] * sin;
    let cap = (0.36f64 + 2.0 * 2.0 * (1.2 - 1.0)).sqrt() - 0.6;
    assert!(
        towards <= cap + 0.05,
        "{towards} m/s towards the trunk, cap {cap}: {:?}",
        steer.velocity_frd_m_s
    );
}

#[test]
fn a_sidestep_boxed_in_between_two_closing_sides_climbs_until_the_path_clears() {
    // A pole straight ahead with the sides tied: sidestep right, by convention.
    let mut avoider = unfiltered(3.0);
    let pole = |t: f64, left_m: Option<f32>, right_m: Option<f32>| {
        let mut grid = clear_grid(t, blocked(&[(1, 1)]));
        grid.regions[1][0].nearest_m = left_m;
        grid.regions[1][2].nearest_m = right_m;
        grid
    };
    let first = avoider.update(at(0.0), &pole(0.0, None, None)).expect("valid");
    assert_eq!(first.health.sidestep_m_s, 1.0, "{:?}", first.health);
    // Something 3 m off on the right closes it: turn left (one turn).
    let left = avoider.update(at(0.1), &pole(0.1, None, Some(3.0))).expect("valid");
    assert_eq!(left.health.sidestep_m_s, -1.0, "{:?}", left.health);
    assert!(!left.health.climbing);
    // Then the left closes and the right is open again: turning back is being boxed in.
    let back = avoider.update(at(0.2), &pole(0.2, Some(3.0), None)).expect("valid");
    assert_eq!(back.health.sidestep_m_s, 1.0, "{:?}", back.health);
    // From the next grid on it climbs, with no sidestep, while the path stays blocked.
    for t in [0.3, 0.4, 1.0] {
        let climb = avoider.update(at(t), &pole(t, None, Some(3.0))).expect("valid");
        assert!(climb.health.climbing, "at {t} s: {:?}", climb.health);
        assert_eq!(climb.velocity_frd_m_s, [-3.0, 0.0, -1.5], "at {t} s");
    }
    // The path clears (the pole is below): the climb goes on for its 1 m margin (0.67 s).
    let clear = |t: f64| clear_grid(t, [[0.0; 3]; 3]);
    assert!(avoider.update(at(1.1), &clear(1.1)).expect("valid").health.climbing);
    assert!(avoider.update(at(1.7), &clear(1.7)).expect("valid").health.climbing);
    let over = avoider.update(at(1.8), &clear(1.8)).expect("valid");
    assert!(!over.health.climbing && over.health.sidestep_m_s == 0.0, "{:?}", over.health);

    // One turn alone is no box: a new sidestep after the path cleared starts its count afresh.
    let again = avoider.update(at(2.0), &pole(2.0, None, None)).expect("valid");
    assert_eq!(again.health.sidestep_m_s, 1.0, "{:?}", again.health);
    let turned = avoider.update(at(2.1), &pole(2.1, None, Some(3.0))).expect("valid");
    assert_eq!(turned.health.sidestep_m_s, -1.0);
    let on = avoider.update(at(2.2), &pole(2.2, None, Some(3.0))).expect("valid");
    assert!(!on.health.climbing && on.health.sidestep_m_s == -1.0, "{:?}", on.health);
}

#[test]
fn a_sidestep_that_has_slid_its_limit_with_the_path_still_blocked_climbs() {
    // A pole straight ahead with the sides tied: sidestep right, by convention, from 10 m north.
    let pole = |t: f64| clear_grid(t, blocked(&[(1, 1)]));
    let mut avoider = unfiltered(3.0);
    let slide = |avoider: &mut Avoider, t: f64, east_m: f64| {
        avoider.set_pose(&nav_at(t, 10.0, east_m));
        avoider.update(at(t), &pole(t)).expect("valid").health
    };
    let max_m = AvoiderParams::default().sidestep_max_m;
    for east_m in [0.0, 1.0, 2.0, max_m - 0.1] {
        let health = slide(&mut avoider, east_m, east_m);
        assert!(!health.climbing && health.sidestep_m_s == 1.0, "at {east_m} m: {health:?}");
    }
    // `sidestep_max_m` from where it began: boxed in from the next grid on.
    slide(&mut avoider, max_m, max_m);
    let climbing = slide(&mut avoider, max_m + 0.1, max_m + 0.1);
    assert!(climbing.climbing && climbing.sidestep_m_s == 0.0, "{climbing:?}");

    // Without the estimator's poses the slide is not measured, so it is not limited...
    let mut blind = unfiltered(3.0);
    for t in [0.0, 3.0, 6.0] {
        let health = blind.update(at(t), &pole(t)).expect("valid").health;
        assert!(!health.climbing && health.sidestep_m_s == 1.0, "at {t} s: {health:?}");
    }
    // ...until they come: it is measured from the first.
    for (t, east_m) in [(7.0, 0.0), (8.0, max_m - 0.1), (9.0, max_m)] {
        let health = slide(&mut blind, t, east_m);
        assert!(!health.climbing && health.sidestep_m_s == 1.0, "at {east_m} m: {health:?}");
    }
    assert!(slide(&mut blind, 10.0, max_m + 0.1).climbing);

    // The limit reached on the grid where the side under way closes (the sidestep turns to the
    // other side) climbs from the next grid all the same.
    let mut turning = unfiltered(3.0);
    for east_m in [0.0, 1.0, 2.0] {
        slide(&mut turning, east_m, east_m);
    }
    turning.set_pose(&nav_at(max_m, 10.0, max_m));
    let mut closing = pole(max_m);
    closing.regions[1][2].nearest_m = Some(1.0);
    let turned = turning.update(at(max_m), &closing).expect("valid").health;
    assert!(!turned.climbing && turned.sidestep_m_s == -1.0, "turned left: {turned:?}");
    let climbing = slide(&mut turning, max_m + 0.1, max_m + 0.1);
    assert!(climbing.climbing, "{climbing:?}");
}

#[test]
fn a_grid_captured_where_the_poses_stopped_is_not_placed_in_the_memory() {
    let mut avoider = unfiltered(3.0);
    avoider.set_pose(&nav_at(0.0, 0.0, 0.0));
    avoider.update(at(0.0), &with_sectors(clear_grid(0.0, [[0.0; 3]; 3]), &[(6, 5.0)])).expect("valid");
    let remembered = avoider.remembered();
    assert!(remembered > 0);
    // Half a second on without a pose: a new return 30° right is not placed from the frozen
    // pose, and what the memory held stays.
    let second = with_sectors(clear_grid(0.5, [[0.0; 3]; 3]), &[(6, 5.0), (-6, 5.0)]);
    avoider.update(at(0.5), &second).expect("valid");
    assert_eq!(avoider.remembered(), remembered);
    // The poses come back: it is.
    avoider.set_pose(&nav_at(0.6, 0.0, 0.0));
    let third = with_sectors(clear_grid(0.6, [[0.0; 3]; 3]), &[(6, 5.0), (-6, 5.0)]);
    avoider.update(at(0.6), &third).expect("valid");
    assert!(avoider.remembered() > remembered, "{} points", avoider.remembered());
}

#[test]
fn sectors_without_a_usable_angle_are_refused() {
    for (increment, offset) in [(f32::NAN, 0.0), (0.0, 0.0), (-5.0, 0.0), (5.0, f32::INFINITY)] {
        let mut grid = clear_grid(0.0, [[0.0; 3]; 3]);
        (grid.sectors.increment_deg, grid.sectors.angle_offset_deg) = (increment, offset);
        let refused = unfiltered(3.0).update(at(0.0), &grid);
        assert!(
            matches!(refused, Err(kestrel_avoider::avoidance::error::GridError::BadSectors { .. })),
            "{increment}°, offset {offset}°: {refused:?}"
        );
    }
}

#[test]
fn a_whole_blocked_centre_column_sidesteps_instead_of_climbing_or_diving() {
    // A tall trunk straight ahead fills up, centre and down: the rule base's vertical answer
    // (rows 5 and 6 of table 3.1 fire against each other) is no way over or under.
    let command =
        unfiltered(3.0).update(at(0.0), &clear_grid(0.0, blocked(&[(0, 1), (1, 1), (2, 1)]))).expect("valid");
    assert!(!command.health.climbing);
    assert_eq!(command.velocity_frd_m_s[2], 0.0, "{:?}", command.velocity_frd_m_s);
    assert!((command.velocity_frd_m_s[1].abs() - 1.0).abs() < 1e-9, "{:?}", command.velocity_frd_m_s);
}

#[test]
fn the_low_pass_step_response_follows_its_time_constant() {
    let tau = 0.5;
    let dt = 0.05;
    let mut avoider =
        // The forward-speed cap acts after the filter; braking this hard it never binds here.
        Avoider::thesis(AvoiderParams {
            filter_time_constant_s: tau,
            stop_distance_m: 0.0,
            brake_decel_m_s2: 1e6,
            ..AvoiderParams::default()
        })
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

#[test]
fn the_clear_range_is_what_the_view_vouches_for_ahead_and_why() {
    use kestrel_proto::messages::{ClearRange, ClearRangeReason};
    let range = |near: [[f32; 3]; 3], invalid: [[f32; 3]; 3]| -> ClearRange {
        unfiltered(3.0).update(at(0.0), &grid(0.0, near, invalid)).expect("valid").clear_range
    };
    let reason = |r: ClearRange| (r.range_m, r.reason);
    // Everything valid, nothing near: the far end of the grid's stereo range (20 m; the scene's
    // centre depth is 20 m too, which is no nearer).
    assert_eq!(reason(range([[0.0; 3]; 3], [[0.0; 3]; 3])), (20.0, ClearRangeReason::StereoRange));
    // A depth 4.5 m ahead in the centre.
    let mut near = [[0.0; 3]; 3];
    near[1][1] = 0.1;
    assert_eq!(reason(range(near, [[0.0; 3]; 3])), (4.5, ClearRangeReason::Obstacle));
    // The sky case of the test above: the centre mostly invalid, the ground below it seen.
    let mut invalid = [[0.05; 3]; 3];
    invalid[0] = [0.99; 3];
    invalid[1][1] = 0.9;
    invalid[2][1] = 0.3;
    assert_eq!(reason(range([[0.0; 3]; 3], invalid)), (4.0, ClearRangeReason::Untextured));
    // ... with a depth nearer than the conservative 4 m in the centre: the depth.
    near[1][1] = 0.6;
    assert_eq!(reason(range(near, invalid)), (2.0, ClearRangeReason::Obstacle));
    // A thin pole straight ahead, too few pixels for the centre's nearest depth but in the
    // sectors: 6.5 m in sector 0 against the centre's 20 m. Sector 2 (7.5°..12.5°) 5 m out can
    // lie 0.65 m off the nose, inside the 0.75 m corridor; 6 m out (0.78 m) it cannot.
    let clear = || grid(0.0, [[0.0; 3]; 3], [[0.0; 3]; 3]);
    let in_path = |readings: &[(i32, f64)]| {
        unfiltered(3.0).update(at(0.0), &with_sectors(clear(), readings)).expect("valid").clear_range
    };
    assert_eq!(reason(in_path(&[(0, 6.5)])), (6.5, ClearRangeReason::ObstacleInPath));
    let beside = in_path(&[(0, 6.5), (2, 5.0)]);
    assert_eq!(beside.reason, ClearRangeReason::ObstacleInPath);
    assert!((beside.range_m - 5.0 * 7.5f64.to_radians().cos()).abs() < 1e-9, "{beside:?}");
    assert_eq!(reason(in_path(&[(0, 6.5), (2, 6.0)])), (6.5, ClearRangeReason::ObstacleInPath));
    // The textureless wall: nothing is vouched for.
    invalid[2][1] = 0.95;
    assert_eq!(reason(range([[0.0; 3]; 3], invalid)), (0.0, ClearRangeReason::UnknownAhead));
    // No grid within the age limit: nothing either.
    let mut avoider = unfiltered(3.0);
    avoider.update(at(0.0), &clear_grid(0.0, [[0.0; 3]; 3])).expect("valid");
    let stale = avoider.check(at(1.0)).expect("stale");
    assert_eq!(reason(stale.clear_range), (0.0, ClearRangeReason::Stale));
}

#[test]
fn above_the_ground_match_height_an_invalid_view_ahead_is_no_wall_but_vouches_only_for_the_unknown_range() {
    use kestrel_proto::messages::{ClearRangeReason, NavState};
    let speed = 4.0;
    // Every region mostly invalid: a textureless wall filling the view, or sky and ground too
    // far for a disparity.
    let invalid = [[0.95; 3]; 3];
    let at_height = |height_m: f64| {
        let mut avoider = unfiltered(speed);
        let pose = NavState::exact(at(0.0), [1.0, 0.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0, 0.0, -height_m]);
        avoider.set_pose(&pose);
        avoider.update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid")
    };
    let limit = AvoiderParams::default().ground_match_height_m;
    // At or below the height the ground below the path would be matched: the wall, stop.
    for height_m in [5.0, limit] {
        let low = at_height(height_m);
        assert!(low.health.unknown_centre_slowdown, "{height_m} m: {:?}", low.health);
        assert!((low.velocity_frd_m_s[0] + speed).abs() < 1e-9, "{height_m} m: {:?}", low.velocity_frd_m_s);
        assert_eq!((low.clear_range.range_m, low.clear_range.reason), (0.0, ClearRangeReason::UnknownAhead));
    }
    // Above it: no slow-down from the avoider, and the conservative range for the commander's cap.
    let high = at_height(limit + 0.5);
    assert!(!high.health.unknown_centre_slowdown, "{:?}", high.health);
    assert!(high.velocity_frd_m_s.iter().all(|v| v.abs() < 5e-3), "{:?}", high.velocity_frd_m_s);
    let unknown_range_m = AvoiderParams::default().unknown_range_m;
    assert_eq!(
        (high.clear_range.range_m, high.clear_range.reason),
        (unknown_range_m, ClearRangeReason::GroundOutOfReach)
    );
    // Without a pose the height is unknown: the wall rule stands.
    let blind = unfiltered(speed).update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid");
    assert!(blind.health.unknown_centre_slowdown);
}

#[test]
fn the_ground_match_height_is_above_the_ground_a_rooftop_take_off_keeps_the_wall_check_on() {
    use kestrel_proto::messages::{NavState, RangefinderOrientation, RangefinderSample};
    let speed = 4.0;
    let invalid = [[0.95; 3]; 3];
    let limit = AvoiderParams::default().ground_match_height_m;
    // 6 m above a roof that is 10 m above the estimator's origin: 16 m above the origin.
    let fly = |home: Option<[f64; 3]>, range_m: Option<f64>| {
        let mut avoider = unfiltered(speed);
        avoider.set_pose(&NavState::exact(
            at(0.0),
            [1.0, 0.0, 0.0, 0.0],
            [0.0; 3],
            [0.0; 3],
            [0.0, 0.0, -16.0],
        ));
        avoider.set_home(home);
        if let Some(d) = range_m {
            avoider.set_range(&RangefinderSample {
                time: at(0.0),
                orientation: RangefinderOrientation::Down,
                distance_m: Some(d),
                min_range_m: 0.1,
                max_range_m: 40.0,
            });
        }
        avoider.update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect("valid")
    };
    assert!((6.0..16.0).contains(&limit), "the case straddles AVOID_GND_HGT ({limit} m)");
    // Measured from the origin (no home heard), the view would pass as open sky.
    assert!(!fly(None, None).health.unknown_centre_slowdown);
    // From home on the roof: 6 m up, the invalid view ahead is a wall: stop.
    let roof = fly(Some([0.0, 0.0, -10.0]), None);
    assert!(roof.health.unknown_centre_slowdown, "{:?}", roof.health);
    assert!((roof.velocity_frd_m_s[0] + speed).abs() < 1e-9, "{:?}", roof.velocity_frd_m_s);
    // The downward rangefinder wins over home: over a hillside rising under the vehicle...
    assert!(fly(Some([0.0; 3]), Some(5.0)).health.unknown_centre_slowdown);
    // ...and off a cliff edge, where home's height says nothing of the ground below.
    assert!(!fly(Some([0.0, 0.0, -10.0]), Some(30.0)).health.unknown_centre_slowdown);
}
