//! Bad rule files are refused with the file, the line and the cause; bad inputs with the input.

use std::path::PathBuf;

use kestrel_avoider::{Cause, InputError, LoadError, evaluate, fll, rule_file, toml_format};

const TIPPER_FLL: &str = include_str!("data/tipper.fll");
const TIPPER_TOML: &str = include_str!("data/tipper.toml");

/// tipper.fll with line `line` (1-based) replaced by `text`.
fn tipper_with(line: usize, text: &str) -> String {
    let mut lines: Vec<&str> = TIPPER_FLL.lines().collect();
    lines[line - 1] = text;
    lines.join("\n")
}

/// Line number of the first line of tipper.fll containing `needle`.
fn line_of(needle: &str) -> usize {
    TIPPER_FLL.lines().position(|l| l.contains(needle)).expect("needle in tipper.fll") + 1
}

fn fll_error(text: &str) -> (usize, Cause, String) {
    let error = fll::parse(text, "bad.fll").expect_err("the file is refused");
    let message = error.to_string();
    let LoadError::Invalid { origin, line, cause } = error else {
        panic!("expected an invalid-text error, got {message}");
    };
    assert_eq!(origin, "bad.fll");
    assert!(message.starts_with(&format!("bad.fll:{line}: ")), "{message}");
    (line, cause, message)
}

#[test]
fn the_unmodified_files_load() {
    let from_fll = fll::parse(TIPPER_FLL, "tipper.fll").expect("tipper.fll loads");
    let from_toml = toml_format::parse(TIPPER_TOML, "tipper.toml").expect("tipper.toml loads");
    assert_eq!(from_fll.inputs(), from_toml.inputs());
    // Debug text, because the default value NaN is not equal to itself.
    assert_eq!(format!("{:?}", from_fll.outputs()), format!("{:?}", from_toml.outputs()));
    assert_eq!(from_fll.blocks(), from_toml.blocks());
}

#[test]
fn unknown_variable_in_a_rule() {
    let line = line_of("rule: if service is good");
    let (at, cause, message) =
        fll_error(&tipper_with(line, "  rule: if ambience is good then tip is average"));
    assert_eq!(at, line);
    assert!(matches!(cause, Cause::UnknownVariable { ref name, .. } if name == "ambience"));
    assert!(message.contains("unknown input variable 'ambience'"), "{message}");
}

#[test]
fn unknown_term_in_a_rule() {
    let line = line_of("rule: if service is good");
    let (at, cause, _) = fll_error(&tipper_with(line, "  rule: if service is great then tip is average"));
    assert_eq!(at, line);
    assert_eq!(cause, Cause::UnknownTerm { variable: "service".into(), term: "great".into() });
    let (_, cause, _) = fll_error(&tipper_with(line, "  rule: if service is good then tip is huge"));
    assert!(matches!(cause, Cause::UnknownTerm { ref term, .. } if term == "huge"));
}

#[test]
fn term_outside_its_range() {
    let line = line_of("term: generous");
    let (at, cause, message) =
        fll_error(&tipper_with(line, "  term: generous Triangle 35.000 40.000 45.000"));
    assert_eq!(at, line);
    assert!(matches!(cause, Cause::TermOutsideRange { ref term, .. } if term == "generous"));
    assert!(message.contains("outside the range 0..30"), "{message}");
}

#[test]
fn rule_reading_a_disabled_variable_never_fires() {
    let line = line_of("InputVariable: food") + 1;
    let (at, cause, message) = fll_error(&tipper_with(line, "  enabled: false"));
    assert_eq!(at, line_of("rule: if service is poor or food"));
    assert!(matches!(cause, Cause::NeverFires { .. }), "{cause:?}");
    assert!(message.contains("input variable 'food' is disabled"), "{message}");
}

#[test]
fn rule_on_a_term_zero_over_the_whole_range_never_fires() {
    let line = line_of("term: good Gaussian");
    // Height 0: the term is zero everywhere.
    let (at, cause, message) = fll_error(&tipper_with(line, "  term: good Gaussian 5.000 1.500 0.0"));
    assert_eq!(at, line_of("rule: if service is good"));
    assert!(matches!(cause, Cause::NeverFires { .. }), "{cause:?}");
    assert!(message.contains("'service is good' is zero over the whole range"), "{message}");
}

#[test]
fn malformed_numbers() {
    let line = line_of("range: 0.000 30.000");
    let (at, cause, _) = fll_error(&tipper_with(line, "  range: 0.000 3O.000"));
    assert_eq!(at, line);
    assert_eq!(cause, Cause::MalformedNumber("3O.000".into()));
    let line = line_of("term: poor Gaussian");
    let (at, cause, _) = fll_error(&tipper_with(line, "  term: poor Gaussian 0.0 1,5"));
    assert_eq!(at, line);
    assert_eq!(cause, Cause::MalformedNumber("1,5".into()));
    let line = line_of("rule: if service is good");
    let (at, cause, _) =
        fll_error(&tipper_with(line, "  rule: if service is good then tip is average with half"));
    assert_eq!(at, line);
    assert_eq!(cause, Cause::MalformedNumber("half".into()));
}

#[test]
fn unknown_term_type() {
    let line = line_of("term: poor Gaussian");
    let (at, cause, message) = fll_error(&tipper_with(line, "  term: poor Parabola 0.0 1.5"));
    assert_eq!(at, line);
    assert_eq!(cause, Cause::UnknownTermType("Parabola".into()));
    assert!(message.contains("unknown term type 'Parabola'"), "{message}");
}

#[test]
fn wrong_parameter_counts_and_invalid_shapes() {
    let line = line_of("term: poor Gaussian");
    let (_, cause, _) = fll_error(&tipper_with(line, "  term: poor Gaussian 0.0"));
    assert!(matches!(cause, Cause::ParameterCount { got: 1, .. }), "{cause:?}");
    let (_, cause, _) = fll_error(&tipper_with(line, "  term: poor Gaussian 0.0 -1.0"));
    assert!(matches!(cause, Cause::InvalidTerm { .. }), "{cause:?}");
    let (_, cause, _) = fll_error(&tipper_with(line, "  term: poor Triangle 3 2 1"));
    assert!(matches!(cause, Cause::InvalidTerm { .. }), "{cause:?}");
}

#[test]
fn unknown_operators_and_missing_ones() {
    let line = line_of("defuzzifier: Centroid");
    let (_, cause, _) = fll_error(&tipper_with(line, "  defuzzifier: Middle 100"));
    assert!(matches!(cause, Cause::UnknownName { what: "defuzzifier", .. }), "{cause:?}");
    let line = line_of("disjunction: Maximum");
    let (at, cause, _) = fll_error(&tipper_with(line, "  disjunction: none"));
    assert_eq!(at, line_of("rule: if service is poor or food"));
    assert!(matches!(cause, Cause::MissingNorm { what: "a disjunction", .. }), "{cause:?}");
    let line = line_of("conjunction: Minimum");
    let (_, cause, _) = fll_error(&tipper_with(line, "  conjunction: Mínimo"));
    assert!(matches!(cause, Cause::UnknownName { what: "T-norm", .. }), "{cause:?}");
}

#[test]
fn syntax_errors_name_their_line() {
    let line = line_of("rule: if service is good");
    let (at, cause, _) = fll_error(&tipper_with(line, "  rule: if service good then tip is average"));
    assert_eq!(at, line);
    assert!(matches!(cause, Cause::Syntax(_)), "{cause:?}");
    let (at, _, _) = fll_error(&tipper_with(line, "  colour: blue"));
    assert_eq!(at, line);
}

#[test]
fn toml_errors_name_file_and_line() {
    let with = |from: &str, to: &str| {
        assert!(TIPPER_TOML.contains(from));
        TIPPER_TOML.replacen(from, to, 1)
    };
    let toml_line = |needle: &str| TIPPER_TOML.lines().position(|l| l.contains(needle)).expect("needle") + 1;
    let error = toml_format::parse(&with("name = \"food\"", "name = \"food\"\ncolour = 1"), "t.toml")
        .expect_err("unknown field refused");
    assert_eq!(error.line(), Some(toml_line("name = \"food\"") + 1), "{error}");
    assert!(error.to_string().contains("colour"), "{error}");

    let text = with("[20.0, 25.0, 30.0]", "[35.0, 40.0, 45.0]");
    let error = toml_format::parse(&text, "t.toml").expect_err("term outside range refused");
    assert_eq!(error.line(), Some(toml_line("name = \"generous\"")), "{error}");
    assert!(matches!(error.cause(), Some(Cause::TermOutsideRange { .. })), "{error}");

    let text = with("\"if service is good then tip is average\"", "\"if service is good then tip is large\"");
    let error = toml_format::parse(&text, "t.toml").expect_err("unknown term refused");
    assert_eq!(error.line(), Some(toml_line("if service is good")), "{error}");

    let text = with("type = \"Gaussian\", params = [5.0", "type = \"Cone\", params = [5.0");
    let error = toml_format::parse(&text, "t.toml").expect_err("unknown type refused");
    assert_eq!(error.cause(), Some(&Cause::UnknownTermType("Cone".into())), "{error}");

    let text = with("[0.0, 30.0]", "[0.0, 30.0.0]");
    let error = toml_format::parse(&text, "t.toml").expect_err("malformed number refused");
    assert_eq!(error.line(), Some(toml_line("[0.0, 30.0]")), "{error}");
}

#[test]
fn files_are_named_in_errors() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join("bad_tipper.fll");
    let line = line_of("term: poor Gaussian");
    std::fs::write(&path, tipper_with(line, "  term: poor Parabola 0 1")).expect("write");
    let message = rule_file::load(&path).expect_err("refused").to_string();
    assert!(message.starts_with(&format!("{}:{line}: unknown term type", path.display())), "{message}");
    let missing = dir.join("no_such_rules.fll");
    let error = rule_file::load(&missing).expect_err("missing file");
    assert!(matches!(error, LoadError::Io { .. }), "{error}");
    let error = rule_file::load(&dir.join("rules.yaml")).expect_err("unknown format");
    assert!(matches!(error, LoadError::UnknownFormat { .. }), "{error}");
}

#[test]
fn bad_inputs_are_named() {
    let engine = fll::parse(TIPPER_FLL, "tipper.fll").expect("loads");
    let mut workspace = engine.workspace();
    let ok = evaluate(&engine, &mut workspace, &["service=3", "food=7.5"]).expect("evaluates");
    assert_eq!(ok.outputs.len(), 1);
    assert!(ok.to_string().starts_with("tip="), "{ok}");
    assert_eq!(ok.rules.len(), 3);
    let cases: [(&[&str], InputError); 5] = [
        (&["service=3"], InputError::Missing("food".into())),
        (&["service=3", "food=x"], InputError::MalformedNumber { name: "food".into(), value: "x".into() }),
        (&["service=3", "food=1", "ambience=2"], InputError::UnknownVariable("ambience".into())),
        (&["service=3", "service=4"], InputError::Duplicate("service".into())),
        (&["service=3", "food=nan"], InputError::NotANumber("food".into())),
    ];
    for (inputs, expected) in cases {
        assert_eq!(evaluate(&engine, &mut workspace, inputs), Err(expected));
    }
    assert!(matches!(engine.infer(&mut workspace, &[1.0]), Err(InputError::Count { expected: 2, got: 1 })));
    let other = fll::parse(include_str!("data/every_shape.fll"), "every_shape.fll").expect("loads");
    let mut foreign = other.workspace();
    assert_eq!(engine.infer(&mut foreign, &[1.0, 2.0]), Err(InputError::ForeignWorkspace));
}

#[test]
fn a_resolution_below_one_or_beyond_the_cap_is_named_as_such() {
    let line = line_of("defuzzifier: Centroid");
    for (resolution, found) in [("0", "0"), ("-5", "-5"), ("1000000000000", "1000000000000")] {
        let (at, cause, message) =
            fll_error(&tipper_with(line, &format!("  defuzzifier: Centroid {resolution}")));
        assert_eq!(at, line);
        assert_eq!(cause, Cause::Resolution { found: found.into(), max: fll::MAX_RESOLUTION }, "{message}");
        assert!(!message.contains("malformed"), "{message}");
    }
    let (_, cause, _) = fll_error(&tipper_with(line, "  defuzzifier: Centroid 100.0"));
    assert_eq!(cause, Cause::MalformedNumber("100.0".into()), "fuzzylite reads an integer here too");
    assert!(fll::parse(&tipper_with(line, "  defuzzifier: Centroid 1"), "one.fll").is_ok());
}
