//! The graph's one vehicle: the vehicle file that the simulator flies is the airframe the
//! controller controls.
//!
//! A vehicle file (`config/vehicles/*.toml`, [`kestrel_sim::VehicleParams`]) holds mass,
//! inertia, frame (motor layout, order and spin), motors and sensors, written once. A graph names
//! it once, with the top-level key `vehicle = "vehicles/hexa_x.toml"` (relative to the graph's
//! directory), and before any actor is built [`resolve`] hands it on:
//! * every simulator (`sim`, `hil_sim`: [`VEHICLE_ACTORS`]) that names no vehicle of its own
//!   flies it; one that names another file is an error ([`VehicleError::TwoVehicles`]);
//! * every controller that writes no `params.control.airframe` controls the airframe
//!   [`airframe_of`] the file; one that writes fields of its own must agree with the file on
//!   each ([`VehicleError::Airframe`]) and then flies the file's values. Its gains stay its own.
//!
//! A graph that names no vehicle keeps each actor's own parameters (the simulator's
//! `params.vehicle`, by default `vehicles/quad_x.toml`; the controller's airframe, by default
//! that file's), and they must still agree: a simulator on the hexa under a controller of the
//! quad is refused at start, naming both, instead of flown into the ground. A hardware graph
//! (`config/navio2.toml`) names its vehicle for the controller alone. The design and what it
//! replaced: docs/src/decisions/0047-one-vehicle-file-for-the-simulator-and-the-controller.md.
//! The tests below hold each hand-on and each refusal; `tests/flight_vehicle_frames.rs` flies the hexa
//! and the octo on `config/sim.toml` with only its `vehicle` changed, and sees both refusals
//! stop `kestrel run` at start.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use kestrel_control::AirframeParams;
use kestrel_sim::{SimActorParams, VehicleParams};
use serde::Deserialize;
use toml::Spanned;

use crate::config::{ActorDecl, ConfigError, LoadedConfig, Source};

/// The actor types that fly a vehicle file (their `params.vehicle`, [`SimActorParams`]).
pub const VEHICLE_ACTORS: [&str; 2] = ["sim", "hil_sim"];
/// The actor type that controls an airframe (its `params.control.airframe`).
pub const CONTROLLER_ACTOR: &str = "controller";

/// Two floating-point values of a field agree within this share of the larger: a value the
/// controller's airframe derives (a motor's full thrust, `k_f·ω_max²`) may differ from the same
/// number written by hand in the last bits, and no more.
const AGREEMENT: f64 = 1e-9;

/// The controller's airframe of a vehicle file: the fields it flies by, with the motor's full
/// thrust `k_f·ω_max²` and torque-to-thrust ratio `k_m/k_f` (the simulator's motor model:
/// thrust linear in the command). For `config/vehicles/quad_x.toml` it is
/// `AirframeParams::default()` to the bit (the test
/// `the_quad_files_airframe_is_the_controllers_default_to_the_bit`).
pub fn airframe_of(vehicle: &VehicleParams) -> AirframeParams {
    let m = &vehicle.motor;
    AirframeParams {
        mass_kg: vehicle.mass_kg,
        inertia_frd_kg_m2: vehicle.inertia_frd_kg_m2,
        arm_length_m: vehicle.arm_length_m,
        frame: vehicle.frame,
        max_thrust_per_motor_n: m.max_thrust_n(),
        torque_to_thrust_m: m.torque_coefficient_n_m_per_rad2_s2 / m.thrust_coefficient_n_per_rad2_s2,
    }
}

/// The vehicle-file field each airframe field is read from.
fn vehicle_field(airframe_field: &str) -> &'static str {
    match airframe_field {
        "mass_kg" => "mass_kg",
        "inertia_frd_kg_m2" => "inertia_frd_kg_m2",
        "arm_length_m" => "arm_length_m",
        "frame" => "frame",
        "max_thrust_per_motor_n" => "motor.thrust_coefficient_n_per_rad2_s2 × motor.max_speed_rad_s²",
        "torque_to_thrust_m" => {
            "motor.torque_coefficient_n_m_per_rad2_s2 / motor.thrust_coefficient_n_per_rad2_s2"
        }
        _ => "(no such field)",
    }
}

/// One field on which a controller's airframe and a vehicle file disagree.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldMismatch {
    /// The field of `params.control.airframe`.
    pub field: String,
    /// Its value in the controller, as TOML.
    pub controller: String,
    /// Whether the graph wrote it (else it is the controller's default).
    pub written: bool,
    /// Where the vehicle file has it.
    pub vehicle_field: &'static str,
    /// Its value from the vehicle file, as TOML.
    pub vehicle: String,
}

impl fmt::Display for FieldMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let whose = if self.written { "" } else { " (its default)" };
        write!(
            f,
            "params.control.airframe.{} = {}{whose}, the vehicle file's {} = {}",
            self.field, self.controller, self.vehicle_field, self.vehicle
        )
    }
}

/// Why a graph's simulator and controller do not fly one vehicle.
#[derive(Debug, thiserror::Error)]
pub enum VehicleError {
    /// The graph's `vehicle` file cannot be read, parsed or validated.
    #[error("the graph's vehicle: {0}")]
    Load(#[source] kestrel_sim::ConfigError),
    /// A simulator names a vehicle file of its own, other than the graph's.
    #[error(
        "actor '{actor}' flies {} (its params.vehicle), but the graph's vehicle is {}: a graph names its vehicle once, in the top-level `vehicle`",
        actor_file.display(),
        graph_file.display()
    )]
    TwoVehicles { actor: String, actor_file: PathBuf, graph_file: PathBuf },
    /// A controller's airframe is not the vehicle's: every field that differs.
    #[error(
        "actor '{controller}' controls another airframe than {} flies ({}): {}; {}",
        vehicle_file.display(),
        flown_by.as_deref().map_or_else(|| "the graph's vehicle".to_owned(), |sim| format!("actor '{sim}'")),
        mismatches.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "),
        if flown_by.is_some() {
            "name the vehicle once, in the graph's top-level `vehicle`, and the controller flies it"
        } else {
            "leave the airframe out and the controller flies the vehicle file's"
        }
    )]
    Airframe {
        controller: String,
        /// The simulator whose vehicle it is; `None`: the graph's top-level `vehicle`.
        flown_by: Option<String>,
        vehicle_file: PathBuf,
        mismatches: Vec<FieldMismatch>,
    },
    /// The airframe could not be written as the controller's parameters.
    #[error("cannot write the vehicle's airframe as the controller's params: {0}")]
    Write(#[source] toml::ser::Error),
}

impl VehicleError {
    /// The error placed on the line of the key it is about.
    pub fn locate(&self, source: &Source) -> ConfigError {
        let message = self.to_string();
        let at = |path: &[&str]| source.line_of_key(path);
        let line = match self {
            VehicleError::Load(_) | VehicleError::Write(_) => at(&["vehicle"]),
            VehicleError::TwoVehicles { actor, .. } => at(&["actors", actor, "params", "vehicle"]),
            VehicleError::Airframe { controller, flown_by, mismatches, .. } => {
                let written = mismatches.iter().find(|m| m.written).and_then(|m| {
                    at(&["actors", controller, "params", "control", "airframe", m.field.as_str()])
                });
                written
                    .or_else(|| flown_by.as_ref().and_then(|sim| at(&["actors", sim, "params", "vehicle"])))
                    .or_else(|| at(&["vehicle"]))
                    .or_else(|| at(&["actors", controller]))
            }
        };
        source.error_on_line(line, message)
    }
}

/// The graph's actors with its vehicle handed on (see the module's documentation): what is
/// built and run. Every actor is as written when the graph names no vehicle.
pub fn resolve(config: &LoadedConfig) -> Result<BTreeMap<Spanned<String>, ActorDecl>, VehicleError> {
    let dir = config.source.dir();
    let mut actors = config.graph.actors.clone();
    match &config.graph.vehicle {
        Some(written) => {
            let graph_file = dir.join(written.get_ref());
            let vehicle = VehicleParams::load(&graph_file).map_err(VehicleError::Load)?;
            let airframe = airframe_of(&vehicle);
            for (name, decl) in &mut actors {
                if VEHICLE_ACTORS.contains(&decl.kind.get_ref().as_str()) {
                    hand_on_vehicle(name.get_ref(), decl, written.get_ref(), dir)?;
                } else if decl.kind.get_ref() == CONTROLLER_ACTOR {
                    hand_on_airframe(name.get_ref(), decl, &airframe, written.get_ref())?;
                }
            }
        }
        None => check_as_written(&actors, dir)?,
    }
    Ok(actors)
}

/// Gives simulator `name` the graph's vehicle file `written`, unless it names the same file.
fn hand_on_vehicle(name: &str, decl: &mut ActorDecl, written: &str, dir: &Path) -> Result<(), VehicleError> {
    let params = decl.params.get_or_insert_with(|| Spanned::new(0..0, toml::Table::new())).get_mut();
    match params.get("vehicle") {
        None => {
            params.insert("vehicle".into(), toml::Value::String(written.to_owned()));
            Ok(())
        }
        Some(toml::Value::String(own)) if same_file(&dir.join(own), &dir.join(written)) => Ok(()),
        // Not a path: the simulator's own parameter check names it when the actor is built.
        Some(toml::Value::String(own)) => Err(VehicleError::TwoVehicles {
            actor: name.to_owned(),
            actor_file: PathBuf::from(own),
            graph_file: PathBuf::from(written),
        }),
        Some(_) => Ok(()),
    }
}

/// Gives controller `name` the airframe of the graph's vehicle, after checking the fields its
/// params write against it.
fn hand_on_airframe(
    name: &str,
    decl: &mut ActorDecl,
    airframe: &AirframeParams,
    written: &str,
) -> Result<(), VehicleError> {
    let params = decl.params.get_or_insert_with(|| Spanned::new(0..0, toml::Table::new())).get_mut();
    let control = params.entry("control").or_insert_with(|| toml::Value::Table(toml::Table::new()));
    // A `control` that is no table is the controller's to refuse when it is built.
    let toml::Value::Table(control) = control else { return Ok(()) };
    if let Some(own) = control.get("airframe") {
        let mismatches = compare(own, airframe, true)?;
        if !mismatches.is_empty() {
            return Err(VehicleError::Airframe {
                controller: name.to_owned(),
                flown_by: None,
                vehicle_file: PathBuf::from(written),
                mismatches,
            });
        }
    }
    control.insert("airframe".into(), airframe_value(airframe)?);
    Ok(())
}

/// In a graph that names no vehicle: every simulator's vehicle file against every controller's
/// airframe, each as its own params (or defaults) have it.
fn check_as_written(actors: &BTreeMap<Spanned<String>, ActorDecl>, dir: &Path) -> Result<(), VehicleError> {
    let params_of = |decl: &ActorDecl| decl.params.as_ref().map(|p| p.get_ref().clone()).unwrap_or_default();
    for (sim, decl) in actors.iter().filter(|(_, d)| VEHICLE_ACTORS.contains(&d.kind.get_ref().as_str())) {
        // Parameters or a file the simulator cannot use: it says so itself when it is built.
        let Ok(sim_params) = SimActorParams::deserialize(toml::Value::Table(params_of(decl))) else {
            continue;
        };
        let Ok(vehicle) = VehicleParams::load(&dir.join(&sim_params.vehicle)) else { continue };
        let flown = airframe_of(&vehicle);
        for (controller, decl) in actors.iter().filter(|(_, d)| d.kind.get_ref() == CONTROLLER_ACTOR) {
            let own = params_of(decl)
                .get("control")
                .and_then(|c| c.get("airframe"))
                .cloned()
                .unwrap_or_else(|| toml::Value::Table(toml::Table::new()));
            let mismatches = compare(&own, &flown, false)?;
            if !mismatches.is_empty() {
                return Err(VehicleError::Airframe {
                    controller: controller.get_ref().clone(),
                    flown_by: Some(sim.get_ref().clone()),
                    vehicle_file: sim_params.vehicle.clone(),
                    mismatches,
                });
            }
        }
    }
    Ok(())
}

/// The airframe as a TOML table, as the controller's params take it.
fn airframe_value(airframe: &AirframeParams) -> Result<toml::Value, VehicleError> {
    toml::Value::try_from(airframe).map_err(VehicleError::Write)
}

/// The fields on which `own` (a controller's `params.control.airframe`, its defaults filling
/// what it leaves out) and `vehicle` disagree: only those `own` writes when `written_only`,
/// else every field. An airframe the controller cannot read is its own to refuse when it is
/// built, and compared as nothing here.
fn compare(
    own: &toml::Value,
    vehicle: &AirframeParams,
    written_only: bool,
) -> Result<Vec<FieldMismatch>, VehicleError> {
    let Ok(parsed) = AirframeParams::deserialize(own.clone()) else { return Ok(Vec::new()) };
    let (toml::Value::Table(ours), toml::Value::Table(theirs)) =
        (airframe_value(&parsed)?, airframe_value(vehicle)?)
    else {
        return Ok(Vec::new());
    };
    let written = |field: &str| own.get(field).is_some();
    Ok(ours
        .iter()
        .filter(|(field, _)| !written_only || written(field))
        .filter_map(|(field, value)| {
            let theirs = theirs.get(field)?;
            (!agree(value, theirs)).then(|| FieldMismatch {
                field: field.clone(),
                controller: value.to_string(),
                written: written(field),
                vehicle_field: vehicle_field(field),
                vehicle: theirs.to_string(),
            })
        })
        .collect())
}

/// Whether two values of one field agree: numbers within [`AGREEMENT`], arrays element by
/// element, anything else equal.
fn agree(a: &toml::Value, b: &toml::Value) -> bool {
    match (a, b) {
        (toml::Value::Float(x), toml::Value::Float(y)) => (x - y).abs() <= AGREEMENT * x.abs().max(y.abs()),
        (toml::Value::Array(xs), toml::Value::Array(ys)) => {
            xs.len() == ys.len() && xs.iter().zip(ys).all(|(x, y)| agree(x, y))
        }
        _ => a == b,
    }
}

/// Whether two paths name one file (by their canonical paths where both exist).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

#[cfg(test)]
mod tests {
    use kestrel_control::ControllerActorParams;

    use super::*;

    /// The repository's config directory, where graphs' relative paths resolve.
    fn config_dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("config")
    }

    /// `text` as a graph file in config/ (never written: nothing in it extends a base).
    fn graph(text: &str) -> LoadedConfig {
        LoadedConfig::parse(&config_dir().join("unit-vehicle.toml"), text).expect("the graph parses")
    }

    fn shipped(name: &str) -> VehicleParams {
        VehicleParams::load(&config_dir().join("vehicles").join(name)).expect("a shipped vehicle loads")
    }

    /// The params `resolve` gives actor `name`, as its actor type reads them.
    fn params_of<P: serde::de::DeserializeOwned>(
        actors: &BTreeMap<Spanned<String>, ActorDecl>,
        name: &str,
    ) -> P {
        let decl = &actors[&Spanned::new(0..0, name.to_owned())];
        let table = decl.params.as_ref().map(|p| p.get_ref().clone()).unwrap_or_default();
        P::deserialize(toml::Value::Table(table)).expect("params the actor reads")
    }

    const SIM_AND_CONTROLLER: &str =
        "[actors.sim]\ntype = \"sim\"\n[actors.controller]\ntype = \"controller\"\n";

    #[test]
    fn the_quad_files_airframe_is_the_controllers_default_to_the_bit() {
        let quad = airframe_of(&shipped("quad_x.toml"));
        let default = AirframeParams::default();
        assert_eq!(quad, default);
        assert_eq!(quad.max_thrust_per_motor_n.to_bits(), default.max_thrust_per_motor_n.to_bits());
        assert_eq!(quad.torque_to_thrust_m.to_bits(), default.torque_to_thrust_m.to_bits());
    }

    #[test]
    fn the_graphs_vehicle_goes_to_the_simulator_and_its_airframe_to_the_controller() {
        for name in ["hexa_x.toml", "octo_x.toml", "quad_x.toml"] {
            let config = graph(&format!("vehicle = \"vehicles/{name}\"\n{SIM_AND_CONTROLLER}"));
            let actors = resolve(&config).expect("one vehicle");
            let sim: SimActorParams = params_of(&actors, "sim");
            assert_eq!(sim.vehicle, Path::new("vehicles").join(name));
            let controller: ControllerActorParams = params_of(&actors, "controller");
            assert_eq!(controller.control.airframe, airframe_of(&shipped(name)), "{name}");
        }
        // The gains and the rest stay the controller's own.
        let config = graph(&format!(
            "vehicle = \"vehicles/hexa_x.toml\"\n{SIM_AND_CONTROLLER}params.control.rate.p = [0.2, 0.2, 0.1]\n"
        ));
        let controller: ControllerActorParams = params_of(&resolve(&config).unwrap(), "controller");
        assert_eq!(controller.control.rate.p, [0.2, 0.2, 0.1]);
        assert_eq!(controller.control.airframe.frame, kestrel_proto::frame_layout::FrameLayout::HexaX);
    }

    #[test]
    fn a_graph_without_a_simulator_gives_the_controller_its_vehicle() {
        let config =
            graph("vehicle = \"vehicles/octo_x.toml\"\n[actors.controller]\ntype = \"controller\"\n");
        let controller: ControllerActorParams = params_of(&resolve(&config).unwrap(), "controller");
        assert_eq!(controller.control.airframe, airframe_of(&shipped("octo_x.toml")));
    }

    #[test]
    fn the_navio2_graph_names_its_vehicle_for_the_controller_alone() {
        let config = LoadedConfig::load(&config_dir().join("navio2.toml")).expect("config/navio2.toml");
        let actors = resolve(&config).expect("one vehicle");
        assert!(actors.values().all(|d| !VEHICLE_ACTORS.contains(&d.kind.get_ref().as_str())));
        let controller: ControllerActorParams = params_of(&actors, "controller");
        assert_eq!(controller.control.airframe, airframe_of(&shipped("quad_x.toml")));
    }

    #[test]
    fn a_controller_airframe_other_than_the_vehicles_is_refused_naming_both() {
        let text = format!(
            "vehicle = \"vehicles/hexa_x.toml\"\n{SIM_AND_CONTROLLER}\
             [actors.controller.params.control.airframe]\nmass_kg = 1.5\narm_length_m = 0.275\n"
        );
        let config = graph(&text);
        let err = resolve(&config).unwrap_err();
        let VehicleError::Airframe { controller, flown_by, vehicle_file, mismatches } = &err else {
            panic!("{err}")
        };
        assert_eq!(
            (controller.as_str(), flown_by, vehicle_file),
            ("controller", &None, &PathBuf::from("vehicles/hexa_x.toml"))
        );
        // Only the field written and wrong: the arm length agrees, the rest is not written.
        assert_eq!(mismatches.len(), 1, "{err}");
        assert_eq!((mismatches[0].field.as_str(), mismatches[0].written), ("mass_kg", true));
        let located = err.locate(&config.source);
        assert_eq!(located.line, Some(7), "{located}");
        let message = located.to_string();
        for part in [
            "unit-vehicle.toml:7",
            "'controller'",
            "vehicles/hexa_x.toml",
            "params.control.airframe.mass_kg = 1.5",
            "mass_kg = 2.4",
        ] {
            assert!(message.contains(part), "{part} in {message}");
        }
    }

    #[test]
    fn an_airframe_written_as_the_vehicle_has_it_is_accepted_and_flies_the_files_values() {
        // The motor's full thrust, k_f·ω_max², written by hand as the vehicle file gives it.
        let text = format!(
            "vehicle = \"vehicles/hexa_x.toml\"\n{SIM_AND_CONTROLLER}\
             [actors.controller.params.control.airframe]\nmass_kg = 2.4\nframe = \"hexa_x\"\nmax_thrust_per_motor_n = 11.0\n"
        );
        let controller: ControllerActorParams = params_of(&resolve(&graph(&text)).unwrap(), "controller");
        assert_eq!(controller.control.airframe, airframe_of(&shipped("hexa_x.toml")));
    }

    #[test]
    fn a_simulator_naming_another_vehicle_file_is_refused_at_its_line() {
        let text = "vehicle = \"vehicles/hexa_x.toml\"\n[actors.sim]\ntype = \"sim\"\nparams.vehicle = \"vehicles/quad_x.toml\"\n";
        let config = graph(text);
        let err = resolve(&config).unwrap_err();
        assert!(matches!(&err, VehicleError::TwoVehicles { actor, .. } if actor == "sim"), "{err}");
        let located = err.locate(&config.source);
        assert_eq!(located.line, Some(4), "{located}");
        assert!(
            located.message.contains("vehicles/quad_x.toml")
                && located.message.contains("vehicles/hexa_x.toml")
        );
        // The same file, spelled another way, is one vehicle.
        let same = "vehicle = \"vehicles/hexa_x.toml\"\n[actors.sim]\ntype = \"sim\"\nparams.vehicle = \"./vehicles/hexa_x.toml\"\n";
        resolve(&graph(same)).expect("one file");
    }

    #[test]
    fn without_a_graph_vehicle_a_hexa_simulator_under_the_quads_controller_is_refused() {
        let text = "[actors.sim]\ntype = \"sim\"\nparams.vehicle = \"vehicles/hexa_x.toml\"\n[actors.controller]\ntype = \"controller\"\n";
        let config = graph(text);
        let err = resolve(&config).unwrap_err();
        let VehicleError::Airframe { flown_by, mismatches, .. } = &err else { panic!("{err}") };
        assert_eq!(flown_by.as_deref(), Some("sim"));
        let mut fields: Vec<&str> = mismatches.iter().map(|m| m.field.as_str()).collect();
        fields.sort_unstable();
        assert_eq!(fields, ["arm_length_m", "frame", "inertia_frd_kg_m2", "mass_kg"], "{err}");
        assert!(mismatches.iter().all(|m| !m.written));
        let located = err.locate(&config.source);
        assert_eq!(located.line, Some(3), "at the simulator's vehicle: {located}");
        assert!(
            located
                .message
                .contains("frame = \"quad_x\" (its default), the vehicle file's frame = \"hexa_x\""),
            "{located}"
        );
    }

    #[test]
    fn without_a_graph_vehicle_agreeing_actors_run_as_written() {
        // The simulator's default vehicle file is the quad, the controller's default airframe its.
        let config = graph(SIM_AND_CONTROLLER);
        let actors = resolve(&config).expect("the defaults agree");
        assert_eq!(actors.len(), 2);
        assert!(actors.values().all(|d| d.params.is_none()), "nothing handed on");
    }

    #[test]
    fn a_graph_vehicle_that_cannot_load_is_an_error_at_its_key() {
        let config = graph(&format!("\nvehicle = \"vehicles/nowhere.toml\"\n{SIM_AND_CONTROLLER}"));
        let err = resolve(&config).unwrap_err();
        assert!(matches!(err, VehicleError::Load(_)), "{err}");
        let located = err.locate(&config.source);
        assert_eq!(located.line, Some(2), "{located}");
        assert!(located.message.contains("nowhere.toml"), "{located}");
    }
}
