//! Every relative link in README.md and in the user guide (`docs/**/*.md`) resolves: the file or
//! folder it names exists, and a `#anchor` into a Markdown file names one of its headings, as
//! GitHub and mdBook derive heading ids. A link from a page of the book (`docs/src/`) must stay
//! inside the book, since mdBook publishes only that folder. mdBook itself checks only that the
//! chapters in SUMMARY.md exist; this is the rest.

use std::collections::HashSet;
use std::path::{Component, Path, PathBuf};

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A link found in a Markdown file: the file, its line (1-based) and the target as written.
#[derive(Debug)]
struct Link {
    file: PathBuf,
    line: usize,
    target: String,
}

/// The Markdown files the test covers: README.md and every `.md` under docs/ (not the built book).
fn markdown_files(root: &Path) -> Vec<PathBuf> {
    let mut files = vec![root.join("README.md")];
    let mut dirs = vec![root.join("docs")];
    while let Some(dir) = dirs.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for entry in entries {
            let path = entry.expect("a readable docs/ entry").path();
            if path.is_dir() {
                if path != root.join("docs/book") {
                    dirs.push(path);
                }
            } else if path.extension().is_some_and(|e| e == "md") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// The lines of `text` outside fenced code blocks, with their 1-based numbers.
fn prose_lines(text: &str) -> Vec<(usize, &str)> {
    let mut fence: Option<&str> = None;
    let mut lines = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let marker = ["```", "~~~"].into_iter().find(|m| trimmed.starts_with(m));
        match (fence, marker) {
            (None, Some(m)) => fence = Some(m),
            (Some(open), Some(m)) if open == m => fence = None,
            (None, None) => lines.push((i + 1, line)),
            _ => {}
        }
    }
    lines
}

/// `line` with its inline code spans (`` `...` ``) removed: a link inside one is text.
fn without_code_spans(line: &str) -> String {
    let mut out = String::new();
    let mut rest = line;
    while let Some(start) = rest.find('`') {
        out.push_str(&rest[..start]);
        let ticks = rest[start..].chars().take_while(|&c| c == '`').count();
        let after = &rest[start + ticks..];
        match after.find(&"`".repeat(ticks)) {
            Some(end) => rest = &after[end + ticks..],
            None => {
                rest = after;
                break;
            }
        }
    }
    out.push_str(rest);
    out
}

/// The link targets in one line of prose: inline links and images `[text](target "title")`,
/// reference definitions `[name]: target`, and HTML `href="..."` / `src="..."`.
fn targets_in(line: &str) -> Vec<String> {
    let line = without_code_spans(line);
    let mut targets = Vec::new();
    let mut rest = line.as_str();
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        let end = after.find(')').unwrap_or(after.len());
        let inner = after[..end].trim();
        let target = inner.split_whitespace().next().unwrap_or("");
        targets.push(target.trim_start_matches('<').trim_end_matches('>').to_owned());
        rest = &after[end..];
    }
    let trimmed = line.trim_start();
    if trimmed.starts_with('[')
        && !trimmed.starts_with("[^")
        && let Some(close) = trimmed.find("]:")
        && let Some(target) = trimmed[close + 2..].split_whitespace().next()
    {
        targets.push(target.trim_start_matches('<').trim_end_matches('>').to_owned());
    }
    for attribute in ["href=\"", "src=\""] {
        let mut rest = line.as_str();
        while let Some(at) = rest.find(attribute) {
            let after = &rest[at + attribute.len()..];
            let end = after.find('"').unwrap_or(after.len());
            targets.push(after[..end].to_owned());
            rest = &after[end..];
        }
    }
    targets
}

fn links_in(file: &Path) -> Vec<Link> {
    let text = std::fs::read_to_string(file).expect("a readable Markdown file");
    prose_lines(&text)
        .into_iter()
        .flat_map(|(line, s)| {
            targets_in(s).into_iter().map(move |target| Link { file: file.to_owned(), line, target })
        })
        .collect()
}

/// A heading's id as GitHub and mdBook derive it: the text without Markdown (code ticks, link
/// targets, emphasis), lowercased; letters, digits, `-` and `_` kept, whitespace turned into `-`,
/// everything else dropped.
fn heading_id(heading: &str) -> String {
    let mut text = String::new();
    let mut rest = heading;
    // A link in a heading keeps its text.
    while let Some(open) = rest.find('[') {
        let Some(mid) = rest[open..].find("](") else { break };
        let Some(close) = rest[open + mid..].find(')') else { break };
        text.push_str(&rest[..open]);
        text.push_str(&rest[open + 1..open + mid]);
        rest = &rest[open + mid + close + 1..];
    }
    text.push_str(rest);
    text.trim()
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '_' || c == '-' {
                Some(c.to_lowercase().next().unwrap_or(c))
            } else if c.is_whitespace() {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

/// The anchors a Markdown file offers: one per ATX heading (a repeated one gets `-1`, `-2`, ...).
fn anchors(file: &Path) -> HashSet<String> {
    let text = std::fs::read_to_string(file).unwrap_or_default();
    let mut ids = HashSet::new();
    for (_, line) in prose_lines(&text) {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if !(1..=6).contains(&hashes) || !line[hashes..].starts_with(' ') {
            continue;
        }
        let id = heading_id(line[hashes..].trim().trim_end_matches('#'));
        let mut unique = id.clone();
        let mut n = 0;
        while ids.contains(&unique) {
            n += 1;
            unique = format!("{id}-{n}");
        }
        ids.insert(unique);
    }
    ids
}

/// `path` with `.` and `..` folded, without touching the file system.
fn normalised(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// What is wrong with `link`, if anything. External links (a scheme) are not checked.
fn problem(root: &Path, link: &Link) -> Option<String> {
    let target = link.target.as_str();
    if target.is_empty() {
        return Some("an empty link".to_owned());
    }
    if target.contains("://") || target.starts_with("mailto:") {
        return None;
    }
    let (path, anchor) = match target.split_once('#') {
        Some((path, anchor)) => (path, Some(anchor)),
        None => (target, None),
    };
    let dir = link.file.parent().expect("a file in a folder");
    let resolved = if path.is_empty() { link.file.clone() } else { normalised(&dir.join(path)) };
    if !resolved.exists() {
        return Some(format!("{} does not exist", resolved.display()));
    }
    let book = root.join("docs/src");
    if link.file.starts_with(&book) && !resolved.starts_with(&book) {
        return Some(format!("{} is outside the book (docs/src), which mdBook publishes alone", path));
    }
    if let Some(anchor) = anchor
        && resolved.extension().is_some_and(|e| e == "md")
        && !anchors(&resolved).contains(anchor)
    {
        return Some(format!("{} has no heading with the id #{anchor}", resolved.display()));
    }
    None
}

fn broken_links(root: &Path) -> (usize, Vec<String>) {
    let links: Vec<Link> = markdown_files(root).iter().flat_map(|f| links_in(f)).collect();
    let broken = links
        .iter()
        .filter_map(|link| {
            problem(root, link).map(|why| {
                let file = link.file.strip_prefix(root).unwrap_or(&link.file);
                format!("{}:{}: ({}) {why}", file.display(), link.line, link.target)
            })
        })
        .collect();
    (links.len(), broken)
}

#[test]
fn every_relative_link_in_the_readme_and_the_guide_resolves() {
    let (checked, broken) = broken_links(repo());
    assert!(checked > 100, "only {checked} links found: is the guide in docs/src?");
    assert!(broken.is_empty(), "{} broken link(s):\n{}", broken.len(), broken.join("\n"));
}

#[test]
fn a_missing_file_a_missing_anchor_and_a_link_out_of_the_book_are_each_found() {
    let root = std::env::temp_dir().join(format!("kestrel-doc-links-{}", std::process::id()));
    let book = root.join("docs/src");
    std::fs::create_dir_all(&book).unwrap();
    std::fs::write(
        root.join("README.md"),
        "See [the guide](docs/src/a.md#the-first-part), [`code`](docs/src/a.md#no-such-part)\n\
         and `[not a link](nowhere.md)`.\n\n```\n[in a code block](nowhere.md)\n```\n",
    )
    .unwrap();
    std::fs::write(
        book.join("a.md"),
        "# The `first` part\n\n[up](../../README.md), [gone](b.md), [self](#the-first-part)\n\
         [external](https://example.org/x.md)\n",
    )
    .unwrap();
    let (checked, broken) = broken_links(&root);
    std::fs::remove_dir_all(&root).unwrap();
    assert_eq!(checked, 6, "{broken:?}");
    assert_eq!(broken.len(), 3, "{broken:?}");
    assert!(broken[0].contains("#no-such-part") && broken[0].starts_with("README.md:1:"), "{broken:?}");
    assert!(broken[1].contains("outside the book"), "{broken:?}");
    assert!(broken[2].contains("b.md does not exist"), "{broken:?}");
}

#[test]
fn heading_ids_follow_github_and_mdbook() {
    assert_eq!(heading_id("Faults and failsafes"), "faults-and-failsafes");
    assert_eq!(heading_id("`kestrel run`: the main job"), "kestrel-run-the-main-job");
    assert_eq!(heading_id("GPS lost: drag keeps the velocity"), "gps-lost-drag-keeps-the-velocity");
    assert_eq!(heading_id("[Zenoh](zenoh.md) and fleets"), "zenoh-and-fleets");
    assert_eq!(heading_id("320 × 240 rig"), "320--240-rig");
}
