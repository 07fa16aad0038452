//! STATUSTEXT for what the commander does: arming, mode changes, the geofence switch,
//! failsafes, the speed cap, the rangefinders' vertical limits and refusals.

use kestrel_proto::messages::{
    FailsafeCause, SpeedCapStatus, VehicleStatus, VerticalLimitKind, VerticalLimitStatus,
};
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
    if let Some(text) = speed_cap_change(old.and_then(|o| o.speed_cap), new.speed_cap) {
        out.push(statustext(MavSeverity::MAV_SEVERITY_INFO, &text));
    }
    if let Some(text) = vertical_limit_change(old.and_then(|o| o.vertical_limit), new.vertical_limit) {
        out.push(statustext(MavSeverity::MAV_SEVERITY_WARNING, &text));
    }
    if let Some(refusal) = &new.last_refusal
        && old.is_none_or(|o| o.refusals != new.refusals || o.last_refusal.as_ref() != Some(refusal))
    {
        out.push(statustext(MavSeverity::MAV_SEVERITY_WARNING, refusal));
    }
    out
}

/// What a ground station is told of the forward speed cap: when it starts to hold
/// the vehicle back or the reason changes while it does, the cap, the range and the reason;
/// when it stops, that it has. Its figures alone moving is no news.
fn speed_cap_change(old: Option<SpeedCapStatus>, new: Option<SpeedCapStatus>) -> Option<String> {
    let limiting = |c: Option<SpeedCapStatus>| c.filter(|c| c.limiting);
    match (limiting(old), limiting(new)) {
        (Some(a), Some(b)) if a.reason == b.reason => None,
        (_, Some(c)) => Some(format!(
            "Speed capped at {:.1} m/s: {} {:.1} m ahead",
            c.cap_m_s,
            c.reason.as_str(),
            c.range_m
        )),
        (Some(_), None) => Some("Speed cap lifted".to_owned()),
        (None, None) => None,
    }
}

/// What a ground station is told when a rangefinder starts or stops holding the vehicle
/// vertically: the kind and the distance when it starts or changes kind, and that it
/// ended; the distance alone moving is no news.
fn vertical_limit_change(
    old: Option<VerticalLimitStatus>,
    new: Option<VerticalLimitStatus>,
) -> Option<String> {
    match (old, new) {
        (Some(a), Some(b)) if a.kind == b.kind => None,
        (_, Some(v)) => Some(match v.kind {
            VerticalLimitKind::Overhead => {
                format!("Climb held: {} {:.1} m above", v.kind.as_str(), v.distance_m)
            }
            VerticalLimitKind::ObstacleBelow => {
                format!("Landing: {} {:.1} m down, moving off", v.kind.as_str(), v.distance_m)
            }
        }),
        (Some(_), None) => Some("Vertical limit lifted".to_owned()),
        (None, None) => None,
    }
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

    #[test]
    fn the_speed_cap_is_announced_when_it_holds_back_changes_reason_and_lifts() {
        use kestrel_proto::messages::ClearRangeReason;
        let base = vehicle_status(Time::ZERO, true, FlightMode::PosHold, LandedState::InAir);
        let cap = |cap_m_s, range_m, reason, limiting| VehicleStatus {
            speed_cap: Some(SpeedCapStatus { cap_m_s, range_m, reason, limiting }),
            ..base.clone()
        };
        let untextured = cap(2.75, 4.0, ClearRangeReason::Untextured, true);
        let texts = |old: &VehicleStatus, new: &VehicleStatus| -> Vec<String> {
            status_changes(Some(old), new).iter().map(text).collect()
        };
        assert_eq!(texts(&base, &untextured), ["Speed capped at 2.8 m/s: untextured 4.0 m ahead"]);
        // The figures moving is no news; a cap that does not hold the vehicle back is none.
        assert!(texts(&untextured, &cap(2.5, 3.5, ClearRangeReason::Untextured, true)).is_empty());
        assert!(texts(&base, &cap(9.0, 20.0, ClearRangeReason::StereoRange, false)).is_empty());
        assert_eq!(
            texts(&untextured, &cap(0.0, 0.0, ClearRangeReason::UnknownAhead, true)),
            ["Speed capped at 0.0 m/s: unknown ahead 0.0 m ahead"]
        );
        assert_eq!(texts(&untextured, &base), ["Speed cap lifted"]);
    }

    #[test]
    fn a_vertical_limit_is_announced_when_it_starts_changes_kind_and_lifts() {
        let base = vehicle_status(Time::ZERO, true, FlightMode::Takeoff, LandedState::InAir);
        let limit = |kind, distance_m| VehicleStatus {
            vertical_limit: Some(VerticalLimitStatus { kind, distance_m }),
            ..base.clone()
        };
        let texts = |a: &VehicleStatus, b: &VehicleStatus| -> Vec<String> {
            status_changes(Some(a), b).iter().map(text).collect()
        };
        let overhead = limit(VerticalLimitKind::Overhead, 3.96);
        assert_eq!(texts(&base, &overhead), ["Climb held: obstacle overhead 4.0 m above"]);
        assert!(texts(&overhead, &limit(VerticalLimitKind::Overhead, 2.5)).is_empty());
        let below = limit(VerticalLimitKind::ObstacleBelow, 6.0);
        assert_eq!(texts(&overhead, &below), ["Landing: obstacle below 6.0 m down, moving off"]);
        assert_eq!(texts(&below, &base), ["Vertical limit lifted"]);
    }
}
