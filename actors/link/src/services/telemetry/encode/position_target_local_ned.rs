//! POSITION_TARGET_LOCAL_NED: what GUIDED is really flying, from the commander's setpoint (not an
//! echo of what a ground station sent): the position, velocity and acceleration of each axis the
//! trajectory holds, in the estimator's NED frame, and its yaw and yaw rate. As ArduCopter's
//! `send_position_target_local_ned`: only in GUIDED, and nothing while an attitude is flown.

use kestrel_proto::messages::{FlightMode, SetpointTarget, TrajectorySetpoint};
use mavlink::dialects::ardupilotmega::{MavFrame, POSITION_TARGET_LOCAL_NED_DATA, PositionTargetTypemask};

use super::super::Snapshot;

/// The ignore bits of the axes a trajectory leaves free: a `None` position or velocity axis is
/// ignored; the acceleration is always the feed-forward flown; the yaw when it holds the heading.
pub fn type_mask(sp: &TrajectorySetpoint) -> PositionTargetTypemask {
    use PositionTargetTypemask as M;
    let position = [
        M::POSITION_TARGET_TYPEMASK_X_IGNORE,
        M::POSITION_TARGET_TYPEMASK_Y_IGNORE,
        M::POSITION_TARGET_TYPEMASK_Z_IGNORE,
    ];
    let velocity = [
        M::POSITION_TARGET_TYPEMASK_VX_IGNORE,
        M::POSITION_TARGET_TYPEMASK_VY_IGNORE,
        M::POSITION_TARGET_TYPEMASK_VZ_IGNORE,
    ];
    let mut mask = M::empty();
    for i in 0..3 {
        if sp.position_ned_m[i].is_none() {
            mask |= position[i];
        }
        if sp.velocity_ned_m_s[i].is_none() {
            mask |= velocity[i];
        }
    }
    if sp.yaw_rad.is_none() {
        mask |= M::POSITION_TARGET_TYPEMASK_YAW_IGNORE;
    }
    mask
}

/// The trajectory being flown, in GUIDED only.
pub fn guided_trajectory(snap: &Snapshot) -> Option<&TrajectorySetpoint> {
    let status = snap.status.as_ref()?;
    let sp = snap.setpoint.as_ref()?;
    match &sp.target {
        SetpointTarget::Trajectory(t) if status.mode == FlightMode::Guided && sp.armed => Some(t),
        _ => None,
    }
}

/// POSITION_TARGET_LOCAL_NED of the setpoint flown in GUIDED, stamped `boot_ms`; ignored axes
/// read 0.
pub fn position_target_local_ned(snap: &Snapshot, boot_ms: u32) -> Option<POSITION_TARGET_LOCAL_NED_DATA> {
    let t = guided_trajectory(snap)?;
    let [x, y, z] = t.position_ned_m.map(|v| v.unwrap_or(0.0) as f32);
    let [vx, vy, vz] = t.velocity_ned_m_s.map(|v| v.unwrap_or(0.0) as f32);
    let [afx, afy, afz] = t.acceleration_ned_m_s2.map(|v| v as f32);
    Some(POSITION_TARGET_LOCAL_NED_DATA {
        time_boot_ms: boot_ms,
        x,
        y,
        z,
        vx,
        vy,
        vz,
        afx,
        afy,
        afz,
        yaw: t.yaw_rad.unwrap_or(0.0) as f32,
        yaw_rate: t.yaw_rate_rad_s as f32,
        type_mask: type_mask(t),
        coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::{LandedState, Setpoint};
    use kestrel_proto::testing::vehicle_status;

    use super::*;

    /// A snapshot in `mode`, armed, flying `target`.
    pub(crate) fn flying(mode: FlightMode, target: SetpointTarget) -> Snapshot {
        Snapshot {
            status: Some(vehicle_status(Time::ZERO, true, mode, LandedState::InAir)),
            setpoint: Some(Setpoint {
                time: Time::ZERO,
                armed: true,
                target,
                landing: false,
                failed_motor: None,
            }),
            nav: Some(crate::services::telemetry::encode::nav_facing_east()),
            ..Snapshot::default()
        }
    }

    #[test]
    fn the_guided_trajectory_is_sent_with_the_axes_it_leaves_free_ignored() {
        let t = TrajectorySetpoint {
            position_ned_m: [None, None, Some(-10.0)],
            velocity_ned_m_s: [Some(2.0), Some(-1.0), None],
            acceleration_ned_m_s2: [0.5, 0.0, 0.0],
            yaw_rad: Some(1.5),
            yaw_rate_rad_s: 0.25,
            ..TrajectorySetpoint::default()
        };
        let m = position_target_local_ned(&flying(FlightMode::Guided, SetpointTarget::Trajectory(t)), 42)
            .expect("sent in GUIDED");
        assert_eq!((m.x, m.y, m.z, m.vx, m.vy, m.vz), (0.0, 0.0, -10.0, 2.0, -1.0, 0.0));
        assert_eq!((m.afx, m.yaw, m.yaw_rate, m.time_boot_ms), (0.5, 1.5, 0.25, 42));
        use PositionTargetTypemask as M;
        assert_eq!(
            m.type_mask,
            M::POSITION_TARGET_TYPEMASK_X_IGNORE
                | M::POSITION_TARGET_TYPEMASK_Y_IGNORE
                | M::POSITION_TARGET_TYPEMASK_VZ_IGNORE
        );
        assert_eq!(m.coordinate_frame, MavFrame::MAV_FRAME_LOCAL_NED);
        let auto = flying(FlightMode::Auto, SetpointTarget::Trajectory(t));
        assert!(position_target_local_ned(&auto, 0).is_none(), "GUIDED only, as ArduCopter");
        let attitude =
            SetpointTarget::Attitude { attitude: [1.0, 0.0, 0.0, 0.0], yaw_rate_rad_s: 0.0, thrust: 0.5 };
        assert!(position_target_local_ned(&flying(FlightMode::Guided, attitude), 0).is_none());
    }
}
