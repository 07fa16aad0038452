//! Durations, rates and sizes in a graph config that no `Duration` or allocation can hold are
//! refused at start-up with the file, the line of the field and the field's name — never a
//! panic ("cannot convert float seconds to Duration") or an abort.

use std::path::Path;

use kestrel::{LoadedConfig, Registry, RunError, RunOptions};

/// The start-up errors of the graph `text`, as if it were a file in `config/`.
fn start_up_errors(text: &str) -> Vec<kestrel::config::ConfigError> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/ranges-test.toml");
    let config = LoadedConfig::parse(&path, text).expect("the graph itself parses");
    match kestrel::run(&config, &Registry::standard(), RunOptions::default()) {
        Err(RunError::Config(errors)) => errors,
        other => panic!("expected config errors, got {other:?}"),
    }
}

#[track_caller]
fn assert_located(text: &str, line: usize, field: &str) {
    let errors = start_up_errors(text);
    assert!(
        errors.iter().any(|e| e.line == Some(line) && e.message.contains(field)),
        "expected an error at line {line} naming {field}, got: {errors:?}"
    );
}

#[test]
fn actor_timing_parameters_out_of_range_are_errors_at_their_line() {
    let link = "[actors.link]\ntype = \"link\"\nparams.system_id = 1\nparams.gcs_timeout_s = 1e30\n";
    assert_located(link, 4, "gcs_timeout_s");

    let camera = "[actors.camera]\ntype = \"camera\"\n\
        params = { fps = 1e-300, source = { kind = \"image_folder\", dir = \"missing\", left = \"l.png\", right = \"r.png\" } }\n";
    assert_located(camera, 3, "fps");

    let avoider = "[actors.avoider]\ntype = \"avoider\"\n\nparams.check_period_s = 1e-9\n";
    assert_located(avoider, 4, "check_period_s");

    let motors = "[actors.motors]\ntype = \"pwm_motors\"\n[actors.motors.params]\nchannels = [0, 1, 2, 3]\ntimeout_s = 1e30\n";
    assert_located(motors, 5, "timeout_s");
}

#[test]
fn a_bad_socket_address_is_named_with_its_field_value_and_line() {
    let link = "[actors.link]\ntype = \"link\"\nparams.endpoints = [\n\
        { type = \"udp_in\", bind = \"0.0.0.0:14540\" },\n\
        { type = \"udp_out\", address = \"127.0.0.1:99999\" },\n]\n";
    let errors = start_up_errors(link);
    let error = errors.first().expect("an error");
    assert_eq!(error.line, Some(5), "{error}");
    assert!(error.message.contains("endpoint address \"127.0.0.1:99999\""), "{error}");
    let tcp = "[actors.link]\ntype = \"link\"\nparams.endpoints = [{ type = \"tcp_in\", bind = \"localhost:5760\" }]\n";
    assert_located(tcp, 3, "endpoint bind \"localhost:5760\"");
}

/// Every numeric leaf of `value` (tables and arrays walked), as a path.
fn numeric_leaves(value: &toml::Value, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match value {
        toml::Value::Table(table) => {
            for (key, child) in table {
                prefix.push(key.clone());
                numeric_leaves(child, prefix, out);
                prefix.pop();
            }
        }
        toml::Value::Array(items) => {
            for (i, child) in items.iter().enumerate() {
                prefix.push(i.to_string());
                numeric_leaves(child, prefix, out);
                prefix.pop();
            }
        }
        toml::Value::Integer(_) | toml::Value::Float(_) => out.push(prefix.clone()),
        _ => {}
    }
}

fn leaf_mut<'v>(value: &'v mut toml::Value, path: &[String]) -> &'v mut toml::Value {
    path.iter().fold(value, |v, key| match v {
        toml::Value::Table(t) => t.get_mut(key).expect("key"),
        toml::Value::Array(a) => &mut a[key.parse::<usize>().expect("index")],
        _ => unreachable!("a leaf path ends at a leaf"),
    })
}

/// The sweep the issue asked to keep: every number in the parameters of every shipped graph,
/// set to each extreme a careless or hostile person writes, is refused or used — building the
/// actor never panics or aborts.
#[test]
fn every_shipped_parameter_at_an_extreme_is_refused_or_used_without_a_panic() {
    use kestrel::activity::Activity;
    use kestrel::clock::LockstepClock;
    use kestrel::graph::Graph;
    use std::sync::Arc;

    let floats = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e30, -1e30, -1.0, 0.0, 1e-300];
    let integers = [i64::MAX, i64::MIN, -1, 0, 1 << 40];
    let registry = Registry::standard();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("config");
    let mut built = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let config = LoadedConfig::load(&path).unwrap_or_else(|e| panic!("{e}"));
        for (name, decl) in &config.graph.actors {
            let Some(params) = &decl.params else { continue };
            let Some(kind) = registry.get(decl.kind.get_ref()) else { continue };
            let mut leaves = Vec::new();
            numeric_leaves(&toml::Value::Table(params.get_ref().clone()), &mut Vec::new(), &mut leaves);
            for leaf in leaves {
                let values =
                    floats.iter().map(|&f| toml::Value::Float(f)).chain(integers.map(toml::Value::Integer));
                for value in values {
                    let mut table = toml::Value::Table(params.get_ref().clone());
                    *leaf_mut(&mut table, &leaf) = value.clone();
                    let toml::Value::Table(table) = table else { unreachable!() };
                    let mut decl = decl.clone();
                    decl.params = Some(toml::Spanned::new(params.span(), table));
                    let activity = Activity::new();
                    let clock = Arc::new(LockstepClock::new(Arc::clone(&activity)));
                    let mut graph = Graph::new(clock, activity);
                    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        kind.prepare(name.get_ref(), &decl, &config.source, &mut graph).is_ok()
                    }));
                    assert!(
                        outcome.is_ok(),
                        "{}: actor '{}' params.{} = {value} panicked",
                        path.display(),
                        name.get_ref(),
                        leaf.join(".")
                    );
                    built += 1;
                }
            }
        }
    }
    assert!(built > 100, "the sweep reached {built} builds");
}

#[test]
fn a_pace_given_by_the_caller_is_checked_like_the_configs() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/ranges-test.toml");
    let config = LoadedConfig::parse(&path, "[actors]\n").expect("an empty graph");
    let options = RunOptions { speedup: Some(1e-300), ..RunOptions::default() };
    match kestrel::run(&config, &Registry::standard(), options) {
        Err(RunError::Config(errors)) => {
            assert!(errors[0].message.contains("speedup = 1e-300"), "{errors:?}")
        }
        other => panic!("expected a config error, got {other:?}"),
    }
}
