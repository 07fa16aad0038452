//! Mutated and arbitrary rule bases — FLL and our TOML — load or are refused, never panic or
//! abort; what loads evaluates to finite outputs or a typed error.

use kestrel_avoider::{fll, toml_format};
use kestrel_proto::bad_input::mutate;
use proptest::prelude::*;

const FLL_FILES: [&str; 3] = [
    include_str!("../../../config/avoider/thesis.fll"),
    include_str!("data/tipper.fll"),
    include_str!("data/every_shape.fll"),
];
const TOML_FILE: &str = include_str!("data/tipper.toml");

fn edits() -> impl Strategy<Value = Vec<(u8, usize, u8)>> {
    prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..6)
}

/// Evaluates a loaded engine at the middle of every input's range.
fn evaluate(engine: &kestrel_avoider::Engine) {
    let mut workspace = engine.workspace();
    let inputs: Vec<f64> = engine.inputs().iter().map(|v| (v.min + v.max) / 2.0).collect();
    let _ = engine.infer(&mut workspace, &inputs);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_fll_loads_or_is_refused(which in 0..FLL_FILES.len(), edits in edits()) {
        let text = String::from_utf8_lossy(&mutate(FLL_FILES[which].as_bytes(), &edits)).into_owned();
        if let Ok(engine) = fll::parse(&text, "mutated.fll") {
            evaluate(&engine);
        }
    }

    #[test]
    fn mutated_toml_rule_bases_load_or_are_refused(edits in edits()) {
        let text = String::from_utf8_lossy(&mutate(TOML_FILE.as_bytes(), &edits)).into_owned();
        if let Ok(engine) = toml_format::parse(&text, "mutated.toml") {
            evaluate(&engine);
        }
    }

    #[test]
    fn arbitrary_text_is_no_rule_base(text in ".{0,400}") {
        let _ = fll::parse(&text, "arbitrary.fll");
        let _ = toml_format::parse(&text, "arbitrary.toml");
    }
}
