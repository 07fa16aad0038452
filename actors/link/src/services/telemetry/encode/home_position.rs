//! HOME_POSITION: the commander's home (set at arming or by DO_SET_HOME) in WGS-84 and in the
//! estimator's NED frame; before the commander has one, the estimator's origin, where the
//! vehicle started.

use kestrel_proto::Time;
use kestrel_proto::geo::{LocalFrame, deg_e7};
use mavlink::dialects::ardupilotmega::HOME_POSITION_DATA;

use super::super::Snapshot;

/// HOME_POSITION at `now`; `None` before the estimator has a geodetic origin.
pub fn home_position(snap: &Snapshot, now: Time) -> Option<HOME_POSITION_DATA> {
    let origin = snap.nav.as_ref()?.origin?;
    let [n, e, d] = snap.status.as_ref().and_then(|s| s.home).map_or([0.0; 3], |h| h.position_ned_m);
    let home = LocalFrame::new(origin).to_geodetic([n, e, 0.0]);
    Some(HOME_POSITION_DATA {
        latitude: deg_e7(home.lat_deg),
        longitude: deg_e7(home.lon_deg),
        // One altitude convention with the mission's: down is height below the origin.
        altitude: ((origin.alt_m - d) * 1000.0).round() as i32,
        x: n as f32,
        y: e as f32,
        z: d as f32,
        q: [1.0, 0.0, 0.0, 0.0],
        time_usec: now.as_micros(),
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::{FlightMode, Home, LandedState, VehicleStatus};
    use kestrel_proto::testing::vehicle_status;

    use super::*;
    use crate::services::telemetry::encode::nav_facing_east;

    #[test]
    fn home_position_follows_the_commanders_home() {
        let mut snap = Snapshot { nav: Some(nav_facing_east()), ..Snapshot::default() };
        let origin = home_position(&snap, Time::ZERO).expect("an origin");
        assert_eq!((origin.latitude, origin.longitude, origin.altitude), (67_971_000, 799_017_000, 20_000));
        snap.status = Some(VehicleStatus {
            home: Some(Home { position_ned_m: [110.6, 0.0, -5.0], revision: 2 }),
            ..vehicle_status(Time::ZERO, true, FlightMode::PosHold, LandedState::InAir)
        });
        let moved = home_position(&snap, Time::ZERO).expect("an origin");
        assert!((moved.latitude - 67_981_000).abs() < 20, "{}", moved.latitude);
        assert_eq!((moved.longitude, moved.altitude), (799_017_000, 25_000));
        assert_eq!((moved.x, moved.y, moved.z), (110.6, 0.0, -5.0));
        snap.nav.as_mut().expect("set").origin = None;
        assert!(home_position(&snap, Time::ZERO).is_none(), "no origin, no home to show");
    }
}
