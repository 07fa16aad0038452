//! Direct control from outside: MANUAL_CONTROL sticks and SET_POSITION_TARGET_LOCAL_NED /
//! GLOBAL_INT guided targets. Non-finite or out-of-range input is refused and counted.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame, deg_from_e7};
use kestrel_proto::messages::{Command, ManualControl, StickSource};
use mavlink::dialects::ardupilotmega::{
    MANUAL_CONTROL_DATA, MavFrame, MavMessage, POSITION_TARGET_GLOBAL_INT_DATA,
    POSITION_TARGET_LOCAL_NED_DATA, PositionTargetTypemask, SET_POSITION_TARGET_GLOBAL_INT_DATA,
    SET_POSITION_TARGET_LOCAL_NED_DATA,
};

/// Counts of refused offboard input.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OffboardRejects {
    /// Non-finite or out-of-range values.
    pub invalid: u64,
    /// Coordinate frames we do not fly (only LOCAL_NED and GLOBAL(_RELATIVE_ALT)_INT).
    pub frame: u64,
    /// Global targets before the vehicle knows where home is.
    pub no_origin: u64,
}

/// MANUAL_CONTROL (x forward, y right, r yaw in -1000..1000; z throttle 0..1000) from system
/// `system_id` as sticks; the commander decides whether that system is the one in control.
pub fn manual_control(
    m: &MANUAL_CONTROL_DATA,
    system_id: u8,
    now: Time,
    rejects: &mut OffboardRejects,
) -> Option<ManualControl> {
    let axis = |v: i16| (v != i16::MAX && (-1000..=1000).contains(&v)).then(|| f64::from(v) / 1000.0);
    let throttle = (0..=1000).contains(&m.z).then(|| f64::from(m.z) / 1000.0);
    match (axis(m.x), axis(m.y), axis(m.r), throttle) {
        (Some(pitch), Some(roll), Some(yaw), Some(throttle)) => Some(ManualControl {
            time: now,
            roll,
            pitch,
            yaw,
            throttle,
            source: StickSource::Mavlink { system_id },
        }),
        _ => {
            rejects.invalid += 1;
            None
        }
    }
}

const POSITION_IGNORED: PositionTargetTypemask = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_X_IGNORE
    .union(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Y_IGNORE)
    .union(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Z_IGNORE);
const VELOCITY_IGNORED: PositionTargetTypemask = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VX_IGNORE
    .union(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VY_IGNORE)
    .union(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VZ_IGNORE);

fn finite(v: [f64; 3], rejects: &mut OffboardRejects) -> Option<[f64; 3]> {
    if v.iter().all(|x| x.is_finite()) {
        Some(v)
    } else {
        rejects.invalid += 1;
        None
    }
}

/// A guided command from a position (or, with position ignored, velocity) target in the local
/// NED frame around home.
pub fn local_target(
    m: &SET_POSITION_TARGET_LOCAL_NED_DATA,
    rejects: &mut OffboardRejects,
) -> Option<Command> {
    if m.coordinate_frame != MavFrame::MAV_FRAME_LOCAL_NED {
        rejects.frame += 1;
        return None;
    }
    if !m.type_mask.intersects(POSITION_IGNORED) {
        let p = finite([f64::from(m.x), f64::from(m.y), f64::from(m.z)], rejects)?;
        return Some(Command::GotoNed { position_ned_m: p });
    }
    if !m.type_mask.intersects(VELOCITY_IGNORED) {
        let v = finite([f64::from(m.vx), f64::from(m.vy), f64::from(m.vz)], rejects)?;
        return Some(Command::VelocityNed { velocity_ned_m_s: v });
    }
    rejects.invalid += 1;
    None
}

/// A guided command from a global position target, converted with the one WGS-84↔NED
/// conversion around `home`.
pub fn global_target(
    m: &SET_POSITION_TARGET_GLOBAL_INT_DATA,
    home: Option<Geodetic>,
    rejects: &mut OffboardRejects,
) -> Option<Command> {
    let relative = match m.coordinate_frame {
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT => true,
        MavFrame::MAV_FRAME_GLOBAL_INT | MavFrame::MAV_FRAME_GLOBAL => false,
        _ => {
            rejects.frame += 1;
            return None;
        }
    };
    let Some(home) = home else {
        rejects.no_origin += 1;
        return None;
    };
    if !m.type_mask.intersects(POSITION_IGNORED) {
        let lat_deg = deg_from_e7(f64::from(m.lat_int));
        let lon_deg = deg_from_e7(f64::from(m.lon_int));
        let alt = f64::from(m.alt);
        if !(alt.is_finite() && lat_deg.abs() <= 90.0 && lon_deg.abs() <= 180.0) {
            rejects.invalid += 1;
            return None;
        }
        let alt_m = if relative { home.alt_m + alt } else { alt };
        let ned = LocalFrame::new(home).to_ned(Geodetic { lat_deg, lon_deg, alt_m });
        return Some(Command::GotoNed { position_ned_m: ned });
    }
    if !m.type_mask.intersects(VELOCITY_IGNORED) {
        let v = finite([f64::from(m.vx), f64::from(m.vy), f64::from(m.vz)], rejects)?;
        return Some(Command::VelocityNed { velocity_ned_m_s: v });
    }
    rejects.invalid += 1;
    None
}

/// The POSITION_TARGET_LOCAL_NED echo of an accepted local target.
pub fn local_echo(m: &SET_POSITION_TARGET_LOCAL_NED_DATA, now: Time) -> MavMessage {
    MavMessage::POSITION_TARGET_LOCAL_NED(POSITION_TARGET_LOCAL_NED_DATA {
        time_boot_ms: (now.as_micros() / 1000) as u32,
        x: m.x,
        y: m.y,
        z: m.z,
        vx: m.vx,
        vy: m.vy,
        vz: m.vz,
        afx: m.afx,
        afy: m.afy,
        afz: m.afz,
        yaw: m.yaw,
        yaw_rate: m.yaw_rate,
        type_mask: m.type_mask,
        coordinate_frame: m.coordinate_frame,
    })
}

/// The POSITION_TARGET_GLOBAL_INT echo of an accepted global target.
pub fn global_echo(m: &SET_POSITION_TARGET_GLOBAL_INT_DATA, now: Time) -> MavMessage {
    MavMessage::POSITION_TARGET_GLOBAL_INT(POSITION_TARGET_GLOBAL_INT_DATA {
        time_boot_ms: (now.as_micros() / 1000) as u32,
        lat_int: m.lat_int,
        lon_int: m.lon_int,
        alt: m.alt,
        vx: m.vx,
        vy: m.vy,
        vz: m.vz,
        afx: m.afx,
        afy: m.afy,
        afz: m.afz,
        yaw: m.yaw,
        yaw_rate: m.yaw_rate,
        type_mask: m.type_mask,
        coordinate_frame: m.coordinate_frame,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sticks_are_normalised_and_out_of_range_refused() {
        let mut r = OffboardRejects::default();
        let m = MANUAL_CONTROL_DATA { x: 500, y: -1000, z: 250, r: 0, ..Default::default() };
        let s = manual_control(&m, 254, Time::ZERO, &mut r).expect("valid sticks");
        assert_eq!((s.pitch, s.roll, s.throttle, s.yaw), (0.5, -1.0, 0.25, 0.0));
        assert_eq!(s.source, StickSource::Mavlink { system_id: 254 }, "the sender is named");
        assert!(manual_control(&MANUAL_CONTROL_DATA { z: -5, ..m }, 255, Time::ZERO, &mut r).is_none());
        assert_eq!(r.invalid, 1);
    }

    #[test]
    fn local_targets_become_goto_or_velocity() {
        let mut r = OffboardRejects::default();
        let mut m = SET_POSITION_TARGET_LOCAL_NED_DATA {
            x: 10.0,
            y: -5.0,
            z: -20.0,
            coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
            type_mask: VELOCITY_IGNORED,
            ..Default::default()
        };
        assert_eq!(local_target(&m, &mut r), Some(Command::GotoNed { position_ned_m: [10.0, -5.0, -20.0] }));
        m.type_mask = POSITION_IGNORED;
        m.vx = 1.0;
        assert_eq!(
            local_target(&m, &mut r),
            Some(Command::VelocityNed { velocity_ned_m_s: [1.0, 0.0, 0.0] })
        );
        m.vy = f32::NAN;
        assert_eq!(local_target(&m, &mut r), None);
        m.coordinate_frame = MavFrame::MAV_FRAME_BODY_NED;
        assert_eq!(local_target(&m, &mut r), None);
        assert_eq!((r.invalid, r.frame), (1, 1));
    }

    #[test]
    fn global_targets_go_through_the_local_frame() {
        let mut r = OffboardRejects::default();
        let home = Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 };
        let m = SET_POSITION_TARGET_GLOBAL_INT_DATA {
            lat_int: 67_971_000,
            lon_int: 799_017_000,
            alt: 30.0,
            coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            type_mask: VELOCITY_IGNORED,
            ..Default::default()
        };
        let Some(Command::GotoNed { position_ned_m: p }) = global_target(&m, Some(home), &mut r) else {
            panic!("expected a goto");
        };
        assert!(p[0].abs() < 0.01 && p[1].abs() < 0.01 && (p[2] + 30.0).abs() < 0.01, "{p:?}");
        assert_eq!(global_target(&m, None, &mut r), None);
        assert_eq!(r.no_origin, 1);
    }
}
