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
