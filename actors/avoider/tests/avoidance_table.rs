//! The avoider's command in body FRD follows thesis table 3.1: with the centre blocked, an
//! obstacle in each off-centre region gives the table's signs once the thesis's axes (x right,
//! y forward, z up) are mapped to FRD; left and right mirror; nothing near asks for nothing.

mod scenes;

use kestrel_avoider::{Avoider, AvoiderParams};
use kestrel_proto::messages::{AvoidanceCommand, DepthGrid};
use proptest::prelude::*;
use scenes::{at, blocked, clear_grid, flying_north, grid};

/// Unfiltered, so each command is the target for its own grid; without the sidestep, whose
/// fixed choice on a tie (right) is the one thing that does not mirror (it has its own tests).
fn avoider() -> Avoider {
    Avoider::thesis(AvoiderParams {
        filter_time_constant_s: 0.0,
        sidestep_speed_m_s: 0.0,
        ..AvoiderParams::default()
    })
    .expect("builds")
}

/// A blocked region `[row][column]`, its thesis name, and the signs table 3.1 gives in FRD
/// (forward, right, down).
type Row = ((usize, usize), &'static str, i8, i8, i8);

/// Table 3.1 rows 2–9 and 11–18 (last row corrected) in FRD: forward = thesis Vy,
/// right = Vx, down = −Vz.
const TABLE_FRD: [Row; 8] = [
    ((0, 0), "D_lu", -1, 1, 1),
    ((1, 0), "D_lc", -1, 1, 0),
    ((2, 0), "D_ld", -1, 1, -1),
    ((0, 1), "D_cu", -1, 0, 1),
    ((2, 1), "D_cd", -1, 0, -1),
    ((0, 2), "D_ru", -1, -1, 1),
    ((1, 2), "D_rc", -1, -1, 0),
    ((2, 2), "D_rd", -1, -1, -1),
];

#[test]
fn each_off_centre_obstacle_with_the_centre_blocked_gives_the_tables_signs_in_frd() {
    // V_in Low (hovering) and High (the maximum, 5 m/s).
    for speed_m_s in [0.0, 5.0] {
        for (cell, name, forward, right, down) in TABLE_FRD {
            let mut avoider = avoider();
            avoider.set_setpoint(&flying_north(0.0, speed_m_s)).expect("valid setpoint");
            let command = avoider.update(at(0.0), &clear_grid(0.0, blocked(&[(1, 1), cell]))).expect("valid");
            let v = command.velocity_frd_m_s;
            for (axis, value, sign) in
                [("forward", v[0], forward), ("right", v[1], right), ("down", v[2], down)]
            {
                let ok = match sign {
                    // 1% of the maximum speed.
                    0 => value.abs() < 0.05,
                    // At least a small correction (SN/SP centres on ±0.5 of the maximum).
                    s => value * f64::from(s) > 1.5,
                };
                assert!(ok, "{name} blocked at {speed_m_s} m/s: {axis} = {value} m/s, table says {sign:+}");
            }
            assert!(
                command.health.centre_blocked && !command.health.climbing,
                "{name}: {:?}",
                command.health
            );
        }
    }
}

#[test]
fn large_corrections_at_high_speed_and_small_at_low_speed() {
    for (cell, name, ..) in TABLE_FRD.iter().filter(|row| row.3 != 0) {
        let lateral = |speed_m_s: f64| {
            let mut avoider = avoider();
            avoider.set_setpoint(&flying_north(0.0, speed_m_s)).expect("valid setpoint");
            let command =
                avoider.update(at(0.0), &clear_grid(0.0, blocked(&[(1, 1), *cell]))).expect("valid");
            command.velocity_frd_m_s[1].abs()
        };
        let (slow, fast) = (lateral(0.0), lateral(5.0));
        assert!(fast > slow + 1.0, "{name}: LP/LN ({fast} m/s) beyond SP/SN ({slow} m/s)");
    }
}

#[test]
fn nothing_near_asks_for_no_correction() {
    // Up to 7.5 m/s, the fastest from which the forward-speed cap lets the vehicle stop short
    // of a depth at the 20 m end of the stereo range.
    for speed_m_s in [0.0, 1.0, 2.5, 4.0, 5.0, 7.5] {
        let mut avoider = avoider();
        avoider.set_setpoint(&flying_north(0.0, speed_m_s)).expect("valid setpoint");
        let command = avoider.update(at(0.0), &clear_grid(0.0, [[0.0; 3]; 3])).expect("valid");
        let v = command.velocity_frd_m_s;
        // 0.1% of the maximum speed: the Gaussian terms never reach zero, so the rules that want
        // a correction still fire at e^-8 of their strength.
        assert!(v.iter().all(|c| c.abs() < 5e-3), "{speed_m_s} m/s: {v:?}");
        assert!(
            !command.health.centre_blocked
                && !command.health.climbing
                && !command.health.unknown_centre_slowdown
        );
    }
}

/// The same scene seen in a mirror: left and right columns swap.
fn mirrored(grid: &DepthGrid) -> DepthGrid {
    let mut m = grid.clone();
    for row in &mut m.regions {
        row.swap(0, 2);
    }
    m
}

fn assert_mirrored(a: &AvoidanceCommand, b: &AvoidanceCommand) -> Result<(), TestCaseError> {
    let (va, vb) = (a.velocity_frd_m_s, b.velocity_frd_m_s);
    prop_assert!((va[0] - vb[0]).abs() < 1e-9, "forward {} vs mirrored {}", va[0], vb[0]);
    prop_assert!((va[1] + vb[1]).abs() < 1e-9, "right {} vs mirrored {}", va[1], vb[1]);
    prop_assert!((va[2] - vb[2]).abs() < 1e-9, "down {} vs mirrored {}", va[2], vb[2]);
    prop_assert!((a.fuzzy.vx_right + b.fuzzy.vx_right).abs() < 1e-9);
    prop_assert!((a.fuzzy.vy_forward - b.fuzzy.vy_forward).abs() < 1e-9);
    prop_assert!((a.fuzzy.vz_up - b.fuzzy.vz_up).abs() < 1e-9);
    let mut unknown = a.health.unknown_regions;
    for row in &mut unknown {
        row.swap(0, 2);
    }
    prop_assert_eq!(unknown, b.health.unknown_regions);
    prop_assert_eq!(
        (a.health.centre_blocked, a.health.climbing, a.health.unknown_centre_slowdown),
        (b.health.centre_blocked, b.health.climbing, b.health.unknown_centre_slowdown)
    );
    Ok(())
}

fn shares() -> impl Strategy<Value = [[f32; 3]; 3]> {
    prop::array::uniform3(prop::array::uniform3(prop_oneof![Just(0.0f32), Just(1.0f32), 0.0f32..=1.0]))
}

proptest! {
    /// Every output mirrors over a sequence of frames, through the low-pass, the climb latch
    /// and the unknown-region handling.
    #[test]
    fn left_and_right_mirror(
        frames in prop::collection::vec((shares(), shares()), 1..6),
        speed_m_s in 0.0f64..7.0,
    ) {
        let params = AvoiderParams { sidestep_speed_m_s: 0.0, ..AvoiderParams::default() };
        let mut plain = Avoider::thesis(params.clone()).expect("builds");
        let mut mirror = Avoider::thesis(params).expect("builds");
        for avoider in [&mut plain, &mut mirror] {
            avoider.set_setpoint(&flying_north(0.0, speed_m_s)).expect("valid setpoint");
        }
        for (k, (near, invalid)) in frames.into_iter().enumerate() {
            let t = k as f64 * 0.066;
            let g = grid(t, near, invalid);
            let a = plain.update(at(t), &g).expect("valid");
            let b = mirror.update(at(t), &mirrored(&g)).expect("valid");
            assert_mirrored(&a, &b)?;
        }
    }
}
