//! Agreement with an independent implementation: pyfuzzylite 8 (from PyPI, in the repo's
//! `.venv`, made by `scripts/python-env.sh`) evaluates the same FLL files on the same seeded
//! random inputs through `scripts/fuzzy_reference.py`; every output must agree to 1e-4 of its
//! variable's range.

mod common;

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use common::{SplitMix64, data, repo_root};
use kestrel_avoider::{Engine, rule_file};

const ROWS: usize = 2000;
const TOLERANCE: f64 = 1e-4;

/// Inputs: half uniform over each range (a tenth beyond it for range-locked inputs, to
/// exercise the lock), half drawn near the ends of the range, where rule bases like the
/// thesis's decide (region empty / blocked).
fn random_inputs(engine: &Engine, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = SplitMix64::new(seed);
    (0..ROWS)
        .map(|row| {
            engine
                .inputs()
                .iter()
                .map(|v| {
                    let span = v.max - v.min;
                    if row % 2 == 0 {
                        let margin = if v.lock_range { 0.1 * span } else { 0.0 };
                        rng.uniform(v.min - margin, v.max + margin)
                    } else if rng.unit() < 0.5 {
                        v.min + 0.15 * span * rng.unit()
                    } else {
                        v.max - 0.15 * span * rng.unit()
                    }
                })
                .collect()
        })
        .collect()
}

/// Runs pyfuzzylite on `inputs`; one row of outputs per input row, in the engine's order.
fn reference(fll: &Path, engine: &Engine, inputs: &[Vec<f64>], tag: &str) -> Vec<Vec<f64>> {
    let python = repo_root().join(".venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run scripts/python-env.sh to create the Python reference environment",
        python.display()
    );
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let in_csv = dir.join(format!("fuzzy_reference_{tag}_in.csv"));
    let out_csv = dir.join(format!("fuzzy_reference_{tag}_out.csv"));
    let mut text = engine.inputs().iter().map(|v| v.name.as_str()).collect::<Vec<_>>().join(",");
    text.push('\n');
    for row in inputs {
        let cells: Vec<String> = row.iter().map(|x| format!("{x:e}")).collect();
        writeln!(text, "{}", cells.join(",")).expect("writing to a String cannot fail");
    }
    std::fs::write(&in_csv, text).expect("write the input CSV");
    let status = Command::new(&python)
        .arg(repo_root().join("scripts/fuzzy_reference.py"))
        .arg(fll)
        .arg(&in_csv)
        .arg(&out_csv)
        .status()
        .expect("run scripts/fuzzy_reference.py");
    assert!(status.success(), "fuzzy_reference.py failed: {status}");
    let out = std::fs::read_to_string(&out_csv).expect("read the output CSV");
    let mut lines = out.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let names: Vec<&str> = engine.outputs().iter().map(|v| v.name.as_str()).collect();
    assert_eq!(header, names, "pyfuzzylite's outputs differ from ours");
    lines
        .map(|line| line.split(',').map(|cell| cell.parse().expect("a number from pyfuzzylite")).collect())
        .collect()
}

/// Compares every output of every row; returns the largest absolute error per output.
fn assert_agrees(fll: &Path, seed: u64, tag: &str) -> Vec<(String, f64)> {
    let engine = rule_file::load(fll).expect("rule base loads");
    let inputs = random_inputs(&engine, seed);
    let expected = reference(fll, &engine, &inputs, tag);
    assert_eq!(expected.len(), inputs.len());
    let mut workspace = engine.workspace();
    let mut worst = vec![0.0f64; engine.outputs().len()];
    let mut undefined = vec![0usize; engine.outputs().len()];
    for (row, (x, want)) in inputs.iter().zip(&expected).enumerate() {
        let got = engine.infer(&mut workspace, x).expect("valid inputs");
        for (k, ((g, w), output)) in got.iter().zip(want).zip(engine.outputs()).enumerate() {
            if g.is_nan() || w.is_nan() {
                assert!(
                    g.is_nan() && w.is_nan(),
                    "{tag} row {row} {}: ours {g}, pyfuzzylite {w}, inputs {x:?}",
                    output.name
                );
                undefined[k] += 1;
                continue;
            }
            let error = (g - w).abs();
            assert!(
                error <= TOLERANCE * output.span(),
                "{tag} row {row} {}: ours {g}, pyfuzzylite {w} (error {error:e}), inputs {x:?}",
                output.name
            );
            worst[k] = worst[k].max(error);
        }
    }
    for (output, count) in engine.outputs().iter().zip(&undefined) {
        assert!(
            *count < ROWS / 10,
            "{tag} {}: {count} of {ROWS} rows undefined, too few to compare",
            output.name
        );
    }
    let worst: Vec<(String, f64)> = engine.outputs().iter().map(|v| v.name.clone()).zip(worst).collect();
    println!("{tag}: {ROWS} rows, max |error| per output {worst:?}, undefined {undefined:?}");
    worst
}

#[test]
fn thesis_rule_base_agrees_with_pyfuzzylite() {
    let fll = repo_root().join("config/avoider/thesis.fll");
    assert_agrees(&fll, 0x7E515, "thesis");
}

#[test]
fn tipper_agrees_with_pyfuzzylite() {
    assert_agrees(&data("tipper.fll"), 0x71BB, "tipper");
}

#[test]
fn every_shape_and_defuzzifier_agrees_with_pyfuzzylite() {
    assert_agrees(&data("every_shape.fll"), 0x5AAB, "every_shape");
}
