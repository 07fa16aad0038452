//! Forests of our own that generalise: three families of random forests, each flown
//! closed loop at 5 m/s cruise with seeds 1 to 10, each asking at least 9 of 10 seeds completed,
//! landed and without a collision: thin trunks close together, legs at several headings, and
//! round trips whose RETURN_TO_LAUNCH flies home through trees taller than the RTL altitude.
//! Legs are 50 m, short in simulated time, as the whole suite must stay inside CI's budget.
//! Each family's row of docs/src/results/avoidance.md is checked against what it flew
//! ([`avoidance_page`]; `KESTREL_UPDATE_DOCS=1` rewrites it).

mod support;
use support::{avoidance_page, forest_seeds, qgc_plan};

use forest_seeds::{Flight, Outcome, family_row, fly_seeds, set, template};

/// Seeds each family flies.
const SEEDS: std::ops::RangeInclusive<u64> = 1..=10;
/// Leg length (m) and altitude above home (m): the worlds keep their take-off and turning or
/// landing spots clear at 0 and 50 m along.
const LEG_M: f64 = 50.0;
const ALT_M: f64 = 5.0;
/// The headings of the headings family, one per seed in turn (deg).
const HEADINGS_DEG: [f64; 4] = [45.0, 135.0, 225.0, 300.0];

/// The family's verdict: at least 9 of 10 seeds clean ([`Outcome::clean`]).
fn nine_of_ten(family: &str, outcomes: &[Outcome]) {
    let good = outcomes.iter().filter(|o| o.clean).count();
    assert!(
        good * 10 >= outcomes.len() * 9,
        "{family}: {good} of {} seeds clean: {outcomes:#?}",
        outcomes.len()
    );
}

/// `template` with `seed` (and the other `[forest]` lines of `lines`) set, written into `dir`.
fn world(dir: &std::path::Path, template: &str, seed: u64, lines: &[(&str, String)]) -> std::path::PathBuf {
    let mut text = set(template, "seed", &seed.to_string());
    for (key, value) in lines {
        text = set(&text, key, value);
    }
    let path = dir.join("world.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn thin_trunks_2_5_m_apart_on_a_50_m_leg_are_flown_through_clean_for_nine_of_ten_seeds() {
    let template = template("forest-thin.toml");
    let seeds: Vec<u64> = SEEDS.collect();
    let outcomes = fly_seeds("forest-thin", &seeds, 90, |dir, seed| Flight {
        label: String::new(),
        world: world(dir, &template, seed, &[]),
        plan: qgc_plan::leg(dir, 0.0, LEG_M, ALT_M),
        lands_home: false,
    });
    nine_of_ten("forest-thin", &outcomes);
    avoidance_page::check(&[family_row("thin forest, seeds 1–10", "AUTO", &outcomes)]);
}

#[test]
fn legs_at_45_135_225_and_300_deg_through_a_forest_are_flown_clean_for_nine_of_ten_seeds() {
    let template = template("forest-headings.toml");
    let seeds: Vec<u64> = SEEDS.collect();
    let outcomes = fly_seeds("forest-headings", &seeds, 90, |dir, seed| {
        let heading_deg = HEADINGS_DEG[(seed as usize - 1) % HEADINGS_DEG.len()];
        Flight {
            label: format!("heading {heading_deg}°"),
            world: world(dir, &template, seed, &[("heading_deg", format!("{heading_deg:.1}"))]),
            plan: qgc_plan::leg(dir, heading_deg, LEG_M, ALT_M),
            lands_home: false,
        }
    });
    nine_of_ten("forest-headings", &outcomes);
    avoidance_page::check(&[family_row("forest at headings 45/135/225/300°, seeds 1–10", "AUTO", &outcomes)]);
}

#[test]
fn a_round_trip_whose_rtl_flies_home_through_trees_above_the_rtl_altitude_lands_home_clean_for_nine_of_ten_seeds()
 {
    let template = template("forest-rtl.toml");
    let seeds: Vec<u64> = SEEDS.collect();
    let outcomes = fly_seeds("forest-rtl", &seeds, 180, |dir, seed| Flight {
        label: String::new(),
        world: world(dir, &template, seed, &[]),
        plan: qgc_plan::write(
            dir,
            "out-and-rtl.plan",
            &[
                qgc_plan::Item::north(qgc_plan::TAKEOFF, 0.0, ALT_M),
                qgc_plan::Item::north(qgc_plan::WAYPOINT, LEG_M, ALT_M),
                qgc_plan::Item::north(qgc_plan::RETURN_TO_LAUNCH, 0.0, 0.0),
            ],
        ),
        lands_home: true,
    });
    nine_of_ten("forest-rtl", &outcomes);
    let scenario = "round trip, RTL home through trees above the RTL altitude, seeds 1–10";
    avoidance_page::check(&[family_row(scenario, "AUTO, RTL", &outcomes)]);
}
