//! Live parameters declared once, in the code of the actor that owns them.
//!
//! An owner lists its tunables as [`ParamDef`]s over its own parameter struct: the MAVLink name,
//! range, unit and description next to the field they change. From that one list it builds the
//! [`ParamDecl`] it publishes to the link ([`declare`]) and applies each `ParamSet` it receives
//! ([`apply`]): the range is checked again (the link checked it too, but a bench may publish
//! `ParamSet` without a link), then the owner's own validation of the whole struct, and the old
//! value is kept when either refuses. [`answer`] is the rest of every owner's `param_set`
//! handler: what to log, and whether to publish the declaration again.
//!
//! Each definition also says whether the parameter may change while the vehicle is armed
//! ([`WhileArmed`]): the link refuses a PARAM_SET of a [`WhileArmed::Locked`] one while armed,
//! and an owner that knows the armed state refuses it too ([`apply_set`]).

use crate::messages::{ParamDecl, ParamInfo, ParamSet};
use crate::time::Time;

/// The longest MAVLink `param_id`.
pub const PARAM_NAME_MAX: usize = 16;

/// Whether a parameter may change while the vehicle is armed, declared with each parameter so
/// that adding one is a decision.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WhileArmed {
    /// Gains, speeds, limits, failsafe choices, simulated faults: tunable in flight, as
    /// ArduPilot allows.
    Tunable,
    /// Moves what the outputs or the sensors mean: a motor's pulse range (`SERVOn_MIN/MAX`: a
    /// narrowed range stops that motor), a sensor's offsets and scales or the board's trim (the
    /// corrected samples step under an estimator that realigns only on the ground). Set only
    /// while disarmed; a parameter file loaded at boot applies them all.
    Locked,
}

/// One live parameter of a `P`: where it lives and what values it accepts.
pub struct ParamDef<P> {
    /// MAVLink name, at most [`PARAM_NAME_MAX`] ASCII characters.
    pub name: &'static str,
    /// SI unit of the field (and so of `min`/`max`).
    pub unit: &'static str,
    pub min: f64,
    pub max: f64,
    pub description: &'static str,
    /// Whether a PARAM_SET may change it while armed.
    pub while_armed: WhileArmed,
    /// Reads the value from `P`.
    pub get: fn(&P) -> f64,
    /// Writes the value into `P` (one parameter may set several fields, e.g. north and east).
    pub set: fn(&mut P, f64),
}

/// What a `ParamSet` did to an owner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamChange {
    /// The field now holds the value.
    Applied,
    /// Not one of this owner's parameters (another actor may own it).
    NotMine,
}

/// Why an owner kept the old value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamRefused {
    #[error("parameter {name}: {value} is outside {min}..={max} {unit}")]
    OutOfRange { name: String, value: f64, min: f64, max: f64, unit: &'static str },
    #[error("parameter {name}: {reason}")]
    Invalid { name: String, reason: String },
    #[error("{name}: cannot change while armed")]
    WhileArmed { name: String },
}

/// Why a declaration cannot be served over MAVLink.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DeclError {
    #[error("parameter '{0}': a name must be 1 to 16 ASCII characters")]
    Name(String),
    #[error("parameter '{0}' is declared twice")]
    Duplicate(String),
    #[error("parameter '{name}': value {value} is outside {min}..={max} or not finite")]
    OutOfRange { name: String, value: f64, min: f64, max: f64 },
}

/// The declaration of `defs` with the values `params` holds now; `start` for the one an owner
/// publishes when it starts (see [`ParamDecl::start`]).
pub fn declare<P>(defs: &[ParamDef<P>], params: &P, owner: &str, start: bool, time: Time) -> ParamDecl {
    let values = defs
        .iter()
        .map(|d| ParamInfo {
            name: d.name.to_owned(),
            value: (d.get)(params),
            min: d.min,
            max: d.max,
            unit: d.unit.to_owned(),
            description: d.description.to_owned(),
            integer: false,
            disarmed_only: d.while_armed == WhileArmed::Locked,
        })
        .collect();
    ParamDecl { time, owner: owner.to_owned(), start, params: values }
}

/// Sets `name` to `value` in `params` if `defs` holds it, the value is in range and the changed
/// struct passes `validate`; otherwise `params` is untouched.
pub fn apply<P: Clone, E: std::fmt::Display>(
    defs: &[ParamDef<P>],
    params: &mut P,
    name: &str,
    value: f64,
    validate: impl Fn(&P) -> Result<(), E>,
) -> Result<ParamChange, ParamRefused> {
    let Some(def) = defs.iter().find(|d| d.name == name) else {
        return Ok(ParamChange::NotMine);
    };
    if !(value.is_finite() && value >= def.min && value <= def.max) {
        return Err(ParamRefused::OutOfRange {
            name: name.to_owned(),
            value,
            min: def.min,
            max: def.max,
            unit: def.unit,
        });
    }
    let mut changed = params.clone();
    (def.set)(&mut changed, value);
    validate(&changed).map_err(|e| ParamRefused::Invalid { name: name.to_owned(), reason: e.to_string() })?;
    *params = changed;
    Ok(ParamChange::Applied)
}

/// [`apply`] for a `ParamSet` arriving at an owner that knows whether the vehicle is `armed`:
/// a [`WhileArmed::Locked`] parameter is refused while armed — unless the set restores the
/// value in force before this owner (re)started ([`ParamSet::restore`]), which its restart
/// already dropped. Holds "no locked parameter changes while armed"
/// (`tests::no_locked_parameter_changes_while_armed_whatever_the_sets`).
pub fn apply_set<P: Clone, E: std::fmt::Display>(
    defs: &[ParamDef<P>],
    params: &mut P,
    set: &ParamSet,
    armed: bool,
    validate: impl Fn(&P) -> Result<(), E>,
) -> Result<ParamChange, ParamRefused> {
    let locked = defs.iter().any(|d| d.name == set.name && d.while_armed == WhileArmed::Locked);
    if armed && locked && !set.restore {
        return Err(ParamRefused::WhileArmed { name: set.name.clone() });
    }
    apply(defs, params, &set.name, set.value, validate)
}

/// What an owner does after trying a `ParamSet` (`outcome`, from [`apply`] and whatever the
/// owner does with an applied value): logs it, applied or refused and why, and returns whether
/// to publish its [`ParamDecl`] again. That is yes for every name of its own, applied or refused,
/// so the link always serves the value really in use; no for another owner's name, which would
/// only repeat an unchanged declaration.
pub fn answer<E: std::fmt::Display>(owner: &str, set: &ParamSet, outcome: Result<ParamChange, E>) -> bool {
    match outcome {
        Ok(ParamChange::NotMine) => false,
        Ok(ParamChange::Applied) => {
            tracing::info!(actor = owner, name = %set.name, value = set.value, "parameter applied");
            true
        }
        Err(e) => {
            tracing::warn!(actor = owner, name = %set.name, value = set.value, "parameter refused: {e}");
            true
        }
    }
}

impl ParamDecl {
    /// Checks what the link relies on: names MAVLink can carry, no name twice, values in range.
    pub fn check(&self) -> Result<(), DeclError> {
        for (i, p) in self.params.iter().enumerate() {
            if p.name.is_empty() || p.name.len() > PARAM_NAME_MAX || !p.name.is_ascii() {
                return Err(DeclError::Name(p.name.clone()));
            }
            if self.params[..i].iter().any(|o| o.name == p.name) {
                return Err(DeclError::Duplicate(p.name.clone()));
            }
            if !(p.value.is_finite() && p.value >= p.min && p.value <= p.max) {
                return Err(DeclError::OutOfRange {
                    name: p.name.clone(),
                    value: p.value,
                    min: p.min,
                    max: p.max,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Debug, PartialEq)]
    struct Tuning {
        low: f64,
        high: f64,
    }

    const DEFS: [ParamDef<Tuning>; 2] = [
        ParamDef {
            name: "T_LOW",
            unit: "m",
            min: 0.0,
            max: 10.0,
            description: "lower",
            while_armed: WhileArmed::Tunable,
            get: |t| t.low,
            set: |t, v| t.low = v,
        },
        ParamDef {
            name: "T_HIGH",
            unit: "m",
            min: 0.0,
            max: 10.0,
            description: "upper",
            while_armed: WhileArmed::Locked,
            get: |t| t.high,
            set: |t, v| t.high = v,
        },
    ];

    fn ordered(t: &Tuning) -> Result<(), String> {
        if t.low < t.high { Ok(()) } else { Err(format!("low {} must stay below high {}", t.low, t.high)) }
    }

    #[test]
    fn a_declaration_carries_the_current_values_and_passes_its_checks() {
        let decl = declare(&DEFS, &Tuning { low: 1.0, high: 4.0 }, "owner", true, Time::ZERO);
        assert_eq!(decl.owner, "owner");
        let values: Vec<(&str, f64)> = decl.params.iter().map(|p| (p.name.as_str(), p.value)).collect();
        assert_eq!(values, [("T_LOW", 1.0), ("T_HIGH", 4.0)]);
        decl.check().expect("valid");
    }

    #[test]
    fn apply_sets_in_range_values_and_keeps_the_old_one_on_any_refusal() {
        let mut t = Tuning { low: 1.0, high: 4.0 };
        assert_eq!(apply(&DEFS, &mut t, "T_LOW", 2.5, ordered), Ok(ParamChange::Applied));
        assert_eq!(t.low, 2.5);
        assert_eq!(apply(&DEFS, &mut t, "OTHER", 2.5, ordered), Ok(ParamChange::NotMine));
        for (name, value) in [("T_LOW", 11.0), ("T_LOW", f64::NAN), ("T_LOW", -0.1)] {
            assert!(matches!(
                apply(&DEFS, &mut t, name, value, ordered),
                Err(ParamRefused::OutOfRange { .. })
            ));
        }
        assert!(matches!(apply(&DEFS, &mut t, "T_LOW", 5.0, ordered), Err(ParamRefused::Invalid { .. })));
        assert_eq!(t, Tuning { low: 2.5, high: 4.0 });
    }

    #[test]
    fn bad_declarations_are_named() {
        let mut decl = declare(&DEFS, &Tuning { low: 1.0, high: 4.0 }, "owner", true, Time::ZERO);
        decl.params[1].name = "T_LOW".into();
        assert_eq!(decl.check(), Err(DeclError::Duplicate("T_LOW".into())));
        decl.params[1].name = "A_NAME_LONGER_THAN_16".into();
        assert_eq!(decl.check(), Err(DeclError::Name("A_NAME_LONGER_THAN_16".into())));
        decl.params[1].name = "T_HIGH".into();
        decl.params[1].value = 20.0;
        assert!(matches!(decl.check(), Err(DeclError::OutOfRange { .. })));
    }

    fn set(name: &str, value: f64, restore: bool) -> ParamSet {
        ParamSet { time: Time::ZERO, name: name.into(), value, restore }
    }

    #[test]
    fn the_declaration_carries_which_parameters_are_locked_while_armed() {
        let decl = declare(&DEFS, &Tuning { low: 1.0, high: 4.0 }, "owner", true, Time::ZERO);
        let locked: Vec<(&str, bool)> =
            decl.params.iter().map(|p| (p.name.as_str(), p.disarmed_only)).collect();
        assert_eq!(locked, [("T_LOW", false), ("T_HIGH", true)]);
    }

    #[test]
    fn a_locked_parameter_is_refused_while_armed_and_taken_disarmed_or_restored() {
        let mut t = Tuning { low: 1.0, high: 4.0 };
        assert_eq!(
            apply_set(&DEFS, &mut t, &set("T_HIGH", 6.0, false), true, ordered),
            Err(ParamRefused::WhileArmed { name: "T_HIGH".into() })
        );
        assert_eq!(
            ParamRefused::WhileArmed { name: "T_HIGH".into() }.to_string(),
            "T_HIGH: cannot change while armed"
        );
        assert_eq!(t.high, 4.0);
        // A tunable one is taken armed; the locked one disarmed, or restored after a restart.
        assert_eq!(
            apply_set(&DEFS, &mut t, &set("T_LOW", 2.0, false), true, ordered),
            Ok(ParamChange::Applied)
        );
        assert_eq!(
            apply_set(&DEFS, &mut t, &set("T_HIGH", 6.0, false), false, ordered),
            Ok(ParamChange::Applied)
        );
        assert_eq!(
            apply_set(&DEFS, &mut t, &set("T_HIGH", 7.0, true), true, ordered),
            Ok(ParamChange::Applied)
        );
        assert_eq!(t, Tuning { low: 2.0, high: 7.0 });
        // Range and validation still apply to every path.
        assert!(apply_set(&DEFS, &mut t, &set("T_HIGH", 11.0, false), false, ordered).is_err());
        assert_eq!(
            apply_set(&DEFS, &mut t, &set("OTHER", 1.0, false), true, ordered),
            Ok(ParamChange::NotMine)
        );
    }

    proptest::proptest! {
        /// Whatever sets arrive, armed or not, a locked parameter holds its value through every
        /// armed stretch, and a tunable one is never refused for being armed.
        #[test]
        fn no_locked_parameter_changes_while_armed_whatever_the_sets(
            sets in proptest::collection::vec((proptest::bool::ANY, 0usize..3, -2.0f64..12.0), 1..60)
        ) {
            let mut t = Tuning { low: 1.0, high: 9.0 };
            for (armed, which, value) in sets {
                let name = ["T_LOW", "T_HIGH", "OTHER"][which];
                let before = t.clone();
                let outcome = apply_set(&DEFS, &mut t, &set(name, value, false), armed, ordered);
                if armed {
                    proptest::prop_assert_eq!(t.high, before.high);
                    if name == "T_HIGH" {
                        proptest::prop_assert_eq!(&outcome, &Err(ParamRefused::WhileArmed { name: name.into() }));
                    }
                }
                if name == "T_LOW" {
                    let armed_refusal = matches!(outcome, Err(ParamRefused::WhileArmed { .. }));
                    proptest::prop_assert!(!armed_refusal, "a tunable parameter refused for being armed");
                }
            }
        }
    }

    #[test]
    fn an_owner_answers_its_own_names_applied_or_refused_and_not_others() {
        let set = ParamSet { time: Time::ZERO, name: "T_LOW".into(), value: 1.0, restore: false };
        assert!(answer("t", &set, Ok::<_, ParamRefused>(ParamChange::Applied)));
        assert!(answer("t", &set, Err("out of range")));
        assert!(!answer("t", &set, Ok::<_, ParamRefused>(ParamChange::NotMine)));
    }
}
