//! STATUSTEXT for what the commander does: arming, mode changes, the geofence switch,
//! failsafes and refusals.

use kestrel_proto::messages::{FailsafeCause, VehicleStatus};
use mavlink::dialects::ardupilotmega::{MavMessage, MavSeverity, STATUSTEXT_DATA};

use crate::modes::mode_name;

/// A STATUSTEXT carrying `text` (cut to MAVLink's 50 characters).
pub fn statustext(severity: MavSeverity, text: &str) -> MavMessage {
    let mut bytes = [0u8; 50];
    let mut n = 0;
    for c in text.chars() {
        let len = c.len_utf8();
        if n + len > bytes.len() {
            break;
        }
        c.encode_utf8(&mut bytes[n..]);
        n += len;
    }
    MavMessage::STATUSTEXT(STATUSTEXT_DATA { severity, text: bytes.into(), id: 0, chunk_seq: 0 })
}

fn cause_text(cause: FailsafeCause) -> &'static str {
    match cause {
        FailsafeCause::DataLinkLost => "GCS link lost",
        FailsafeCause::BatteryLow => "battery low",
        FailsafeCause::BatteryCritical => "battery critical",
        FailsafeCause::GeofenceBreach => "geofence breach",
        FailsafeCause::EstimatorUnhealthy => "EKF unhealthy",
        FailsafeCause::NavStateStale => "navigation stale",
        FailsafeCause::CriticalActorFailed => "critical task failed",
        FailsafeCause::ManualControlLost => "radio (sticks) lost",
        FailsafeCause::MotorFailure => "motor failure",
        FailsafeCause::AvoidanceLost => "obstacle data lost",
    }
}

/// STATUSTEXTs for what changed between two statuses (`old = None`: the first one).
pub fn status_changes(old: Option<&VehicleStatus>, new: &VehicleStatus) -> Vec<MavMessage> {
    let mut out = Vec::new();
    if old.map(|o| o.armed) != Some(new.armed) && old.is_some() {
        out.push(statustext(MavSeverity::MAV_SEVERITY_INFO, if new.armed { "Armed" } else { "Disarmed" }));
    }
    if old.map(|o| o.mode) != Some(new.mode) && old.is_some() {
        out.push(statustext(MavSeverity::MAV_SEVERITY_INFO, &format!("Mode {}", mode_name(new.mode))));
    }
    if let Some(o) = old
        && o.geofence_enabled != new.geofence_enabled
    {
        let text = if new.geofence_enabled { "Geofence enabled" } else { "Geofence disabled" };
        out.push(statustext(MavSeverity::MAV_SEVERITY_NOTICE, text));
    }
    let old_failsafe = old.and_then(|o| o.failsafe);
    match (old_failsafe, new.failsafe) {
        (None, Some(f)) => out.push(statustext(
            MavSeverity::MAV_SEVERITY_CRITICAL,
            &format!("Failsafe: {}, {:?}", cause_text(f.cause), f.action),
        )),
        (Some(a), Some(b)) if (a.cause, a.action) != (b.cause, b.action) => out.push(statustext(
            MavSeverity::MAV_SEVERITY_CRITICAL,
            &format!("Failsafe: {}, {:?}", cause_text(b.cause), b.action),
        )),
        (Some(_), None) => out.push(statustext(MavSeverity::MAV_SEVERITY_INFO, "Failsafe cleared")),
        _ => {}
    }
    if let Some(refusal) = &new.last_refusal
        && old.is_none_or(|o| o.refusals != new.refusals || o.last_refusal.as_ref() != Some(refusal))
    {
        out.push(statustext(MavSeverity::MAV_SEVERITY_WARNING, refusal));
    }
    out
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::{Failsafe, FailsafeAction, FlightMode, LandedState};
    use kestrel_proto::testing::vehicle_status;

    use super::*;

    fn text(m: &MavMessage) -> String {
        match m {
            MavMessage::STATUSTEXT(s) => {
                s.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned()
            }
            other => panic!("not a STATUSTEXT: {other:?}"),
        }
    }

    #[test]
    fn arming_mode_failsafe_and_refusal_are_announced() {
        let a = vehicle_status(Time::ZERO, false, FlightMode::Stabilize, LandedState::OnGround);
        assert!(status_changes(None, &a).is_empty());
        let b = VehicleStatus {
            armed: true,
            mode: FlightMode::ReturnToLaunch,
            failsafe: Some(Failsafe {
                cause: FailsafeCause::DataLinkLost,
                action: FailsafeAction::ReturnToLaunch,
                since: Time::ZERO,
            }),
            last_refusal: Some("Arm: no GPS fix".into()),
            refusals: 0,
            armable: false,
            ..a.clone()
        };
        let texts: Vec<String> = status_changes(Some(&a), &b).iter().map(text).collect();
        assert_eq!(
            texts,
            ["Armed", "Mode RTL", "Failsafe: GCS link lost, ReturnToLaunch", "Arm: no GPS fix"]
        );
        assert!(status_changes(Some(&b), &b).is_empty());
        let fence_off = VehicleStatus { geofence_enabled: false, ..b.clone() };
        let texts: Vec<String> = status_changes(Some(&b), &fence_off).iter().map(text).collect();
        assert_eq!(texts, ["Geofence disabled"]);
        let texts: Vec<String> = status_changes(Some(&fence_off), &b).iter().map(text).collect();
        assert_eq!(texts, ["Geofence enabled"]);
    }

    #[test]
    fn long_texts_are_cut_to_fifty_bytes() {
        let long = "x".repeat(80);
        assert_eq!(text(&statustext(MavSeverity::MAV_SEVERITY_INFO, &long)).len(), 50);
    }
}
