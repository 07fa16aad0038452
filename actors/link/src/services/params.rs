//! The parameter protocol (PARAM_REQUEST_LIST / PARAM_REQUEST_READ / PARAM_SET / PARAM_VALUE),
//! values C-cast into `param_value` (MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST).
//!
//! A set outside the parameter's range is refused: the current value is echoed and a STATUSTEXT
//! says why. An unknown name gets a STATUSTEXT only (there is no value to echo).

use kestrel_proto::Time;
use kestrel_proto::messages::ParamSet;
use mavlink::dialects::ardupilotmega::{MavMessage, MavParamType, MavSeverity, PARAM_VALUE_DATA};

use super::events::statustext;
use super::{Outputs, ToGraph};
use crate::config::{ParamKind, ParamSpec};

/// Why a parameter table could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParamError {
    #[error("parameter '{0}': a name must be 1 to 16 ASCII characters")]
    Name(String),
    #[error("{0} parameters: MAVLink indexes at most 32767")]
    TooMany(usize),
    #[error("parameter '{0}' is listed twice")]
    Duplicate(String),
    #[error("parameter '{name}': value {value} is outside {min}..={max} or not finite")]
    OutOfRange { name: String, value: f64, min: f64, max: f64 },
}

/// The vehicle's parameters, in config order (that order is the MAVLink index).
#[derive(Debug)]
pub struct ParamTable {
    specs: Vec<ParamSpec>,
}

impl ParamTable {
    /// Checks `specs` (names, ranges, defaults).
    pub fn new(specs: Vec<ParamSpec>) -> Result<ParamTable, ParamError> {
        if specs.len() > i16::MAX as usize {
            return Err(ParamError::TooMany(specs.len()));
        }
        for (i, s) in specs.iter().enumerate() {
            if s.name.is_empty() || s.name.len() > 16 || !s.name.is_ascii() {
                return Err(ParamError::Name(s.name.clone()));
            }
            if specs[..i].iter().any(|o| o.name == s.name) {
                return Err(ParamError::Duplicate(s.name.clone()));
            }
            if !in_range(s, s.value) {
                return Err(ParamError::OutOfRange {
                    name: s.name.clone(),
                    value: s.value,
                    min: s.min,
                    max: s.max,
                });
            }
        }
        Ok(ParamTable { specs })
    }

    /// The number of parameters.
    pub fn len(&self) -> usize {
        self.specs.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.specs.is_empty()
    }

    /// `(name, value)` of every parameter, for persisting.
    pub fn values(&self) -> impl Iterator<Item = (&str, f64)> {
        self.specs.iter().map(|s| (s.name.as_str(), s.value))
    }

    /// Applies a stored value at start-up (ignored, with the reason, when unknown or invalid).
    pub fn restore(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let Some(spec) = self.specs.iter_mut().find(|s| s.name == name) else {
            return Err(ParamError::Name(name.to_owned()));
        };
        if !in_range(spec, value) {
            return Err(ParamError::OutOfRange {
                name: name.to_owned(),
                value,
                min: spec.min,
                max: spec.max,
            });
        }
        spec.value = quantise(spec.kind, value);
        Ok(())
    }

    fn value_msg(&self, index: usize) -> Option<MavMessage> {
        let s = self.specs.get(index)?;
        Some(MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
            param_value: s.value as f32,
            param_count: u16::try_from(self.specs.len()).unwrap_or(u16::MAX),
            param_index: u16::try_from(index).unwrap_or(u16::MAX),
            param_id: s.name.as_str().into(),
            param_type: match s.kind {
                ParamKind::Real32 => MavParamType::MAV_PARAM_TYPE_REAL32,
                ParamKind::Int32 => MavParamType::MAV_PARAM_TYPE_INT32,
                ParamKind::Uint8 => MavParamType::MAV_PARAM_TYPE_UINT8,
            },
        }))
    }

    /// Every parameter, in index order.
    pub fn list(&self) -> Vec<MavMessage> {
        (0..self.specs.len()).filter_map(|i| self.value_msg(i)).collect()
    }

    /// PARAM_REQUEST_READ: by index when `index >= 0`, else by name. Unknown: nothing.
    pub fn read(&self, name: &str, index: i16) -> Option<MavMessage> {
        let i = match usize::try_from(index) {
            Ok(i) => i,
            Err(_) => self.specs.iter().position(|s| s.name == name)?,
        };
        self.value_msg(i)
    }

    /// PARAM_SET.
    pub fn set(&mut self, name: &str, value: f32, now: Time) -> Outputs {
        let Some(i) = self.specs.iter().position(|s| s.name == name) else {
            let text = format!("Param {name}: unknown");
            return Outputs::send(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
        };
        let value = f64::from(value);
        let spec = &mut self.specs[i];
        if !in_range(spec, value) {
            let text = format!("Param {name}: {value} outside {}..{} {}", spec.min, spec.max, spec.unit);
            let mut out = Outputs::send(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
            out.mav.extend(self.value_msg(i));
            return out;
        }
        spec.value = quantise(spec.kind, value);
        let applied = ParamSet { time: now, name: spec.name.clone(), value: spec.value };
        Outputs { mav: self.value_msg(i).into_iter().collect(), graph: vec![ToGraph::Param(applied)] }
    }
}

fn in_range(spec: &ParamSpec, value: f64) -> bool {
    value.is_finite()
        && value >= spec.min
        && value <= spec.max
        && match spec.kind {
            ParamKind::Real32 => true,
            ParamKind::Int32 => value >= f64::from(i32::MIN) && value <= f64::from(i32::MAX),
            ParamKind::Uint8 => (0.0..=255.0).contains(&value),
        }
}

fn quantise(kind: ParamKind, value: f64) -> f64 {
    match kind {
        ParamKind::Real32 => f64::from(value as f32),
        ParamKind::Int32 | ParamKind::Uint8 => value.round(),
    }
}

/// Parses a persisted parameter file: `NAME=VALUE` lines; blank lines and `#` comments skipped.
/// Returns the pairs and the lines that could not be read.
pub fn parse_param_file(text: &str) -> (Vec<(String, f64)>, Vec<String>) {
    let mut pairs = Vec::new();
    let mut bad = Vec::new();
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')) {
        match line.split_once('=').map(|(n, v)| (n.trim(), v.trim().parse::<f64>())) {
            Some((name, Ok(value))) => pairs.push((name.to_owned(), value)),
            _ => bad.push(line.to_owned()),
        }
    }
    (pairs, bad)
}

/// The persisted form of `table`.
pub fn render_param_file(table: &ParamTable) -> String {
    table.values().map(|(n, v)| format!("{n}={v}\n")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(name: &str, value: f64, min: f64, max: f64, kind: ParamKind) -> ParamSpec {
        ParamSpec { name: name.into(), value, min, max, kind, unit: "m".into() }
    }

    fn table() -> ParamTable {
        ParamTable::new(vec![
            spec("RTL_ALT_M", 30.0, 5.0, 120.0, ParamKind::Real32),
            spec("FS_ACTION", 1.0, 0.0, 3.0, ParamKind::Int32),
        ])
        .expect("valid table")
    }

    fn value(m: &MavMessage) -> (String, f32, u16, u16) {
        match m {
            MavMessage::PARAM_VALUE(p) => (
                p.param_id.to_str().unwrap_or_default().trim_end_matches('\0').to_owned(),
                p.param_value,
                p.param_index,
                p.param_count,
            ),
            other => panic!("not a PARAM_VALUE: {other:?}"),
        }
    }

    #[test]
    fn list_and_read_by_name_and_index() {
        let t = table();
        let all: Vec<_> = t.list().iter().map(value).collect();
        assert_eq!(all, [("RTL_ALT_M".into(), 30.0, 0, 2), ("FS_ACTION".into(), 1.0, 1, 2)]);
        assert_eq!(value(&t.read("FS_ACTION", -1).expect("by name")).2, 1);
        assert_eq!(value(&t.read("", 0).expect("by index")).0, "RTL_ALT_M");
        assert!(t.read("NOPE", -1).is_none());
        assert!(t.read("", 5).is_none());
    }

    #[test]
    fn set_applies_in_range_and_echoes_the_old_value_otherwise() {
        let mut t = table();
        let out = t.set("RTL_ALT_M", 50.0, Time::ZERO);
        assert_eq!(value(&out.mav[0]).1, 50.0);
        assert_eq!(
            out.graph,
            vec![ToGraph::Param(ParamSet { time: Time::ZERO, name: "RTL_ALT_M".into(), value: 50.0 })]
        );
        let out = t.set("RTL_ALT_M", 500.0, Time::ZERO);
        assert!(matches!(out.mav[0], MavMessage::STATUSTEXT(_)));
        assert_eq!(value(&out.mav[1]).1, 50.0);
        assert!(out.graph.is_empty());
        let out = t.set("RTL_ALT_M", f32::NAN, Time::ZERO);
        assert_eq!(value(&out.mav[1]).1, 50.0);
        let out = t.set("FS_ACTION", 2.4, Time::ZERO);
        assert_eq!(value(&out.mav[0]).1, 2.0);
        let out = t.set("UNKNOWN", 1.0, Time::ZERO);
        assert_eq!(out.mav.len(), 1);
        assert!(matches!(out.mav[0], MavMessage::STATUSTEXT(_)));
    }

    #[test]
    fn bad_tables_are_refused() {
        assert!(matches!(
            ParamTable::new(vec![spec("A", 1.0, 2.0, 3.0, ParamKind::Real32)]),
            Err(ParamError::OutOfRange { .. })
        ));
        assert!(matches!(
            ParamTable::new(vec![spec("THIS_NAME_IS_TOO_LONG", 1.0, 0.0, 3.0, ParamKind::Real32)]),
            Err(ParamError::Name(_))
        ));
        let dup =
            vec![spec("A", 1.0, 0.0, 3.0, ParamKind::Real32), spec("A", 1.0, 0.0, 3.0, ParamKind::Real32)];
        assert!(matches!(ParamTable::new(dup), Err(ParamError::Duplicate(_))));
    }

    #[test]
    fn the_file_round_trips() {
        let mut t = table();
        t.set("RTL_ALT_M", 42.5, Time::ZERO);
        let text = render_param_file(&t);
        let (pairs, bad) = parse_param_file(&format!("# saved\n{text}garbage\n"));
        assert_eq!(bad, ["garbage"]);
        let mut fresh = table();
        for (n, v) in pairs {
            fresh.restore(&n, v).expect("known");
        }
        assert_eq!(value(&fresh.read("RTL_ALT_M", -1).expect("known")).1, 42.5);
    }
}
