//! Config composition: `extends = "base.toml"` (or a list of bases) at the top of a graph file.
//!
//! Graphs that differ by a few actors (the simulator's, the perception and forest graphs, the
//! Navio2 vehicle, the benches) share their common actors from one base file, so they cannot
//! drift apart. The rule is a deep merge, the same everywhere: the bases are merged in the
//! order listed, then the file itself; where both sides hold a table (`[actors.controller]`,
//! its `params`, its `inputs`) the keys merge, the later file's winning; any other value
//! (a string, a number, an array such as `params.endpoints`) is replaced whole. So a child
//! overrides one parameter with `[actors.controller] params.loop_mode = "thread"` and adds a
//! route with `inputs.avoidance = { … }`, and never needs to copy the rest.
//!
//! Relative paths inside `params` resolve against the directory of the file that is run, not
//! of the base that spelled them (actors see one config directory), so bases live in
//! `config/base/` and hold no relative paths. Every error names the file and the key: a missing
//! base, a cycle, an `extends` that is not a file name or list of them.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::config::ConfigError;

/// The top-level key naming a file's bases.
pub const EXTENDS_KEY: &str = "extends";

/// Longest chain of bases: deeper is a mistake, not a design.
const MAX_DEPTH: usize = 16;

/// One file of a composition: its path and text (for the lines of its keys).
#[derive(Clone, Debug)]
pub struct Layer {
    pub path: PathBuf,
    pub text: Arc<str>,
}

/// A config file with its bases merged in.
#[derive(Debug)]
pub struct Composed {
    /// The merged document, without `extends`.
    pub table: toml::Table,
    /// Every file that took part, the file that was run first, then its bases nearest first;
    /// empty when the file extends nothing.
    pub layers: Vec<Layer>,
}

/// Reads `path` and merges its bases into it.
pub fn compose(path: &Path, text: &str) -> Result<Composed, ConfigError> {
    let mut layers = Vec::new();
    let table = load_layer(path, text, &mut Vec::new(), &mut layers)?;
    if layers.len() == 1 {
        layers.clear();
    }
    Ok(Composed { table, layers })
}

/// Merges `overlay` into `base`: tables merge key by key, anything else is replaced.
pub fn merge(base: &mut toml::Table, overlay: toml::Table) {
    for (key, value) in overlay {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(into)), toml::Value::Table(from)) => merge(into, from),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

fn error(path: &Path, text: &str, message: String) -> ConfigError {
    let source = crate::config::Source::plain(path, text);
    source.error_at_key(&[EXTENDS_KEY], message)
}

fn load_layer(
    path: &Path,
    text: &str,
    chain: &mut Vec<PathBuf>,
    layers: &mut Vec<Layer>,
) -> Result<toml::Table, ConfigError> {
    let mut table: toml::Table = toml::from_str(text).map_err(|e| {
        let source = crate::config::Source::plain(path, text);
        ConfigError {
            file: path.to_owned(),
            line: e.span().map(|s| source.line_of(s.start)),
            message: e.message().trim().to_owned(),
        }
    })?;
    layers.push(Layer { path: path.to_owned(), text: Arc::from(text) });
    let bases = match table.remove(EXTENDS_KEY) {
        None => return Ok(table),
        Some(toml::Value::String(base)) => vec![base],
        Some(toml::Value::Array(items)) => items
            .into_iter()
            .map(|item| match item {
                toml::Value::String(s) => Ok(s),
                other => Err(error(
                    path,
                    text,
                    format!("`{EXTENDS_KEY}` lists {}, not a file name", other.type_str()),
                )),
            })
            .collect::<Result<Vec<_>, _>>()?,
        Some(other) => {
            return Err(error(
                path,
                text,
                format!("`{EXTENDS_KEY}` is {}: expected a file name or a list of them", other.type_str()),
            ));
        }
    };
    let canonical = path.canonicalize().unwrap_or_else(|_| path.to_owned());
    chain.push(canonical);
    if chain.len() > MAX_DEPTH {
        return Err(error(path, text, format!("`{EXTENDS_KEY}` chains more than {MAX_DEPTH} files deep")));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut merged = toml::Table::new();
    for base in bases {
        let base_path = dir.join(&base);
        let base_text = std::fs::read_to_string(&base_path).map_err(|e| {
            error(path, text, format!("`{EXTENDS_KEY}` names \"{base}\" ({}): {e}", base_path.display()))
        })?;
        let canonical = base_path.canonicalize().unwrap_or_else(|_| base_path.clone());
        if let Some(at) = chain.iter().position(|p| *p == canonical) {
            let cycle: Vec<String> =
                chain[at..].iter().chain([&canonical]).map(|p| p.display().to_string()).collect();
            return Err(error(
                path,
                text,
                format!("`{EXTENDS_KEY}` = \"{base}\" closes a cycle: {}", cycle.join(" → ")),
            ));
        }
        let layer = load_layer(&base_path, &base_text, chain, layers)?;
        merge(&mut merged, layer);
    }
    chain.pop();
    merge(&mut merged, table);
    Ok(merged)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory for one test's files.
    fn temp_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("kestrel-compose-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    fn compose_file(path: &Path) -> Result<Composed, ConfigError> {
        compose(path, &std::fs::read_to_string(path).unwrap())
    }

    #[test]
    fn tables_merge_and_other_values_are_replaced() {
        let mut base: toml::Table =
            toml::from_str("[a]\nx = 1\nlist = [1, 2]\n[a.t]\nkeep = true\nswap = 1\n").unwrap();
        let overlay: toml::Table =
            toml::from_str("[a]\nlist = [3]\n[a.t]\nswap = \"s\"\n[b]\ny = 2\n").unwrap();
        merge(&mut base, overlay);
        let want: toml::Table =
            toml::from_str("[a]\nx = 1\nlist = [3]\n[a.t]\nkeep = true\nswap = \"s\"\n[b]\ny = 2\n").unwrap();
        assert_eq!(base, want);
    }

    #[test]
    fn bases_merge_in_order_then_the_file_itself() {
        let dir = temp_dir("bases_merge_in_order");
        write(dir.as_path(), "one.toml", "[actors.a]\ntype = \"one\"\nparams = { p = 1, q = 1 }\n");
        write(dir.as_path(), "two.toml", "[actors.a]\nparams.q = 2\n[actors.b]\ntype = \"two\"\n");
        let top = write(
            dir.as_path(),
            "top.toml",
            "extends = [\"one.toml\", \"two.toml\"]\n[actors.a]\nparams.p = 3\n",
        );
        let composed = compose_file(&top).unwrap();
        let want: toml::Table = toml::from_str(
            "[actors.a]\ntype = \"one\"\nparams = { p = 3, q = 2 }\n[actors.b]\ntype = \"two\"\n",
        )
        .unwrap();
        assert_eq!(composed.table, want);
        assert_eq!(composed.layers.len(), 3);
    }

    #[test]
    fn a_missing_base_names_the_file_and_the_key() {
        let dir = temp_dir("a_missing_base_names");
        let top = write(dir.as_path(), "top.toml", "# x\nextends = \"nowhere.toml\"\n[actors]\n");
        let err = compose_file(&top).unwrap_err();
        assert_eq!((err.file.as_path(), err.line), (top.as_path(), Some(2)), "{err}");
        assert!(err.message.contains("nowhere.toml"), "{err}");
    }

    #[test]
    fn a_cycle_is_an_error_naming_its_files() {
        let dir = temp_dir("a_cycle_is_an_error_");
        write(dir.as_path(), "a.toml", "extends = \"b.toml\"\n");
        let b = write(dir.as_path(), "b.toml", "\nextends = \"a.toml\"\n");
        let err = compose_file(&dir.as_path().join("a.toml")).unwrap_err();
        assert_eq!((err.file.as_path(), err.line), (b.as_path(), Some(2)), "{err}");
        assert!(err.message.contains("cycle") && err.message.contains("a.toml"), "{err}");
        let own = write(dir.as_path(), "self.toml", "extends = \"self.toml\"\n");
        assert!(compose_file(&own).unwrap_err().message.contains("cycle"));
    }

    #[test]
    fn extends_must_name_files() {
        let dir = temp_dir("extends_must_name_fi");
        let top = write(dir.as_path(), "top.toml", "extends = 3\n");
        assert!(compose_file(&top).unwrap_err().message.contains("expected a file name"));
        let top = write(dir.as_path(), "top.toml", "extends = [\"x.toml\", 3]\n");
        assert!(compose_file(&top).unwrap_err().message.contains("not a file name"));
    }
}
