//! A Kestrel MCAP log as a [`FlightLog`]: every topic recorded under a sensor type's schema is a
//! sensor topic; the first `NavState` topic is the log's own estimate and the first
//! `GroundTruth` topic (a simulator run) its truth. Our messages are already stamped with their
//! measurement time, so no lag is recorded or applied.

use kestrel_proto::Message;
use kestrel_proto::messages::{GroundTruth, NavState};

use super::{
    FlightLog, FlightLogError, Format, Kind, LogTopic, LoggedSettings, Place, Reference, ReferencePosition,
    ReferenceSample, SensorTopic,
};
use crate::recorder::LogReader;

pub(super) fn read(log: LogReader) -> Result<FlightLog, FlightLogError> {
    let recorded = log.topics();
    let mut sensors = Vec::new();
    for info in &recorded {
        if let Some(kind) = Kind::of_type(&info.schema_name) {
            sensors.push(SensorTopic {
                name: info.topic.clone(),
                kind,
                samples: kind.read(&log, &info.topic)?,
            });
        }
    }
    let first_of =
        |type_name: &str| recorded.iter().find(|t| t.schema_name == type_name).map(|t| t.topic.clone());
    let estimate = match first_of(NavState::TYPE_NAME) {
        Some(topic) => Some(Reference {
            label: "the recorded nav_state",
            samples: log.read::<NavState>(&topic)?.into_iter().map(|r| estimate_sample(&r.message)).collect(),
            align_height: false,
        }),
        None => None,
    };
    let truth = match first_of(GroundTruth::TYPE_NAME) {
        Some(topic) => Some(Reference {
            label: "ground truth",
            samples: log.read::<GroundTruth>(&topic)?.into_iter().map(|r| truth_sample(&r.message)).collect(),
            align_height: false,
        }),
        None => None,
    };
    Ok(FlightLog {
        path: log.path().to_owned(),
        format: Format::Mcap,
        topics: recorded
            .iter()
            .map(|t| LogTopic { name: t.topic.clone(), type_name: t.schema_name.clone() })
            .collect(),
        sensors,
        estimate,
        truth,
        settings: LoggedSettings::default(),
        damage: log.damage().map(ToString::to_string),
    })
}

fn estimate_sample(nav: &NavState) -> ReferenceSample {
    ReferenceSample {
        time: nav.time,
        attitude: nav.valid.attitude.then_some(nav.attitude),
        position: Some(ReferencePosition {
            place: Place::Local { ned_m: nav.position_ned_m, origin: nav.origin },
            horizontal_valid: nav.valid.horizontal_position,
            vertical_valid: nav.valid.vertical_position,
        }),
    }
}

fn truth_sample(truth: &GroundTruth) -> ReferenceSample {
    ReferenceSample {
        time: truth.time,
        attitude: Some(truth.attitude),
        position: Some(ReferencePosition {
            place: Place::Global(kestrel_proto::geo::Geodetic {
                lat_deg: truth.lat_deg,
                lon_deg: truth.lon_deg,
                alt_m: truth.alt_msl_m,
            }),
            horizontal_valid: true,
            vertical_valid: true,
        }),
    }
}
