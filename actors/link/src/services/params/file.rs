//! The parameter file: the values set over MAVLink or restored, persisted as `NAME=VALUE`
//! lines so a restart keeps them (the link's `param_file`; written off the table by
//! `transport::param_writer`).

use super::ParamTable;

/// Parses a persisted parameter file: `NAME=VALUE` lines; blank lines and `#` comments skipped.
/// Returns the pairs and the lines that could not be read.
pub fn parse_param_file(text: &str) -> (Vec<(String, f64)>, Vec<String>) {
    let mut pairs = Vec::new();
    let mut bad = Vec::new();
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')) {
        match line.split_once('=').map(|(n, v)| (n.trim(), v.trim().parse::<f64>())) {
            Some((name, Ok(value))) => pairs.push((name.to_owned(), value)),
            _ => bad.push(line.to_owned()),
        }
    }
    (pairs, bad)
}

/// The persisted form of `table`: the values set over MAVLink or restored, sorted by name.
pub fn render_param_file(table: &ParamTable) -> String {
    table.persisted().into_iter().map(|(n, v)| format!("{n}={v}\n")).collect()
}
