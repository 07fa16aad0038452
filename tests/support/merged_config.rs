//! Editing a merged graph config (`LoadedConfig::merged_toml`, `kestrel run --print-config`) in
//! tests that fly a stock graph with a part left out: the merged text has one table per section,
//! so a route or an actor's table is dropped whole.

/// `text` (a merged config, one table per section) without the sections `drop` picks by their
/// header and their lines.
pub fn without_sections(text: &str, drop: impl Fn(&str, &[&str]) -> bool) -> String {
    let mut sections: Vec<Vec<&str>> = vec![Vec::new()];
    for line in text.lines() {
        if line.starts_with('[') {
            sections.push(Vec::new());
        }
        if let Some(last) = sections.last_mut() {
            last.push(line);
        }
    }
    let kept = sections.into_iter().filter(|lines| match lines.first() {
        Some(header) if header.starts_with('[') => !drop(header, lines),
        _ => true,
    });
    kept.flatten().map(|l| format!("{l}\n")).collect()
}
