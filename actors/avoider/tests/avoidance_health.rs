//! Bad and old input: stale grids are ignored and reported, broken grids and setpoints are
//! refused and counted, bad parameters and rule bases are named at build.

mod scenes;

use kestrel_avoider::{Avoider, AvoiderError, AvoiderParams, GridError, SetpointError, fll, thesis_engine};
use kestrel_proto::messages::{AVOIDER_RULES, SetpointTarget};
use scenes::{at, blocked, clear_grid, flying_north, grid};

fn avoider(speed_m_s: f64) -> Avoider {
    let mut avoider = Avoider::thesis(AvoiderParams::default()).expect("builds");
    avoider.set_setpoint(&flying_north(0.0, speed_m_s)).expect("valid setpoint");
    avoider
}

#[test]
fn a_stale_grid_is_ignored_the_correction_brakes_and_decays_and_it_is_reported() {
    let mut avoider = avoider(4.0);
    let fresh = avoider.update(at(0.0), &clear_grid(0.0, blocked(&[(1, 0), (1, 1)]))).expect("valid");
    assert!(fresh.velocity_frd_m_s[1] > 1.0, "steering right: {:?}", fresh.velocity_frd_m_s);
    assert_eq!(avoider.check(at(0.3)), None, "within the 0.5 s limit nothing is published");

    let stale = avoider.check(at(0.6)).expect("stale");
    assert!(stale.health.stale);
    assert_eq!(stale.health.grid_age_s, Some(0.6));
    assert_eq!((stale.grid_time, stale.frame_sequence, stale.time), (Some(at(0.0)), Some(0), at(0.6)));
    assert_eq!((stale.near_shares, stale.rule_activations), ([[0.0; 3]; 3], [0.0; AVOIDER_RULES]));
    // Through the filter (τ = 0.3 s) from the last correction towards [−4, 0, 0].
    let decay = (-0.6f64 / 0.3).exp();
    let expected_right = fresh.velocity_frd_m_s[1] * decay;
    assert!((stale.velocity_frd_m_s[1] - expected_right).abs() < 1e-9, "{:?}", stale.velocity_frd_m_s);
    let settled = (1..=30).map(|k| avoider.check(at(0.6 + 0.1 * f64::from(k))).expect("stale")).last();
    let settled = settled.expect("commands");
    assert!((settled.velocity_frd_m_s[0] + 4.0).abs() < 1e-3, "{:?}", settled.velocity_frd_m_s);
    assert!(settled.velocity_frd_m_s[1].abs() < 1e-3 && settled.velocity_frd_m_s[2].abs() < 1e-3);

    let back = avoider.update(at(4.0), &clear_grid(4.0, [[0.0; 3]; 3])).expect("valid");
    assert!(!back.health.stale && back.health.grid_age_s == Some(0.0));
    assert_eq!(avoider.check(at(4.1)), None);
}

#[test]
fn before_the_first_grid_the_view_is_stale() {
    let mut avoider = avoider(2.0);
    let command = avoider.check(at(0.1)).expect("stale");
    assert!(command.health.stale && command.health.grid_age_s.is_none() && command.grid_time.is_none());
    assert_eq!(command.velocity_frd_m_s, [-2.0, 0.0, 0.0], "the first update seeds the filter");
}

#[test]
fn a_climb_ends_when_the_view_goes_stale() {
    let mut avoider = avoider(2.0);
    let all = [[1.0; 3]; 3];
    assert!(avoider.update(at(0.0), &clear_grid(0.0, all)).expect("valid").health.climbing);
    let stale = avoider.check(at(1.0)).expect("stale");
    assert!(!stale.health.climbing);
    assert!(stale.velocity_frd_m_s[2] > -1.5 * 0.1, "climb decays: {:?}", stale.velocity_frd_m_s);
}

#[test]
fn a_grid_too_old_on_arrival_is_refused_and_counted() {
    let mut avoider = avoider(2.0);
    let err = avoider.update(at(0.7), &clear_grid(0.1, [[0.0; 3]; 3])).expect_err("too old");
    assert!(matches!(err, GridError::TooOld { .. }), "{err}");
    assert_eq!(err.to_string(), "depth grid is 0.600 s old on arrival (limit 0.5 s)");
    let report = avoider.check(at(0.7)).expect("still stale");
    assert_eq!(report.health.grids_rejected, 1);
}

#[test]
fn non_finite_or_out_of_range_shares_are_refused_and_counted() {
    let mut avoider = avoider(2.0);
    let mut near = [[0.0; 3]; 3];
    near[2][1] = f32::NAN;
    let err = avoider.update(at(0.0), &clear_grid(0.0, near)).expect_err("NaN");
    assert!(err.to_string().starts_with("depth grid region [2][1]: near_share = NaN"), "{err}");
    let mut invalid = [[0.0; 3]; 3];
    invalid[0][2] = 1.5;
    let err = avoider.update(at(0.0), &grid(0.0, [[0.0; 3]; 3], invalid)).expect_err("1.5");
    assert_eq!(err, GridError::BadShare { row: 0, col: 2, field: "invalid_share", value: 1.5 });
    let near_inf = [[f32::INFINITY; 3]; 3];
    assert!(avoider.update(at(0.0), &clear_grid(0.0, near_inf)).is_err());
    let good = avoider.update(at(0.0), &clear_grid(0.0, [[0.0; 3]; 3])).expect("valid");
    assert_eq!(good.health.grids_rejected, 3);
}

#[test]
fn a_grid_not_newer_than_the_last_is_refused() {
    let mut avoider = avoider(2.0);
    avoider.update(at(0.2), &clear_grid(0.2, [[0.0; 3]; 3])).expect("valid");
    let err = avoider.update(at(0.3), &clear_grid(0.2, [[0.0; 3]; 3])).expect_err("repeat");
    assert!(matches!(err, GridError::OutOfOrder { .. }), "{err}");
    assert!(avoider.update(at(0.3), &clear_grid(0.1, [[0.0; 3]; 3])).is_err());
    assert_eq!(avoider.grids_rejected(), 2);
}

#[test]
fn a_nan_setpoint_is_refused_counted_and_the_previous_speed_kept() {
    let mut avoider = avoider(2.0);
    let mut bad = flying_north(0.1, f64::NAN);
    let err = avoider.set_setpoint(&bad).expect_err("NaN");
    assert!(matches!(err, SetpointError::NotFinite { axis: "north", value } if value.is_nan()), "{err}");
    if let SetpointTarget::Trajectory(t) = &mut bad.target {
        t.velocity_ned_m_s = [Some(1.0), Some(f64::INFINITY), None];
    }
    assert!(avoider.set_setpoint(&bad).is_err());
    let command = avoider.update(at(0.0), &clear_grid(0.0, [[0.0; 3]; 3])).expect("valid");
    assert_eq!((command.desired_speed_m_s, command.speed_input), (2.0, 0.4));
    assert_eq!(command.health.setpoints_rejected, 2);
}

#[test]
fn desired_speed_is_the_trajectorys_horizontal_speed() {
    let mut avoider = avoider(0.0);
    let mut setpoint = flying_north(0.0, 3.0);
    if let SetpointTarget::Trajectory(t) = &mut setpoint.target {
        t.velocity_ned_m_s = [Some(3.0), Some(-4.0), Some(-2.0)];
    }
    avoider.set_setpoint(&setpoint).expect("valid");
    let command = avoider.update(at(0.0), &clear_grid(0.0, [[0.0; 3]; 3])).expect("valid");
    assert_eq!((command.desired_speed_m_s, command.speed_input), (5.0, 1.0));

    setpoint.armed = false;
    avoider.set_setpoint(&setpoint).expect("valid");
    let command = avoider.update(at(0.1), &clear_grid(0.1, [[0.0; 3]; 3])).expect("valid");
    assert_eq!(command.desired_speed_m_s, 0.0, "disarmed");

    setpoint.armed = true;
    setpoint.target = SetpointTarget::Rates { rates_frd_rad_s: [0.0; 3], thrust: 0.5 };
    avoider.set_setpoint(&setpoint).expect("valid");
    let command = avoider.update(at(0.2), &clear_grid(0.2, [[0.0; 3]; 3])).expect("valid");
    assert_eq!(command.desired_speed_m_s, 0.0, "the pilot flies rates");
}

#[test]
fn params_have_documented_defaults_and_bad_values_are_named() {
    let defaults: AvoiderParams = toml::from_str("").expect("all fields default");
    assert_eq!(defaults, AvoiderParams::default());
    defaults.validate().expect("defaults are valid");
    let err = toml::from_str::<AvoiderParams>("max_speed = 5.0").expect_err("unknown field");
    assert!(err.to_string().contains("unknown field `max_speed`"), "{err}");

    let cases = [
        (AvoiderParams { max_speed_m_s: 0.0, ..AvoiderParams::default() }, "max_speed_m_s = 0"),
        (
            AvoiderParams { filter_time_constant_s: -0.1, ..AvoiderParams::default() },
            "filter_time_constant_s",
        ),
        (AvoiderParams { blocked_share: f64::NAN, ..AvoiderParams::default() }, "blocked_share = NaN"),
        (AvoiderParams { climb_exit_share: 0.6, ..AvoiderParams::default() }, "at most blocked_share"),
        (AvoiderParams { max_grid_age_s: f64::INFINITY, ..AvoiderParams::default() }, "max_grid_age_s"),
    ];
    for (params, expected) in cases {
        let err = Avoider::thesis(params).expect_err("bad params");
        assert!(matches!(err, AvoiderError::Params(_)), "{err}");
        assert!(err.to_string().contains(expected), "{err} lacks {expected}");
    }
}

#[test]
fn a_rule_base_without_the_thesis_interface_is_refused() {
    let params = AvoiderParams::default;
    let renamed = kestrel_avoider::THESIS_RULE_BASE.replace("D_lu", "D_xx");
    let engine = fll::parse(&renamed, "renamed.fll").expect("still a valid rule base");
    let err = Avoider::new(engine, params()).expect_err("no D_lu");
    assert_eq!(err.to_string(), "avoider rule base 'thesis_avoider' has no input variable 'D_lu'");

    let last_rule = kestrel_avoider::THESIS_RULE_BASE.rfind("  rule:").expect("rules");
    let engine = fll::parse(&kestrel_avoider::THESIS_RULE_BASE[..last_rule], "short.fll").expect("valid");
    let err = Avoider::new(engine, params()).expect_err("17 rules");
    assert!(matches!(err, AvoiderError::RuleCount { expected: 18, got: 17, .. }), "{err}");

    let tipper = kestrel_avoider::rule_file::load(
        &std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/tipper.fll"),
    )
    .expect("loads");
    assert!(matches!(Avoider::new(tipper, params()), Err(AvoiderError::InputCount { expected: 10, .. })));
    Avoider::new(thesis_engine().expect("loads"), params()).expect("the thesis's own rule base");
}
