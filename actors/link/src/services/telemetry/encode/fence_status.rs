//! FENCE_STATUS: the commander's geofence breaches, as ArduCopter's `AC_Fence::send_fence_status`
//! fills it — sent only while the fence is on; the type is that of the fences breached now
//! (a boundary before a ceiling before a floor, NONE once back inside); the count and the time
//! (ms since boot) of the latest breach stay. No fence-avoidance runs here, so no mitigation.

use kestrel_proto::messages::{FENCE_ALT_MAX, FENCE_ALT_MIN, FENCE_CIRCLE, FENCE_POLYGON, VehicleStatus};
use mavlink::dialects::ardupilotmega::{FENCE_STATUS_DATA, FenceBreach, FenceMitigate};

/// FENCE_STATUS from the commander's status; `None` while the fence is off.
pub fn fence_status(status: &VehicleStatus) -> Option<FENCE_STATUS_DATA> {
    if !status.geofence_enabled {
        return None;
    }
    let f = status.fence;
    let breach_type = if f.breaches & (FENCE_CIRCLE | FENCE_POLYGON) != 0 {
        FenceBreach::FENCE_BREACH_BOUNDARY
    } else if f.breaches & FENCE_ALT_MAX != 0 {
        FenceBreach::FENCE_BREACH_MAXALT
    } else if f.breaches & FENCE_ALT_MIN != 0 {
        FenceBreach::FENCE_BREACH_MINALT
    } else {
        FenceBreach::FENCE_BREACH_NONE
    };
    Some(FENCE_STATUS_DATA {
        breach_time: f.breach_time.map_or(0, |t| (t.as_micros() / 1000) as u32),
        breach_count: f.breach_count,
        breach_status: u8::from(f.breaches != 0),
        breach_type,
        breach_mitigation: FenceMitigate::FENCE_MITIGATE_NONE,
    })
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::{FenceStatus, FlightMode, LandedState};
    use kestrel_proto::testing::vehicle_status;

    use super::*;

    #[test]
    fn fence_status_says_what_is_breached_now_and_keeps_the_count_and_time() {
        let mut s = vehicle_status(Time::ZERO, true, FlightMode::Guided, LandedState::InAir);
        assert_eq!(fence_status(&s).map(|f| (f.breach_status, f.breach_count)), Some((0, 0)));
        s.fence = FenceStatus {
            breaches: FENCE_ALT_MAX | FENCE_POLYGON,
            breach_count: 2,
            breach_time: Some(Time::from_secs_f64(12.5)),
        };
        let f = fence_status(&s).expect("on");
        assert_eq!((f.breach_status, f.breach_count, f.breach_time), (1, 2, 12_500));
        assert_eq!(f.breach_type, FenceBreach::FENCE_BREACH_BOUNDARY);
        s.fence.breaches = FENCE_ALT_MAX;
        assert_eq!(fence_status(&s).map(|f| f.breach_type), Some(FenceBreach::FENCE_BREACH_MAXALT));
        s.fence.breaches = FENCE_ALT_MIN;
        assert_eq!(fence_status(&s).map(|f| f.breach_type), Some(FenceBreach::FENCE_BREACH_MINALT));
        s.fence.breaches = 0;
        let f = fence_status(&s).expect("on");
        assert_eq!((f.breach_status, f.breach_count, f.breach_type), (0, 2, FenceBreach::FENCE_BREACH_NONE));
        s.geofence_enabled = false;
        assert!(fence_status(&s).is_none(), "off: not sent");
    }
}
