//! A world file's `[[faults]]` entries: the flat table each is read from ([`RawFault`]), its
//! conversion to a [`Fault`] that refuses a value its kind does not have, and the checks that
//! locate a bad entry by its line and field.

use kestrel_proto::messages::MAX_MOTORS;
use serde::{Deserialize, Serialize};

use super::kind::{CameraLens, Fault, FaultKind, KINDS};
use crate::error::InvalidParam;

/// The flat table a `[[faults]]` entry is read from: every kind's values are optional here, and
/// [`Fault::try_from`] refuses those a kind does not have, so a typo is an error, not a default.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFault {
    at_s: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    for_s: Option<f64>,
    kind: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    ned_m: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    factor: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gauss: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    m_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rad_s: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    m_s2: Option<[f64; 3]>,
    /// Signed, so that 0 and −1 are refused as motor numbers rather than as integers.
    #[serde(skip_serializing_if = "Option::is_none")]
    motor: Option<i64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    thrust: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    volts: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ned_m_s: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gust_m_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    actor: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    region: Option<[f64; 4]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    intensity: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    lens: Option<String>,
}

impl RawFault {
    /// The names of the values present, for refusing those the kind lacks.
    fn present(&self) -> Vec<&'static str> {
        let mut present = Vec::new();
        let mut note = |name: &'static str, is: bool| {
            if is {
                present.push(name);
            }
        };
        note("ned_m", self.ned_m.is_some());
        note("factor", self.factor.is_some());
        note("gauss", self.gauss.is_some());
        note("m_s", self.m_s.is_some());
        note("rad_s", self.rad_s.is_some());
        note("m_s2", self.m_s2.is_some());
        note("motor", self.motor.is_some());
        note("thrust", self.thrust.is_some());
        note("volts", self.volts.is_some());
        note("ned_m_s", self.ned_m_s.is_some());
        note("gust_m_s", self.gust_m_s.is_some());
        note("actor", self.actor.is_some());
        note("region", self.region.is_some());
        note("intensity", self.intensity.is_some());
        note("lens", self.lens.is_some());
        present
    }
}

impl TryFrom<RawFault> for Fault {
    type Error = InvalidParam;

    fn try_from(raw: RawFault) -> Result<Fault, InvalidParam> {
        fn need<T: Clone>(kind: &str, field: &str, value: &Option<T>) -> Result<T, InvalidParam> {
            value.clone().ok_or_else(|| InvalidParam::new(field, format!("is required by kind `{kind}`")))
        }
        let k = raw.kind.as_str();
        let (kind, takes): (FaultKind, &[&str]) = match k {
            "gps_off" => (FaultKind::GpsOff, &[]),
            "gps_jump" => (FaultKind::GpsJump { ned_m: need(k, "ned_m", &raw.ned_m)? }, &["ned_m"]),
            "gps_noise" => (FaultKind::GpsNoise { factor: need(k, "factor", &raw.factor)? }, &["factor"]),
            "mag_anomaly" => (FaultKind::MagAnomaly { gauss: need(k, "gauss", &raw.gauss)? }, &["gauss"]),
            "mag_stuck" => (FaultKind::MagStuck, &[]),
            "baro_drift" => (FaultKind::BaroDrift { m_s: need(k, "m_s", &raw.m_s)? }, &["m_s"]),
            "baro_stuck" => (FaultKind::BaroStuck, &[]),
            "gyro_bias" => (FaultKind::GyroBias { rad_s: need(k, "rad_s", &raw.rad_s)? }, &["rad_s"]),
            "accel_bias" => (FaultKind::AccelBias { m_s2: need(k, "m_s2", &raw.m_s2)? }, &["m_s2"]),
            "accel_clip" => (FaultKind::AccelClip, &[]),
            "imu_stop" => (FaultKind::ImuStop, &[]),
            "motor_lost" => {
                (FaultKind::MotorLost { motor: motor_number(need(k, "motor", &raw.motor)?)? }, &["motor"])
            }
            "motor_weak" => (
                FaultKind::MotorWeak {
                    motor: motor_number(need(k, "motor", &raw.motor)?)?,
                    thrust: need(k, "thrust", &raw.thrust)?,
                },
                &["motor", "thrust"],
            ),
            "battery_sag" => (FaultKind::BatterySag { volts: need(k, "volts", &raw.volts)? }, &["volts"]),
            "wind" => (
                FaultKind::Wind {
                    ned_m_s: need(k, "ned_m_s", &raw.ned_m_s)?,
                    gust_m_s: raw.gust_m_s.unwrap_or(0.0),
                },
                &["ned_m_s", "gust_m_s"],
            ),
            "camera_stop" => (FaultKind::CameraStop, &[]),
            "camera_black" => (FaultKind::CameraBlack, &[]),
            "camera_frozen" => (FaultKind::CameraFrozen, &[]),
            "camera_glare" => (
                FaultKind::CameraGlare {
                    region: need(k, "region", &raw.region)?,
                    intensity: need(k, "intensity", &raw.intensity)?,
                    lens: raw.lens.as_deref().map_or(Ok(CameraLens::Both), CameraLens::parse)?,
                },
                &["region", "intensity", "lens"],
            ),
            "camera_capped" => (
                FaultKind::CameraCapped { lens: CameraLens::parse(&need(k, "lens", &raw.lens)?)? },
                &["lens"],
            ),
            "actor_panic" => (FaultKind::ActorPanic { actor: need(k, "actor", &raw.actor)? }, &["actor"]),
            "link_lost" => (FaultKind::LinkLost, &[]),
            other => {
                let known = KINDS.join(", ");
                return Err(InvalidParam::new(
                    "kind",
                    format!("`{other}` is not a fault kind (one of {known})"),
                ));
            }
        };
        if let Some(foreign) = raw.present().into_iter().find(|field| !takes.contains(field)) {
            return Err(InvalidParam::new(foreign, format!("is not a value of kind `{k}`")));
        }
        let fault = Fault { at_s: raw.at_s, for_s: raw.for_s, kind };
        fault.validate()?;
        Ok(fault)
    }
}

/// A motor number from the file: 1..=MAX_MOTORS (the frame's own count is checked when the
/// simulator starts, where the vehicle is known).
fn motor_number(motor: i64) -> Result<u8, InvalidParam> {
    u8::try_from(motor)
        .ok()
        .filter(|m| (1..=MAX_MOTORS).contains(&usize::from(*m)))
        .ok_or_else(|| InvalidParam::new("motor", format!("must be within 1..={MAX_MOTORS}, got {motor}")))
}

impl From<Fault> for RawFault {
    fn from(fault: Fault) -> RawFault {
        let mut raw = RawFault {
            at_s: fault.at_s,
            for_s: fault.for_s,
            kind: fault.kind.name().to_owned(),
            ..RawFault::default()
        };
        match fault.kind {
            FaultKind::GpsJump { ned_m } => raw.ned_m = Some(ned_m),
            FaultKind::GpsNoise { factor } => raw.factor = Some(factor),
            FaultKind::MagAnomaly { gauss } => raw.gauss = Some(gauss),
            FaultKind::BaroDrift { m_s } => raw.m_s = Some(m_s),
            FaultKind::GyroBias { rad_s } => raw.rad_s = Some(rad_s),
            FaultKind::AccelBias { m_s2 } => raw.m_s2 = Some(m_s2),
            FaultKind::MotorLost { motor } => raw.motor = Some(i64::from(motor)),
            FaultKind::MotorWeak { motor, thrust } => {
                raw.motor = Some(i64::from(motor));
                raw.thrust = Some(thrust);
            }
            FaultKind::BatterySag { volts } => raw.volts = Some(volts),
            FaultKind::Wind { ned_m_s, gust_m_s } => {
                raw.ned_m_s = Some(ned_m_s);
                raw.gust_m_s = Some(gust_m_s);
            }
            FaultKind::ActorPanic { actor } => raw.actor = Some(actor),
            FaultKind::CameraGlare { region, intensity, lens } => {
                raw.region = Some(region);
                raw.intensity = Some(intensity);
                raw.lens = Some(lens.name().to_owned());
            }
            FaultKind::CameraCapped { lens } => raw.lens = Some(lens.name().to_owned()),
            FaultKind::GpsOff
            | FaultKind::MagStuck
            | FaultKind::BaroStuck
            | FaultKind::AccelClip
            | FaultKind::ImuStop
            | FaultKind::CameraStop
            | FaultKind::CameraBlack
            | FaultKind::CameraFrozen
            | FaultKind::LinkLost => {}
        }
        raw
    }
}

/// Reads every `[[faults]]` entry of a world file's `text` on its own, so that a bad one is
/// reported with its line (1-based) and its field (`faults[i].thrust`). A file TOML cannot parse
/// at all passes here, for the ordinary parse to report.
pub(crate) fn check_entries(text: &str) -> Result<(), (usize, InvalidParam)> {
    #[derive(Deserialize)]
    struct Entries {
        #[serde(default)]
        faults: Vec<toml::Spanned<toml::Table>>,
    }
    let Ok(entries) = toml::from_str::<Entries>(text) else { return Ok(()) };
    for (i, entry) in entries.faults.iter().enumerate() {
        let line = text[..entry.span().start].matches('\n').count() + 1;
        let within = |e: InvalidParam| (line, e.within(&format!("faults[{i}]")));
        let raw = RawFault::deserialize(toml::Value::Table(entry.get_ref().clone()))
            .map_err(|e| (line, InvalidParam::new(format!("faults[{i}]"), e.message().trim().to_owned())))?;
        Fault::try_from(raw).map_err(within)?;
    }
    Ok(())
}

/// The 1-based line of each `[[faults]]` header in a world file's `text`, in order; empty when
/// the text is not TOML.
pub fn entry_lines(text: &str) -> Vec<usize> {
    #[derive(Deserialize)]
    struct Entries {
        #[serde(default)]
        faults: Vec<toml::Spanned<toml::Table>>,
    }
    toml::from_str::<Entries>(text)
        .map(|e| e.faults.iter().map(|f| text[..f.span().start].matches('\n').count() + 1).collect())
        .unwrap_or_default()
}

/// Checks a world's faults against the vehicle that flies in it (motor numbers within the
/// frame); the field is `faults[i].motor`.
pub(crate) fn check_for_vehicle(faults: &[Fault], motor_count: usize) -> Result<(), InvalidParam> {
    for (i, fault) in faults.iter().enumerate() {
        let within = |e: InvalidParam| e.within(&format!("faults[{i}]"));
        if let Some(motor) = fault.kind.motor()
            && usize::from(motor) > motor_count
        {
            return Err(within(InvalidParam::new(
                "motor",
                format!("is {motor}, but the vehicle's frame has motors 1..={motor_count}"),
            )));
        }
    }
    Ok(())
}

/// The fault a `sim_fault` start describes (its `kind` and `values` as the world file spells
/// them), from the message's time on, open-ended: the inverse of `FaultSchedule::message`, for
/// an actor that applies faults the simulator added while running (the camera's). The error
/// says what did not read.
pub fn fault_of_message(msg: &kestrel_proto::messages::SimFault) -> Result<Fault, String> {
    #[derive(Deserialize)]
    struct One {
        fault: Fault,
    }
    let values = if msg.values.is_empty() { String::new() } else { format!(", {}", msg.values) };
    let text = format!("fault = {{ at_s = {:?}, kind = {:?}{values} }}", msg.time.as_secs_f64(), msg.kind);
    toml::from_str::<One>(&text).map(|one| one.fault).map_err(|e| format!("sim_fault {}: {e}", msg.kind))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sim_fault_start_reads_back_as_the_fault_it_reports() {
        use kestrel_proto::Time;

        use crate::faults::FaultSchedule;
        use crate::live_faults::CAMERA_GLARE;
        for kind in [
            CAMERA_GLARE,
            FaultKind::CameraCapped { lens: CameraLens::Right },
            FaultKind::CameraBlack,
            FaultKind::GpsJump { ned_m: [50.0, -3.5, 0.0] },
        ] {
            let mut schedule = FaultSchedule::default();
            schedule.push(Fault { at_s: 12.0, for_s: None, kind: kind.clone() });
            let event = schedule.poll(Time::from_micros(12_020_000)).remove(0);
            let fault = fault_of_message(&schedule.message(&event)).expect("reads back");
            assert_eq!(fault, Fault { at_s: event.time.as_secs_f64(), for_s: None, kind });
        }
    }

    /// The faults of a world file's text (only `[[faults]]` entries), or the first error.
    fn parse(text: &str) -> Result<Vec<Fault>, (usize, InvalidParam)> {
        check_entries(text)?;
        #[derive(Deserialize)]
        struct Only {
            faults: Vec<Fault>,
        }
        Ok(toml::from_str::<Only>(text).expect("checked entries parse").faults)
    }

    fn one(entry: &str) -> Result<Fault, InvalidParam> {
        parse(&format!("[[faults]]\n{entry}\n")).map(|mut f| f.remove(0)).map_err(|(_, e)| e)
    }

    #[test]
    fn every_kind_parses_with_its_values() {
        let cases: [(&str, FaultKind); 22] = [
            ("kind = \"gps_off\"", FaultKind::GpsOff),
            (
                "kind = \"gps_jump\"\nned_m = [50.0, -2.0, 1.0]",
                FaultKind::GpsJump { ned_m: [50.0, -2.0, 1.0] },
            ),
            ("kind = \"gps_noise\"\nfactor = 4.0", FaultKind::GpsNoise { factor: 4.0 }),
            (
                "kind = \"mag_anomaly\"\ngauss = [0.3, 0.0, -0.1]",
                FaultKind::MagAnomaly { gauss: [0.3, 0.0, -0.1] },
            ),
            ("kind = \"mag_stuck\"", FaultKind::MagStuck),
            ("kind = \"baro_drift\"\nm_s = -1.0", FaultKind::BaroDrift { m_s: -1.0 }),
            ("kind = \"baro_stuck\"", FaultKind::BaroStuck),
            (
                "kind = \"gyro_bias\"\nrad_s = [0.087, 0.0, 0.0]",
                FaultKind::GyroBias { rad_s: [0.087, 0.0, 0.0] },
            ),
            ("kind = \"accel_bias\"\nm_s2 = [0.0, 0.5, 0.0]", FaultKind::AccelBias { m_s2: [0.0, 0.5, 0.0] }),
            ("kind = \"accel_clip\"", FaultKind::AccelClip),
            ("kind = \"imu_stop\"", FaultKind::ImuStop),
            ("kind = \"motor_lost\"\nmotor = 1", FaultKind::MotorLost { motor: 1 }),
            (
                "kind = \"motor_weak\"\nmotor = 2\nthrust = 0.7",
                FaultKind::MotorWeak { motor: 2, thrust: 0.7 },
            ),
            ("kind = \"battery_sag\"\nvolts = 1.5", FaultKind::BatterySag { volts: 1.5 }),
            (
                "kind = \"wind\"\nned_m_s = [12.0, 0.0, 0.0]\ngust_m_s = 4.0",
                FaultKind::Wind { ned_m_s: [12.0, 0.0, 0.0], gust_m_s: 4.0 },
            ),
            ("kind = \"camera_stop\"", FaultKind::CameraStop),
            ("kind = \"camera_black\"", FaultKind::CameraBlack),
            ("kind = \"camera_frozen\"", FaultKind::CameraFrozen),
            (
                "kind = \"camera_glare\"\nregion = [0.25, 0.2, 0.75, 0.8]\nintensity = 1.0\nlens = \"left\"",
                FaultKind::CameraGlare {
                    region: [0.25, 0.2, 0.75, 0.8],
                    intensity: 1.0,
                    lens: CameraLens::Left,
                },
            ),
            (
                "kind = \"camera_capped\"\nlens = \"right\"",
                FaultKind::CameraCapped { lens: CameraLens::Right },
            ),
            (
                "kind = \"actor_panic\"\nactor = \"estimator\"",
                FaultKind::ActorPanic { actor: "estimator".into() },
            ),
            ("kind = \"link_lost\"", FaultKind::LinkLost),
        ];
        for (values, kind) in cases {
            let fault = one(&format!("at_s = 12.5\nfor_s = 3.0\n{values}"))
                .unwrap_or_else(|e| panic!("{values}: {e}"));
            assert_eq!(fault, Fault { at_s: 12.5, for_s: Some(3.0), kind: kind.clone() }, "{values}");
            assert!(KINDS.contains(&kind.name()));
            // Written back, it reads the same.
            let text = toml::to_string(&std::collections::BTreeMap::from([("faults", vec![fault.clone()])]))
                .expect("serialises");
            assert_eq!(parse(&text).expect("round trip"), [fault], "{text}");
        }
        let gentle = one("at_s = 0\nkind = \"wind\"\nned_m_s = [3.0, 0.0, 0.0]").expect("gusts optional");
        assert_eq!(gentle.kind, FaultKind::Wind { ned_m_s: [3.0, 0.0, 0.0], gust_m_s: 0.0 });
        assert_eq!(gentle.for_s, None, "omitted: to the end");
    }

    #[test]
    fn bad_values_are_refused_naming_the_field() {
        let cases = [
            ("at_s = -1.0\nkind = \"gps_off\"", "at_s"),
            ("at_s = nan\nkind = \"gps_off\"", "at_s"),
            ("at_s = inf\nkind = \"gps_off\"", "at_s"),
            ("at_s = 1.0\nfor_s = -5.0\nkind = \"gps_off\"", "for_s"),
            ("at_s = 1.0\nfor_s = 0.0\nkind = \"gps_off\"", "for_s"),
            ("at_s = 1.0\nfor_s = inf\nkind = \"gps_off\"", "for_s"),
            ("at_s = 1.0\nkind = \"gps_jump\"\nned_m = [nan, 0.0, 0.0]", "ned_m"),
            ("at_s = 1.0\nkind = \"gps_jump\"", "ned_m"),
            ("at_s = 1.0\nkind = \"gps_noise\"\nfactor = -2.0", "factor"),
            ("at_s = 1.0\nkind = \"gps_noise\"\nfactor = inf", "factor"),
            ("at_s = 1.0\nkind = \"mag_anomaly\"\ngauss = [0.0, -inf, 0.0]", "gauss"),
            ("at_s = 1.0\nkind = \"baro_drift\"\nm_s = nan", "m_s"),
            ("at_s = 1.0\nkind = \"gyro_bias\"\nrad_s = [0.0, 0.0, nan]", "rad_s"),
            ("at_s = 1.0\nkind = \"accel_bias\"\nm_s2 = [inf, 0.0, 0.0]", "m_s2"),
            ("at_s = 1.0\nkind = \"motor_lost\"\nmotor = 0", "motor"),
            ("at_s = 1.0\nkind = \"motor_lost\"\nmotor = -1", "motor"),
            ("at_s = 1.0\nkind = \"motor_lost\"\nmotor = 9", "motor"),
            ("at_s = 1.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = 1.5", "thrust"),
            ("at_s = 1.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = -0.1", "thrust"),
            ("at_s = 1.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = nan", "thrust"),
            ("at_s = 1.0\nkind = \"motor_weak\"\nmotor = 1", "thrust"),
            ("at_s = 1.0\nkind = \"battery_sag\"\nvolts = -1.0", "volts"),
            ("at_s = 1.0\nkind = \"wind\"\nned_m_s = [nan, 0.0, 0.0]", "ned_m_s"),
            ("at_s = 1.0\nkind = \"wind\"\nned_m_s = [1.0, 0.0, 0.0]\ngust_m_s = -1.0", "gust_m_s"),
            ("at_s = 1.0\nkind = \"actor_panic\"\nactor = \" \"", "actor"),
            ("at_s = 1.0\nkind = \"camera_glare\"\nregion = [0.5, 0.0, 0.4, 1.0]\nintensity = 1.0", "region"),
            ("at_s = 1.0\nkind = \"camera_glare\"\nregion = [0.0, 0.0, 1.0, 1.5]\nintensity = 1.0", "region"),
            (
                "at_s = 1.0\nkind = \"camera_glare\"\nregion = [0.0, 0.0, 1.0, 1.0]\nintensity = 1.2",
                "intensity",
            ),
            ("at_s = 1.0\nkind = \"camera_glare\"\nregion = [0.0, 0.0, 1.0, 1.0]", "intensity"),
            (
                "at_s = 1.0\nkind = \"camera_glare\"\nregion = [0.0, 0.0, 1.0, 1.0]\nintensity = 1.0\nlens = \"up\"",
                "lens",
            ),
            ("at_s = 1.0\nkind = \"camera_capped\"", "lens"),
            ("at_s = 1.0\nkind = \"camera_capped\"\nlens = \"both\"", "lens"),
            // A value of another kind, and a kind that does not exist.
            ("at_s = 1.0\nkind = \"gps_off\"\nfactor = 2.0", "factor"),
            ("at_s = 1.0\nkind = \"gps_of\"", "kind"),
        ];
        for (entry, field) in cases {
            let err = one(entry).expect_err(entry);
            assert_eq!(err.field, format!("faults[0].{field}"), "{entry}: {err}");
        }
        // Keys no kind has, and missing times, are TOML-level errors naming the entry.
        for entry in ["at_s = 1.0\nkind = \"gps_off\"\nduration_s = 2.0", "kind = \"gps_off\""] {
            let err = one(entry).expect_err(entry);
            assert_eq!(err.field, "faults[0]", "{entry}: {err}");
        }
    }

    #[test]
    fn a_bad_entry_is_located_by_its_line() {
        let text = "[home]\nlat_deg = 6.8\n\n[[faults]]\nat_s = 1.0\nkind = \"gps_off\"\n\n\
                    [[faults]]\nat_s = 2.0\nkind = \"motor_weak\"\nmotor = 1\nthrust = 1.5\n";
        let (line, err) = parse(text).expect_err("thrust > 1");
        assert_eq!((line, err.field.as_str()), (8, "faults[1].thrust"), "{err}");
        assert_eq!(entry_lines(text), [4, 8]);
    }

    #[test]
    fn motors_outside_the_frame_are_refused_at_start() {
        let weak =
            |motor| Fault { at_s: 1.0, for_s: None, kind: FaultKind::MotorWeak { motor, thrust: 0.5 } };
        assert_eq!(check_for_vehicle(&[weak(4)], 4), Ok(()));
        assert_eq!(check_for_vehicle(&[weak(6)], 6), Ok(()));
        let err = check_for_vehicle(&[weak(1), weak(5)], 4).expect_err("quad has no motor 5");
        assert_eq!(err.field, "faults[1].motor");
        let panic =
            Fault { at_s: 1.0, for_s: None, kind: FaultKind::ActorPanic { actor: "estimator".into() } };
        assert_eq!(check_for_vehicle(&[panic], 4), Ok(()), "the runtime's to check");
    }
}
