//! POSITION_TARGET_GLOBAL_INT: where the vehicle is flying to, as ArduCopter's
//! `send_position_target_global_int` reports its mode's destination: the setpoint's position
//! (all three axes held) converted to WGS-84 around the estimator's origin, altitude above mean
//! sea level in MAV_FRAME_GLOBAL, every other field ignored. Nothing when no position is held.

use kestrel_proto::geo::{LocalFrame, deg_e7};
use kestrel_proto::messages::SetpointTarget;
use mavlink::dialects::ardupilotmega::{MavFrame, POSITION_TARGET_GLOBAL_INT_DATA, PositionTargetTypemask};

use super::super::Snapshot;

/// POSITION_TARGET_GLOBAL_INT of the position the setpoint holds, stamped `boot_ms`.
pub fn position_target_global_int(snap: &Snapshot, boot_ms: u32) -> Option<POSITION_TARGET_GLOBAL_INT_DATA> {
    let sp = snap.setpoint.as_ref().filter(|s| s.armed)?;
    let SetpointTarget::Trajectory(t) = &sp.target else { return None };
    let [Some(n), Some(e), Some(d)] = t.position_ned_m else { return None };
    let origin = snap.nav.as_ref()?.origin?;
    let p = LocalFrame::new(origin).to_geodetic([n, e, d]);
    use PositionTargetTypemask as M;
    Some(POSITION_TARGET_GLOBAL_INT_DATA {
        time_boot_ms: boot_ms,
        lat_int: deg_e7(p.lat_deg),
        lon_int: deg_e7(p.lon_deg),
        alt: p.alt_m as f32,
        type_mask: M::all().difference(
            M::POSITION_TARGET_TYPEMASK_X_IGNORE
                | M::POSITION_TARGET_TYPEMASK_Y_IGNORE
                | M::POSITION_TARGET_TYPEMASK_Z_IGNORE
                | M::POSITION_TARGET_TYPEMASK_FORCE_SET,
        ),
        coordinate_frame: MavFrame::MAV_FRAME_GLOBAL,
        ..POSITION_TARGET_GLOBAL_INT_DATA::DEFAULT
    })
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::{FlightMode, TrajectorySetpoint};

    use super::*;
    use crate::services::telemetry::encode::position_target_local_ned::tests::flying;

    #[test]
    fn the_held_position_goes_out_above_sea_level() {
        let t = TrajectorySetpoint {
            position_ned_m: [Some(0.0), Some(0.0), Some(-30.0)],
            ..TrajectorySetpoint::default()
        };
        let snap = flying(FlightMode::Auto, SetpointTarget::Trajectory(t));
        let m = position_target_global_int(&snap, 5).expect("a position is held");
        assert_eq!((m.lat_int, m.lon_int), (67_971_000, 799_017_000), "the origin");
        assert!((m.alt - 50.0).abs() < 1e-3, "30 m above a 20 m origin: {}", m.alt);
        assert_eq!(m.coordinate_frame, MavFrame::MAV_FRAME_GLOBAL);
        assert!(m.type_mask.contains(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VX_IGNORE));
        assert!(!m.type_mask.contains(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_X_IGNORE));
        let free = TrajectorySetpoint { position_ned_m: [None, None, Some(-30.0)], ..t };
        assert!(
            position_target_global_int(&flying(FlightMode::Guided, SetpointTarget::Trajectory(free)), 0)
                .is_none()
        );
    }
}
