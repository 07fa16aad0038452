//! File-name patterns for the CLI (`'DIR/left*.jpg'`): `*` and `?` in the last path component
//! only, matches sorted by name.

use std::path::{Path, PathBuf};

use crate::error::VisionError;

/// The files matching `pattern`, sorted; an error when the directory cannot be read or a
/// wildcard appears before the last component.
pub fn expand(pattern: &str) -> Result<Vec<PathBuf>, VisionError> {
    let path = Path::new(pattern);
    let file = path.file_name().and_then(|f| f.to_str()).unwrap_or_default();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if dir.to_string_lossy().contains(['*', '?']) {
        return Err(VisionError::Params(format!("pattern {pattern}: wildcards only in the file name")));
    }
    if !file.contains(['*', '?']) {
        return Ok(if path.is_file() { vec![path.to_owned()] } else { Vec::new() });
    }
    let entries =
        std::fs::read_dir(dir).map_err(|source| VisionError::Io { path: dir.to_owned(), source })?;
    let mut found: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter(|e| e.file_name().to_str().is_some_and(|name| matches(file.as_bytes(), name.as_bytes())))
        .map(|e| dir.join(e.file_name()))
        .collect();
    found.sort();
    Ok(found)
}

/// Whether `name` matches `pattern` (`*` any run, `?` any one byte).
fn matches(pattern: &[u8], name: &[u8]) -> bool {
    match (pattern.first(), name.first()) {
        (None, None) => true,
        (Some(b'*'), _) => matches(&pattern[1..], name) || (!name.is_empty() && matches(pattern, &name[1..])),
        (Some(b'?'), Some(_)) => matches(&pattern[1..], &name[1..]),
        (Some(p), Some(n)) if p == n => matches(&pattern[1..], &name[1..]),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::matches;

    #[test]
    fn stars_and_question_marks() {
        assert!(matches(b"left*.jpg", b"left01.jpg"));
        assert!(matches(b"left??.jpg", b"left01.jpg"));
        assert!(!matches(b"left*.jpg", b"right01.jpg"));
        assert!(!matches(b"left*.jpg", b"left01.png"));
        assert!(matches(b"*", b""));
    }
}
