//! A graph's wiring as a Graphviz DOT picture (`kestrel run --print-graph`, and the pictures of
//! the shipped graphs in the guide's configs chapter, held by `tests/docs_graphs.rs`).
//!
//! Each actor is a box; an arrow runs from a publishing actor to each actor that reads one of
//! its topics, labelled with the topics it carries, one per line. A topic no one publishes or
//! no one reads draws nothing: the picture shows what flows. The live-parameter plumbing
//! (`param_set`, `param_decl`), which joins nearly every actor to the link, is left out and the
//! title says so. The text depends only on the wiring (actors, topics and arrows in name
//! order), so the same config draws the same bytes.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;

use crate::graph::{PARAM_DECL_PORT, PARAM_SET_PORT, TopicWiring};

/// The actor an `actor.port` belongs to.
fn actor_of(port: &str) -> &str {
    port.split_once('.').map_or(port, |(actor, _)| actor)
}

/// `text` with DOT's string escapes: quotes and backslashes.
fn escaped(text: &str) -> String {
    text.replace('\\', "\\\\").replace('"', "\\\"")
}

/// A DOT string literal.
fn quoted(text: &str) -> String {
    format!("\"{}\"", escaped(text))
}

/// The DOT text of `topics`' wiring, titled `title` (the config's file name).
pub fn to_dot(title: &str, topics: &[TopicWiring]) -> String {
    let mut actors = BTreeSet::new();
    let mut arrows: BTreeMap<(&str, &str), BTreeSet<&str>> = BTreeMap::new();
    for topic in topics.iter().filter(|t| ![PARAM_SET_PORT, PARAM_DECL_PORT].contains(&t.name.as_str())) {
        for publisher in &topic.publishers {
            for subscriber in &topic.subscribers {
                let (from, to) = (actor_of(publisher), actor_of(subscriber));
                actors.insert(from);
                actors.insert(to);
                arrows.entry((from, to)).or_default().insert(&topic.name);
            }
        }
    }
    let mut dot = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(dot, "digraph {} {{", quoted(title));
    let caption = format!("{title} (live parameters, {PARAM_SET_PORT} and {PARAM_DECL_PORT}, not drawn)");
    let _ = writeln!(dot, "  label={}; labelloc=t; rankdir=LR;", quoted(&caption));
    let _ = writeln!(dot, "  node [shape=box, style=rounded, fontname=\"Helvetica\"];");
    let _ = writeln!(dot, "  edge [fontname=\"Helvetica\", fontsize=9, color=\"#555555\"];");
    for actor in &actors {
        let _ = writeln!(dot, "  {};", quoted(actor));
    }
    for ((from, to), names) in &arrows {
        // DOT's `\n` (backslash, n) breaks a label's line.
        let label = names.iter().map(|n| escaped(n)).collect::<Vec<_>>().join("\\n");
        let _ = writeln!(dot, "  {} -> {} [label=\"{label}\"];", quoted(from), quoted(to));
    }
    dot.push_str("}\n");
    dot
}

#[cfg(test)]
mod tests {
    use super::*;

    fn topic(name: &str, publishers: &[&str], subscribers: &[&str]) -> TopicWiring {
        TopicWiring {
            name: name.into(),
            type_name: "T",
            publishers: publishers.iter().map(|p| (*p).into()).collect(),
            subscribers: subscribers.iter().map(|s| (*s).into()).collect(),
        }
    }

    #[test]
    fn topics_between_the_same_two_actors_share_one_arrow_and_unread_or_parameter_topics_draw_nothing() {
        let topics = [
            topic("imu", &["sim.imu"], &["estimator.imu", "controller.imu"]),
            topic("gps", &["sim.gps"], &["estimator.gps"]),
            topic("sim_truth", &["sim.truth"], &[]),
            topic("orphan", &[], &["link.orphan"]),
            topic("param_decl", &["sim.param_decl"], &["link.param_decl"]),
        ];
        let dot = to_dot("sim.toml", &topics);
        let expected = "digraph \"sim.toml\" {\n  label=\"sim.toml (live parameters, param_set and \
            param_decl, not drawn)\"; labelloc=t; rankdir=LR;\n  \
            node [shape=box, style=rounded, fontname=\"Helvetica\"];\n  \
            edge [fontname=\"Helvetica\", fontsize=9, color=\"#555555\"];\n  \
            \"controller\";\n  \"estimator\";\n  \"sim\";\n  \
            \"sim\" -> \"controller\" [label=\"imu\"];\n  \
            \"sim\" -> \"estimator\" [label=\"gps\\nimu\"];\n}\n";
        assert_eq!(dot, expected);
    }

    #[test]
    fn names_are_quoted_for_dot() {
        assert_eq!(quoted(r#"a"b\c"#), r#""a\"b\\c""#);
        assert_eq!(actor_of("runtime"), "runtime");
        assert_eq!(actor_of("link.param_set"), "link");
    }
}
