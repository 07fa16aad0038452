//! The pictures of the shipped graphs in the guide (`docs/src/configs.md`) are drawn from the
//! configs themselves: for each graph below, the DOT text `kestrel run --print-graph` prints
//! must equal the committed `docs/src/images/graphs/NAME.dot`, and the committed SVG must draw
//! every arrow of it. `KESTREL_UPDATE_DOCS=1` rewrites both (the SVG with Graphviz's `dot`,
//! Debian's `graphviz`, which `scripts/setup.sh --tests` installs).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use kestrel::graph_drawing::to_dot;
use kestrel::hil::{HilOptions, apply_hil};
use kestrel::{LoadedConfig, Registry, topic_wiring};

/// The graphs the guide draws, and whether each is drawn on the emulated board (`--hil`: the
/// Navio2 graph's drivers need their devices to declare their ports).
const DRAWN: [(&str, bool); 6] = [
    ("sim.toml", false),
    ("sim-forest.toml", false),
    ("navio2.toml", true),
    ("split-flight.toml", false),
    ("split-vision.toml", false),
    ("fleet-sim.toml", false),
];

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn images() -> PathBuf {
    repo().join("docs/src/images/graphs")
}

/// The DOT text of a shipped graph, as `kestrel run --print-graph [--hil]` prints it.
fn drawn(file: &str, hil: bool) -> String {
    let mut config = LoadedConfig::load(&repo().join("config").join(file)).expect("shipped config loads");
    let options = HilOptions::new();
    let bench = hil.then(|| apply_hil(&mut config, &options).expect("the emulated board"));
    let wiring = topic_wiring(&config, &Registry::standard()).expect("a runtime to build the graph in");
    if bench.is_some() {
        std::fs::remove_dir_all(&options.dir).ok();
    }
    to_dot(file, &wiring)
}

/// `from -> to` of every arrow in a DOT text.
fn arrows(dot: &str) -> Vec<(String, String)> {
    dot.lines()
        .filter_map(|line| {
            let (from, rest) = line.trim().split_once(" -> ")?;
            let to = rest.split_once(" [")?.0;
            Some((from.trim_matches('"').to_owned(), to.trim_matches('"').to_owned()))
        })
        .collect()
}

fn render_svg(dot: &str, svg: &Path) {
    let mut child = Command::new("dot")
        .args(["-Tsvg", "-o"])
        .arg(svg)
        .stdin(Stdio::piped())
        .spawn()
        .expect("Graphviz's `dot` (Debian: graphviz) to draw the SVG");
    std::io::Write::write_all(&mut child.stdin.take().expect("stdin"), dot.as_bytes()).expect("dot's stdin");
    assert!(child.wait().expect("dot").success(), "dot failed on {}", svg.display());
}

#[test]
fn the_guide_draws_each_shipped_graph_as_its_config_wires_it() {
    let update = std::env::var("KESTREL_UPDATE_DOCS").is_ok_and(|v| v == "1");
    let mut stale = Vec::new();
    for (file, hil) in DRAWN {
        let dot = drawn(file, hil);
        let name = file.trim_end_matches(".toml");
        let (dot_path, svg_path) =
            (images().join(format!("{name}.dot")), images().join(format!("{name}.svg")));
        assert!(arrows(&dot).len() >= 4, "{file} drew {} arrows:\n{dot}", arrows(&dot).len());
        if update {
            std::fs::create_dir_all(images()).expect("images dir");
            std::fs::write(&dot_path, &dot).expect("write the DOT");
            render_svg(&dot, &svg_path);
        }
        if std::fs::read_to_string(&dot_path).ok().as_deref() != Some(dot.as_str()) {
            stale.push(format!("{}:\n{dot}", dot_path.display()));
            continue;
        }
        // Graphviz titles each edge's group `from->to` (escaped as `&#45;&gt;`).
        let svg = std::fs::read_to_string(&svg_path).expect("the committed SVG");
        for (from, to) in arrows(&dot) {
            let title = format!("<title>{from}&#45;&gt;{to}</title>");
            assert!(svg.contains(&title), "{} lacks the arrow {from} -> {to}", svg_path.display());
        }
    }
    assert!(
        stale.is_empty(),
        "committed graph pictures differ from the configs (KESTREL_UPDATE_DOCS=1 redraws them):\n{}",
        stale.join("\n")
    );
}

#[test]
fn print_graph_prints_what_the_guide_draws() {
    let out = Command::new(env!("CARGO_BIN_EXE_kestrel"))
        .current_dir(repo())
        .args(["run", "--config", "config/sim.toml", "--print-graph"])
        .output()
        .expect("run kestrel");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(String::from_utf8_lossy(&out.stdout), drawn("sim.toml", false));
}
