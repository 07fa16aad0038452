//! `kestrel run`: fly a graph (the simulator by default).

use std::path::{Path, PathBuf};

use kestrel::hil::HilOptions;
use kestrel::{LoadedConfig, Registry, RunError, RunOptions};

use crate::cli::RunArgs;

/// What a finished `kestrel run` asks of the process.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// The run is over: exit 0.
    Done,
    /// A ground station's reboot was accepted: exit [`kestrel::reboot::REBOOT_EXIT_CODE`] so the
    /// service manager starts it again.
    Reboot,
}

/// Runs the graph `args` name until its duration passes, a signal arrives or a reboot is taken.
pub fn run(args: RunArgs) -> Result<Ended, String> {
    let config_path = locate_config(&args.config)?;
    let mut config = LoadedConfig::load(&config_path).map_err(|e| e.to_string())?;
    if args.print_config {
        let text = config.merged_toml().map_err(|e| format!("cannot print the merged config: {e}"))?;
        print!("{text}");
        return Ok(Ended::Done);
    }
    if args.print_graph {
        let hil = kestrel::hil::HilOptions::new();
        // The emulated board lives while the drivers are built against it.
        let bench = args.hil.then(|| kestrel::hil::apply_hil(&mut config, &hil)).transpose()?;
        let title = config_path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let wiring = kestrel::topic_wiring(&config, &Registry::standard())
            .map_err(|e| format!("cannot build the graph to draw it: {e}"));
        if let Ok(wiring) = &wiring {
            print!("{}", kestrel::graph_drawing::to_dot(&title, wiring));
        }
        if bench.is_some() {
            std::fs::remove_dir_all(&hil.dir).ok();
        }
        return wiring.map(|_| Ended::Done);
    }
    // Before anything is built: a second run of this instance must not touch the first's
    // devices or ports (kestrel::locks).
    let _instance = kestrel::locks::claim_instance(&config_path, args.instance.unwrap_or(0))
        .map_err(|e| format!("{e}: stop it first, or run another --instance"))?;
    apply_flight_flags(&mut config, &args)?;
    if let Some(n) = args.instance {
        apply_instance(&mut config, n)?;
    }
    apply_log_dir(&mut config, args.log_dir.as_deref(), args.instance.unwrap_or(0))?;
    if args.mission.is_none() && !args.auto {
        apply_state_dir(&mut config, args.instance.unwrap_or(0));
    }
    let hil = kestrel::hil::HilOptions::new();
    let hil = HilOptions { world: args.hil_world.clone().unwrap_or(hil.world.clone()), ..hil };
    let bench = args.hil.then(|| kestrel::hil::apply_hil(&mut config, &hil)).transpose()?;
    let duration = args
        .duration
        .map(kestrel::config::check_duration_s)
        .transpose()
        .map_err(|m| format!("--duration {m}"))?;
    if let Some(Err(m)) = args.speedup.map(kestrel::config::check_speedup) {
        return Err(format!("--{m}"));
    }
    tracing::info!(config = %config_path.display(), "starting");
    let options = RunOptions {
        duration,
        speedup: args.speedup,
        record: args.record,
        onboard_log: true,
        report: args.report.clone(),
        status: !args.quiet,
        escalate: None,
    };
    let report = kestrel::run(&config, &Registry::standard(), options).map_err(|e| match e {
        RunError::Config(_) => format!("the config is not usable:\n{e}"),
        other => other.to_string(),
    });
    if bench.is_some() {
        std::fs::remove_dir_all(&hil.dir).ok();
    }
    let report = report?;
    let total: u64 = report.topics.iter().map(|t| t.2).sum();
    tracing::info!("stopped at t={:.3} s after {total} messages", report.end_time.as_secs_f64());
    for m in report.mailboxes.iter().filter(|m| m.overflowed > 0) {
        tracing::warn!(route = %m.route, overflowed = m.overflowed, "messages refused by a full queue");
    }
    if let Some(path) = &args.report
        && !path.exists()
    {
        return Err(format!("the flight report {} was not written (see the log above)", path.display()));
    }
    if let Some(rec) = &report.recording {
        let n: u64 = rec.messages_per_topic.values().sum();
        tracing::info!(
            "recorded {n} messages on {} topics to {}",
            rec.messages_per_topic.len(),
            rec.path.display()
        );
    }
    if report.reboot {
        tracing::warn!("exiting with {} for the reboot", kestrel::reboot::REBOOT_EXIT_CODE);
        return Ok(Ended::Reboot);
    }
    Ok(Ended::Done)
}

/// Resolves the log directory (`--log-dir`, else `[record] dir`; `instance-N` added for
/// `--instance N` > 0) to an absolute path for the recorder, and hands it to every link actor
/// (`log_dir`), which serves it to ground stations.
fn apply_log_dir(config: &mut LoadedConfig, flag: Option<&Path>, instance: u8) -> Result<(), String> {
    if let Some(dir) = flag {
        let absolute = std::path::absolute(dir).map_err(|e| format!("--log-dir {}: {e}", dir.display()))?;
        config.graph.record.dir = Some(absolute);
    } else if instance > 0
        && let Some(dir) = &config.graph.record.dir
    {
        config.graph.record.dir = Some(dir.join(format!("instance-{instance}")));
    }
    let Some(onboard) = config.graph.record.onboard()? else { return Ok(()) };
    config.graph.record.dir = Some(onboard.dir.clone());
    for actor in config.graph.actors.values_mut().filter(|d| d.kind.get_ref() == "link") {
        let params =
            actor.params.get_or_insert_with(|| toml::Spanned::new(0..0, toml::Table::new())).get_mut();
        params.entry("log_dir").or_insert_with(|| toml::Value::String(onboard.dir.display().to_string()));
    }
    Ok(())
}

/// Resolves `[state] dir` against the state directory (`instance-N` added for `--instance N` >
/// 0) and hands it to every link actor that names none itself (`state_dir`), where the uploaded
/// plans and the parameters set persist.
fn apply_state_dir(config: &mut LoadedConfig, instance: u8) {
    let Some(dir) = &config.graph.state.dir else { return };
    let mut dir = kestrel::config::state_dir().join(dir);
    if instance > 0 {
        dir = dir.join(format!("instance-{instance}"));
    }
    for actor in config.graph.actors.values_mut().filter(|d| d.kind.get_ref() == "link") {
        let params =
            actor.params.get_or_insert_with(|| toml::Spanned::new(0..0, toml::Table::new())).get_mut();
        params.entry("state_dir").or_insert_with(|| toml::Value::String(dir.display().to_string()));
    }
}

/// Hands `--mission`, `--auto` and `--exit-on-land` to the graph's commander as parameters.
fn apply_flight_flags(config: &mut LoadedConfig, args: &RunArgs) -> Result<(), String> {
    if args.mission.is_none() && !args.auto && !args.exit_on_land {
        return Ok(());
    }
    let path = config.source.path.display().to_string();
    let mut commanders = config.graph.actors.values_mut().filter(|d| d.kind.get_ref() == "commander");
    let (Some(commander), None) = (commanders.next(), commanders.next()) else {
        return Err(format!(
            "--mission, --auto and --exit-on-land need exactly one commander actor in {path}"
        ));
    };
    let params =
        commander.params.get_or_insert_with(|| toml::Spanned::new(0..0, toml::Table::new())).get_mut();
    if let Some(mission) = &args.mission {
        let absolute =
            std::path::absolute(mission).map_err(|e| format!("--mission {}: {e}", mission.display()))?;
        // Read here too, so a bad plan is reported as the plan's own error, before the graph
        // that carries it is built.
        kestrel_control::load_plan(&absolute).map_err(|e| format!("--mission {e}"))?;
        params.insert("mission".into(), toml::Value::String(absolute.display().to_string()));
    }
    if args.auto {
        params.insert("auto".into(), toml::Value::Boolean(true));
    }
    if args.exit_on_land {
        params.insert("exit_on_land".into(), toml::Value::Boolean(true));
    }
    Ok(())
}

/// Hands `--instance N` to the graph's links (system id, ports), simulators (spawn point,
/// noise seed) and Zenoh bridges (vehicle name) as their `instance` parameter; each actor says
/// what it means for it.
fn apply_instance(config: &mut LoadedConfig, n: u8) -> Result<(), String> {
    let mut applied = 0;
    for decl in config.graph.actors.values_mut() {
        if matches!(decl.kind.get_ref().as_str(), "link" | "sim" | "bridge") {
            let params =
                decl.params.get_or_insert_with(|| toml::Spanned::new(0..0, toml::Table::new())).get_mut();
            params.insert("instance".into(), toml::Value::Integer(i64::from(n)));
            applied += 1;
        }
    }
    if applied == 0 {
        return Err(format!(
            "--instance needs a link, sim or bridge actor in {}",
            config.source.path.display()
        ));
    }
    Ok(())
}

/// Finds the config: as given, or for the default relative path also inside the source tree
/// this binary was built from, so `kestrel run` works from any directory of a checkout.
fn locate_config(path: &Path) -> Result<PathBuf, String> {
    if path.exists() || path.is_absolute() {
        return Ok(path.to_owned());
    }
    let in_tree = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    if in_tree.exists() {
        return Ok(in_tree);
    }
    Err(format!("config {} not found (also looked for {})", path.display(), in_tree.display()))
}
