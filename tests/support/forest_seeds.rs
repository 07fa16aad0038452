//! A forest world flown once per seed (at least 9 of 10 seeds clean), two flights at a
//! time (the machine has 2 cores), with a `figure:` line per seed. Shared by
//! tests/flight_avoidance.rs (the 100 m forest) and tests/flight_forest_families.rs (thin trunks, legs
//! at several headings, round trips ending in RTL).

use std::path::{Path, PathBuf};

use serde_json::Value;

use super::avoidance_flight::fly;
use super::avoidance_page::time_cell;
use super::flights::{clearance_m, collisions, repo, scratch, sim_forest_graph};

/// One seed's flight, as its setup wrote it.
pub struct Flight {
    /// What sets this flight apart besides its seed (a heading), for its `figure:` line.
    pub label: String,
    pub world: PathBuf,
    pub plan: PathBuf,
    /// The plan ends in RETURN_TO_LAUNCH: a clean flight also lands within
    /// [`HOME_LANDING_M`] of home.
    pub lands_home: bool,
}

/// How near home an RTL lands (m), in the forests and past the lone tree of tests/flight_avoidance.rs.
pub const HOME_LANDING_M: f64 = 2.0;

/// What one seed's flight report says.
#[derive(Debug)]
pub struct Outcome {
    pub seed: u64,
    pub completed: bool,
    pub collisions: u64,
    pub min_clearance_m: f64,
    /// Simulated flight time (s).
    pub time_s: f64,
    pub landed: bool,
    /// Horizontal distance of the landing spot from home (m).
    pub landed_from_home_m: f64,
    /// The plan ended in RETURN_TO_LAUNCH ([`Flight::lands_home`]).
    pub lands_home: bool,
    /// Completed, landed (at home after an RTL) and never touched a tree: what the issue counts
    /// as clean.
    pub clean: bool,
}

/// The text of `config/worlds/{name}`, which forest tests fill in per seed with [`set`].
pub fn template(name: &str) -> String {
    std::fs::read_to_string(repo().join("config/worlds").join(name)).unwrap()
}

/// `world` with its line `key = …` (one of the `[forest]` table's) replaced by `key = value`;
/// panics unless there is exactly one such line, so that a changed template cannot go unset.
pub fn set(world: &str, key: &str, value: &str) -> String {
    let prefix = format!("{key} = ");
    let lines: Vec<&str> = world.lines().collect();
    let at: Vec<usize> = (0..lines.len()).filter(|&i| lines[i].starts_with(&prefix)).collect();
    assert_eq!(at.len(), 1, "the world sets `{key}` on one line: {world}");
    let mut out: Vec<String> = lines.iter().map(|l| (*l).to_owned()).collect();
    out[at[0]] = format!("{prefix}{value}");
    out.join("\n") + "\n"
}

/// Flies each of `seeds` for at most `duration_s`, the world and plan of each written by
/// `setup(dir, seed)` into a scratch directory of the seed's own; prints a `figure:` line per
/// seed and returns their outcomes in seed order. A seed that is not clean keeps its directory,
/// with the graph beside the world, and prints the `kestrel run` that flies it again (lockstep:
/// the same flight) with a recording for `kestrel report`.
pub fn fly_seeds<F>(family: &str, seeds: &[u64], duration_s: u32, setup: F) -> Vec<Outcome>
where
    F: Fn(&Path, u64) -> Flight + Sync,
{
    let dir = scratch("avoid", &format!("{family}-worlds"));
    let setup = &setup;
    let dir_ref = &dir;
    let flown: Vec<(Flight, Outcome)> = seeds
        .chunks(2)
        .flat_map(|pair| {
            std::thread::scope(|scope| {
                let flights: Vec<_> = pair
                    .iter()
                    .map(|&seed| {
                        scope.spawn(move || {
                            let seed_dir = dir_ref.join(format!("seed-{seed}"));
                            std::fs::create_dir_all(&seed_dir).unwrap();
                            let flight = setup(&seed_dir, seed);
                            let name = format!("{family}-{seed}-5ms");
                            let plan = flight.plan.display().to_string();
                            let report = fly(&name, &flight.world, &plan, duration_s);
                            let outcome = outcome(seed, &report, flight.lands_home);
                            (flight, outcome)
                        })
                    })
                    .collect();
                flights.into_iter().map(|f| f.join().expect("flight thread")).collect::<Vec<_>>()
            })
        })
        .collect();
    for (flight, o) in &flown {
        let label = if flight.label.is_empty() { String::new() } else { format!(" ({})", flight.label) };
        println!(
            "figure: {family} seed {}{label} at 5 m/s: completed {}, collisions {}, min clearance {:.2} m, {:.1} s, landed {} {:.1} m from home",
            o.seed, o.completed, o.collisions, o.min_clearance_m, o.time_s, o.landed, o.landed_from_home_m
        );
    }
    for (flight, o) in &flown {
        let seed_dir = flight.world.parent().expect("the world is in its seed's directory");
        if o.clean {
            let _ = std::fs::remove_dir_all(seed_dir);
            continue;
        }
        let graph = seed_dir.join("graph.toml");
        std::fs::write(&graph, sim_forest_graph(&flight.world)).unwrap();
        println!(
            "not clean, again from the repository: kestrel run --speedup 0 --config {} --mission {} --auto --exit-on-land --duration {duration_s} --record {}",
            graph.display(),
            flight.plan.display(),
            seed_dir.join("flight.mcap").display(),
        );
    }
    // Gone unless a seed's directory was kept.
    let _ = std::fs::remove_dir(&dir);
    flown.into_iter().map(|(_, o)| o).collect()
}

fn outcome(seed: u64, report: &Value, lands_home: bool) -> Outcome {
    let flight = &report["flight"];
    let completed = report["mission"]["completed"].as_bool().expect("mission.completed");
    let landed = flight["landed"].as_bool().unwrap_or(false);
    let landed_from_home_m = flight["landing_distance_from_home_m"].as_f64().unwrap_or(f64::NAN);
    let collisions = collisions(report);
    let at_home = !lands_home || landed_from_home_m < HOME_LANDING_M;
    Outcome {
        seed,
        completed,
        collisions,
        min_clearance_m: clearance_m(report),
        time_s: flight["duration_s"].as_f64().unwrap_or(f64::NAN),
        landed,
        landed_from_home_m,
        lands_home,
        clean: completed && landed && at_home && collisions == 0,
    }
}

/// The avoidance page's row of each seed: `| {scenario} {seed} | AUTO | yes | 0 | 1.69 | 91.8 |`.
pub fn seed_rows(scenario: &str, outcomes: &[Outcome]) -> Vec<String> {
    outcomes
        .iter()
        .map(|o| {
            format!(
                "| {scenario} {} | AUTO | {} | {} | {:.2} | {} |",
                o.seed,
                if o.completed { "yes" } else { "no" },
                o.collisions,
                o.min_clearance_m,
                time_cell(o.time_s, o.landed)
            )
        })
        .collect()
}

/// The avoidance page's row of a family of seeds: how many were clean and what went wrong with
/// the others, where an RTL landed, the collisions of all, the least clearance of all with each
/// seed's in order, and the shortest and the longest flight (s).
pub fn family_row(scenario: &str, mode: &str, outcomes: &[Outcome]) -> String {
    let clean = outcomes.iter().filter(|o| o.clean).count();
    let mut completed = format!("{clean} of {}", outcomes.len());
    let unclean: Vec<String> = outcomes
        .iter()
        .filter(|o| !o.clean)
        .map(|o| {
            let mut what = Vec::new();
            if !o.completed {
                what.push("not completed".to_owned());
            }
            if o.collisions > 0 {
                what.push(format!("{} collision{}", o.collisions, if o.collisions == 1 { "" } else { "s" }));
            }
            if !o.landed {
                what.push("not landed".to_owned());
            } else if o.lands_home && o.landed_from_home_m >= HOME_LANDING_M {
                what.push(format!("landed {:.1} m from home", o.landed_from_home_m));
            }
            format!("seed {}: {}", o.seed, what.join(", "))
        })
        .collect();
    let range = |values: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
        format!("{lo:.1}–{hi:.1}")
    };
    if outcomes.iter().any(|o| o.lands_home) {
        let from_home = range(&mut outcomes.iter().filter(|o| o.landed).map(|o| o.landed_from_home_m));
        completed.push_str(&format!(", landed {from_home} m from home"));
    }
    if !unclean.is_empty() {
        completed.push_str(&format!(" ({})", unclean.join("; ")));
    }
    let collisions: u64 = outcomes.iter().map(|o| o.collisions).sum();
    let least = outcomes.iter().map(|o| o.min_clearance_m).fold(f64::INFINITY, f64::min);
    let each: Vec<String> = outcomes.iter().map(|o| format!("{:.2}", o.min_clearance_m)).collect();
    format!(
        "| {scenario} | {mode} | {completed} | {collisions} | {least:.2} ({}) | {} |",
        each.join(", "),
        range(&mut outcomes.iter().map(|o| o.time_s))
    )
}
