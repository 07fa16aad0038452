//! `kestrel fuzzy`: evaluate a rule base (fuzzylite FLL or our TOML) from the command line.

use std::io::Write;
use std::path::Path;

use kestrel_avoider::{Engine, evaluate, rule_file};

use crate::cli::FuzzyArgs;

/// Evaluates the rule base once (`--input`) or per CSV row (`--csv`), printing to stdout.
pub fn run(args: FuzzyArgs) -> Result<(), String> {
    let engine = rule_file::load(&args.rules).map_err(|e| e.to_string())?;
    let mut out = std::io::stdout().lock();
    let written = match &args.csv {
        Some(csv) => evaluate_csv(&engine, csv, args.json, &mut out)?,
        None => {
            let mut workspace = engine.workspace();
            let evaluation = evaluate(&engine, &mut workspace, &args.input).map_err(|e| e.to_string())?;
            if args.json {
                let json = serde_json::to_string_pretty(&evaluation).map_err(|e| e.to_string())?;
                writeln!(out, "{json}")
            } else {
                write!(out, "{evaluation}").and_then(|()| {
                    if args.activations {
                        evaluation.rules.iter().try_for_each(|rule| writeln!(out, "# {rule}"))
                    } else {
                        Ok(())
                    }
                })
            }
        }
    };
    written.map_err(|e| format!("writing the result: {e}"))
}

/// One output row per input row. The CSV's header names the inputs (any order); the output
/// header names the outputs, in the rule base's order.
fn evaluate_csv(
    engine: &Engine,
    path: &Path,
    json: bool,
    out: &mut impl Write,
) -> Result<std::io::Result<()>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, header) =
        lines.next().ok_or_else(|| format!("{}: empty file, expected a header", path.display()))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut workspace = engine.workspace();
    let mut rows = Vec::new();
    for (index, line) in lines {
        let values: Vec<&str> = line.split(',').map(str::trim).collect();
        if values.len() != names.len() {
            return Err(format!(
                "{}:{}: {} values for {} columns",
                path.display(),
                index + 1,
                values.len(),
                names.len()
            ));
        }
        let assignments: Vec<String> = names.iter().zip(&values).map(|(n, v)| format!("{n}={v}")).collect();
        let evaluation = evaluate(engine, &mut workspace, &assignments)
            .map_err(|e| format!("{}:{}: {e}", path.display(), index + 1))?;
        rows.push(evaluation);
    }
    if json {
        let json = serde_json::to_string(&rows).map_err(|e| e.to_string())?;
        return Ok(writeln!(out, "{json}"));
    }
    let header: Vec<&str> = engine.outputs().iter().map(|o| o.name.as_str()).collect();
    Ok(writeln!(out, "{}", header.join(",")).and_then(|()| {
        rows.iter().try_for_each(|row| {
            let values: Vec<String> = row.outputs.iter().map(|o| o.value.to_string()).collect();
            writeln!(out, "{}", values.join(","))
        })
    }))
}
