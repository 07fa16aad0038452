//! Direct control from outside: MANUAL_CONTROL sticks, SET_POSITION_TARGET_LOCAL_NED /
//! GLOBAL_INT and SET_ATTITUDE_TARGET guided targets. Non-finite or out-of-range input is
//! refused and counted; a target that cannot be flown stops the vehicle, as in ArduCopter.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use kestrel_proto::Time;
use kestrel_proto::attitude::euler_rad;
use kestrel_proto::geo::{Geodetic, LocalFrame, deg_from_e7};
use kestrel_proto::messages::{
    AttitudeTarget, Command, ManualControl, NavState, PositionTarget, StickSource,
};
use mavlink::dialects::ardupilotmega::{
    AttitudeTargetTypemask, MANUAL_CONTROL_DATA, MavFrame, PositionTargetTypemask, SET_ATTITUDE_TARGET_DATA,
    SET_POSITION_TARGET_GLOBAL_INT_DATA, SET_POSITION_TARGET_LOCAL_NED_DATA,
};

/// Counts of refused offboard input.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OffboardRejects {
    /// Non-finite or out-of-range values.
    pub invalid: u64,
    /// Coordinate frames ArduCopter does not fly (and terrain-relative ones).
    pub frame: u64,
    /// Type masks ArduCopter does not fly (force; position and acceleration without velocity;
    /// nothing; an attitude target without its attitude or thrust; some body rates only).
    pub combination: u64,
    /// Targets measured from the vehicle or home before the estimator has a position.
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
const ACCELERATION_IGNORED: PositionTargetTypemask =
    PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AX_IGNORE
        .union(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AY_IGNORE)
        .union(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AZ_IGNORE);
/// ArduCopter's `sane_vel_or_acc_vector`: a velocity component beyond this is refused (m/s).
const MAX_VELOCITY_COMPONENT_M_S: f64 = 1000.0;

/// What the type mask asks for, as ArduCopter reads it: one ignore bit of an axis group ignores
/// the whole group.
#[derive(Clone, Copy, Debug)]
struct Parts {
    position: bool,
    velocity: bool,
    acceleration: bool,
    yaw: bool,
    yaw_rate: bool,
}

impl Parts {
    /// The parts, or `None` for a combination ArduCopter does not fly (force instead of
    /// acceleration; a position with an acceleration but no velocity; nothing at all).
    fn of(mask: PositionTargetTypemask) -> Option<Parts> {
        let parts = Parts {
            position: !mask.intersects(POSITION_IGNORED),
            velocity: !mask.intersects(VELOCITY_IGNORED),
            acceleration: !mask.intersects(ACCELERATION_IGNORED),
            yaw: !mask.contains(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_IGNORE),
            yaw_rate: !mask.contains(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE),
        };
        let force = mask.contains(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_FORCE_SET);
        let flown = match (parts.position, parts.velocity, parts.acceleration) {
            (true, true, _) | (false, true, _) | (false, false, true) | (true, false, false) => true,
            (true, false, true) | (false, false, false) => false,
        };
        (flown && !(force && parts.acceleration)).then_some(parts)
    }
}

/// A vector from the message, or `None` when a component is not a number.
fn finite(v: [f32; 3]) -> Option<[f64; 3]> {
    let v = v.map(f64::from);
    v.iter().all(|x| x.is_finite()).then_some(v)
}

/// A velocity ArduCopter would take: finite, no component beyond 1000 m/s.
fn sane_velocity(v: [f32; 3]) -> Option<[f64; 3]> {
    finite(v).filter(|v| v.iter().all(|x| x.abs() <= MAX_VELOCITY_COMPONENT_M_S))
}

/// `v` (forward, right, down) turned by the heading `yaw_rad` into north, east, down: the
/// heading only, as ArduCopter's `rotate_body_frame_to_NE` does, so a body-frame velocity stays
/// horizontal while the vehicle leans.
pub fn body_to_ned(v: [f64; 3], yaw_rad: f64) -> [f64; 3] {
    let (sin, cos) = yaw_rad.sin_cos();
    [v[0] * cos - v[1] * sin, v[0] * sin + v[1] * cos, v[2]]
}

/// The yaw fields the mask keeps, finite; `None` when one is not a number.
fn yaw_fields(yaw: f32, yaw_rate: f32, parts: Parts) -> Option<(Option<f64>, Option<f64>)> {
    let pick = |used: bool, v: f32| -> Option<Option<f64>> {
        if !used {
            return Some(None);
        }
        let v = f64::from(v);
        v.is_finite().then_some(Some(v))
    };
    Some((pick(parts.yaw, yaw)?, pick(parts.yaw_rate, yaw_rate)?))
}

/// SET_POSITION_TARGET_LOCAL_NED as a GUIDED target, as ArduCopter's
/// `handle_message_set_position_target_local_ned` reads it: in LOCAL_NED around the estimator's
/// origin; LOCAL_OFFSET_NED from where the vehicle is; BODY_NED and BODY_OFFSET_NED turned by its
/// heading, the position from where it is and the yaw from its heading. What cannot be flown
/// (another frame, a combination ArduCopter refuses, a value that is not a number or a velocity
/// beyond 1000 m/s, no estimate to measure from) is counted and becomes [`Command::GuidedStop`]:
/// ArduCopter stops and holds (`ModeGuided::init(true)`) rather than fly on. Held by
/// `tests::local_targets_follow_the_frame_and_mask`.
pub fn local_target(
    m: &SET_POSITION_TARGET_LOCAL_NED_DATA,
    nav: Option<&NavState>,
    rejects: &mut OffboardRejects,
) -> Command {
    let (body, offset) = match m.coordinate_frame {
        MavFrame::MAV_FRAME_LOCAL_NED => (false, false),
        MavFrame::MAV_FRAME_LOCAL_OFFSET_NED => (false, true),
        MavFrame::MAV_FRAME_BODY_NED | MavFrame::MAV_FRAME_BODY_OFFSET_NED => (true, true),
        _ => return stop(&mut rejects.frame),
    };
    let Some(parts) = Parts::of(m.type_mask) else { return stop(&mut rejects.combination) };
    let Some((yaw, yaw_rate)) = yaw_fields(m.yaw, m.yaw_rate, parts) else {
        return stop(&mut rejects.invalid);
    };
    let here = nav.map(|n| (n.position_ned_m, euler_rad(n.attitude)[2]));
    let Some((position_m, heading_rad)) = here.or((!body && !offset).then_some(([0.0; 3], 0.0))) else {
        return stop(&mut rejects.no_origin);
    };
    let turn = |v: [f64; 3]| if body { body_to_ned(v, heading_rad) } else { v };
    let position_ned_m = match parts.position.then(|| finite([m.x, m.y, m.z])) {
        None => None,
        Some(None) => return stop(&mut rejects.invalid),
        Some(Some(p)) => {
            let p = turn(p);
            Some(if offset { [0, 1, 2].map(|i| p[i] + position_m[i]) } else { p })
        }
    };
    let velocity_ned_m_s = match parts.velocity.then(|| sane_velocity([m.vx, m.vy, m.vz])) {
        None => None,
        Some(None) => return stop(&mut rejects.invalid),
        Some(Some(v)) => Some(turn(v)),
    };
    let acceleration_ned_m_s2 = match parts.acceleration.then(|| finite([m.afx, m.afy, m.afz])) {
        None => None,
        Some(None) => return stop(&mut rejects.invalid),
        Some(Some(a)) => Some(turn(a)),
    };
    // In the body frames the yaw is a turn from the heading (ArduCopter's `yaw_relative`).
    let yaw_rad = yaw.map(|y| if body { y + heading_rad } else { y });
    Command::PositionTarget(PositionTarget {
        position_ned_m,
        velocity_ned_m_s,
        acceleration_ned_m_s2,
        yaw_rad,
        yaw_rate_rad_s: yaw_rate,
        speed_m_s: None,
    })
}

/// SET_POSITION_TARGET_GLOBAL_INT as a GUIDED target, as ArduCopter's
/// `handle_message_set_position_target_global_int` reads it: the position in GLOBAL(_INT) (above
/// mean sea level) or GLOBAL_RELATIVE_ALT(_INT) (above home), converted with the one WGS-84↔NED
/// conversion around the estimator's origin; velocity, acceleration and yaw in the earth frame.
/// Terrain-relative altitudes are not flown (no terrain database). What cannot be flown is
/// counted and becomes [`Command::GuidedStop`], as for [`local_target`]. Held by
/// `tests::global_targets_go_through_the_local_frame`.
pub fn global_target(
    m: &SET_POSITION_TARGET_GLOBAL_INT_DATA,
    home: Option<Geodetic>,
    rejects: &mut OffboardRejects,
) -> Command {
    let Some(parts) = Parts::of(m.type_mask) else { return stop(&mut rejects.combination) };
    let Some((yaw_rad, yaw_rate_rad_s)) = yaw_fields(m.yaw, m.yaw_rate, parts) else {
        return stop(&mut rejects.invalid);
    };
    let position_ned_m = if parts.position {
        let relative = match m.coordinate_frame {
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT => true,
            MavFrame::MAV_FRAME_GLOBAL_INT | MavFrame::MAV_FRAME_GLOBAL => false,
            _ => return stop(&mut rejects.frame),
        };
        let Some(home) = home else { return stop(&mut rejects.no_origin) };
        let lat_deg = deg_from_e7(f64::from(m.lat_int));
        let lon_deg = deg_from_e7(f64::from(m.lon_int));
        let alt = f64::from(m.alt);
        if !(alt.is_finite() && lat_deg.abs() <= 90.0 && lon_deg.abs() <= 180.0) {
            return stop(&mut rejects.invalid);
        }
        let alt_m = if relative { home.alt_m + alt } else { alt };
        Some(LocalFrame::new(home).to_ned(Geodetic { lat_deg, lon_deg, alt_m }))
    } else {
        None
    };
    let velocity_ned_m_s = match parts.velocity.then(|| sane_velocity([m.vx, m.vy, m.vz])) {
        None => None,
        Some(None) => return stop(&mut rejects.invalid),
        Some(v) => v,
    };
    let acceleration_ned_m_s2 = match parts.acceleration.then(|| finite([m.afx, m.afy, m.afz])) {
        None => None,
        Some(None) => return stop(&mut rejects.invalid),
        Some(a) => a,
    };
    Command::PositionTarget(PositionTarget {
        position_ned_m,
        velocity_ned_m_s,
        acceleration_ned_m_s2,
        yaw_rad,
        yaw_rate_rad_s,
        speed_m_s: None,
    })
}

/// SET_ATTITUDE_TARGET as a GUIDED target, as ArduCopter's `handle_message_set_attitude_target`
/// reads it on its default `GUID_OPTIONS`: a unit attitude (within 1e-3), all three body rates
/// or none (the yaw rate is flown as the heading's feed-forward), and the thrust 0..1 as a climb
/// command around 0.5. Not flown, counted, and a [`Command::GuidedStop`]: an ignored thrust, a
/// thrust outside 0..1 or not a number, some rates without the others (as ArduCopter), and rates
/// without an attitude (ArduCopter flies those with its rate controller; we fly attitudes only,
/// so a rate-only stream holds instead). Held by `tests::attitude_targets_need_an_attitude_and_a_thrust`.
pub fn attitude_target(m: &SET_ATTITUDE_TARGET_DATA, rejects: &mut OffboardRejects) -> Command {
    let mask = m.type_mask;
    if mask.contains(AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE)
        || mask.contains(AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE)
    {
        return stop(&mut rejects.combination);
    }
    let rates = [
        AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE,
        AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE,
        AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE,
    ]
    .map(|bit| !mask.contains(bit));
    let yaw_rate = match rates {
        [true, true, true] => f64::from(m.body_yaw_rate),
        [false, false, false] => 0.0,
        _ => return stop(&mut rejects.combination),
    };
    let q = m.q.map(f64::from);
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let thrust = f64::from(m.thrust);
    if !((norm - 1.0).abs() <= 1e-3 && yaw_rate.is_finite() && (0.0..=1.0).contains(&thrust)) {
        return stop(&mut rejects.invalid);
    }
    Command::AttitudeTarget(AttitudeTarget {
        attitude: q.map(|v| v / norm),
        yaw_rate_rad_s: yaw_rate,
        climb: 2.0 * (thrust - 0.5),
    })
}

/// Counts a refusal and stops, as ArduCopter's GUIDED does on input it cannot fly.
fn stop(count: &mut u64) -> Command {
    *count += 1;
    Command::GuidedStop
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
}

#[cfg(test)]
mod frame_tests {
    use nalgebra::{UnitQuaternion, Vector3};
    use proptest::prelude::*;

    use super::*;

    const HOME: Geodetic = Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 };

    /// Hovering 30 m up, 10 m north and 4 m east of the origin, heading `yaw_rad`.
    fn nav_heading(yaw_rad: f64) -> NavState {
        let q = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_rad);
        NavState {
            attitude: [q.w, q.i, q.j, q.k],
            position_ned_m: [10.0, 4.0, -30.0],
            origin: Some(HOME),
            ..crate::services::telemetry::encode::nav_facing_east()
        }
    }

    /// The reference rotation: the vector turned by the vehicle's whole attitude quaternion when
    /// the vehicle is level (no shared formula with `body_to_ned`).
    fn reference(v: [f64; 3], yaw_rad: f64) -> [f64; 3] {
        let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_rad) * Vector3::from(v);
        [r.x, r.y, r.z]
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b.iter()).all(|(x, y)| (x - y).abs() < 1e-4)
    }

    fn msg(frame: MavFrame, ignore: PositionTargetTypemask) -> SET_POSITION_TARGET_LOCAL_NED_DATA {
        SET_POSITION_TARGET_LOCAL_NED_DATA {
            x: 3.0,
            y: -2.0,
            z: -1.0,
            vx: 2.0,
            vy: 1.0,
            vz: -0.5,
            afx: 0.4,
            afy: 0.2,
            afz: 0.0,
            yaw: 0.5,
            yaw_rate: 0.25,
            coordinate_frame: frame,
            type_mask: ignore,
            ..Default::default()
        }
    }

    fn target(c: Command) -> PositionTarget {
        match c {
            Command::PositionTarget(t) => t,
            other => panic!("not a target: {other:?}"),
        }
    }

    const YAW: PositionTargetTypemask = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_IGNORE;
    const YAW_RATE: PositionTargetTypemask = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE;

    #[test]
    fn local_targets_follow_the_frame_and_mask() {
        let mut r = OffboardRejects::default();
        let heading = 60f64.to_radians();
        let nav = nav_heading(heading);
        let here = Some(&nav);
        // LOCAL_NED: as sent; every part the mask keeps.
        let t = target(local_target(
            &msg(MavFrame::MAV_FRAME_LOCAL_NED, PositionTargetTypemask::empty()),
            here,
            &mut r,
        ));
        assert!(close(t.position_ned_m.expect("p"), [3.0, -2.0, -1.0]));
        assert!(close(t.velocity_ned_m_s.expect("v"), [2.0, 1.0, -0.5]));
        assert!(close(t.acceleration_ned_m_s2.expect("a"), [0.4, 0.2, 0.0]));
        assert_eq!((t.yaw_rad, t.yaw_rate_rad_s), (Some(0.5), Some(0.25)));
        // LOCAL_OFFSET_NED: from where the vehicle is, not turned.
        let t =
            target(local_target(&msg(MavFrame::MAV_FRAME_LOCAL_OFFSET_NED, YAW | YAW_RATE), here, &mut r));
        assert!(close(t.position_ned_m.expect("p"), [13.0, 2.0, -31.0]));
        assert!(close(t.velocity_ned_m_s.expect("v"), [2.0, 1.0, -0.5]));
        assert_eq!((t.yaw_rad, t.yaw_rate_rad_s), (None, None));
        // BODY_NED and BODY_OFFSET_NED: turned by the heading, from where it is, yaw relative.
        for frame in [MavFrame::MAV_FRAME_BODY_NED, MavFrame::MAV_FRAME_BODY_OFFSET_NED] {
            let t = target(local_target(&msg(frame, YAW_RATE), here, &mut r));
            let p = reference([3.0, -2.0, -1.0], heading);
            assert!(close(t.position_ned_m.expect("p"), [p[0] + 10.0, p[1] + 4.0, p[2] - 30.0]), "{t:?}");
            assert!(close(t.velocity_ned_m_s.expect("v"), reference([2.0, 1.0, -0.5], heading)));
            assert!(close(t.acceleration_ned_m_s2.expect("a"), reference([0.4, 0.2, 0.0], heading)));
            assert!((t.yaw_rad.expect("yaw") - (0.5 + heading)).abs() < 1e-6);
            assert_eq!(t.yaw_rate_rad_s, None);
        }
        assert_eq!(r, OffboardRejects::default(), "nothing refused so far");
    }

    #[test]
    fn the_masks_arducopter_refuses_stop_the_vehicle() {
        let mut r = OffboardRejects::default();
        let nav = nav_heading(0.0);
        let f = MavFrame::MAV_FRAME_LOCAL_NED;
        let one_x = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_X_IGNORE;
        // One ignored axis of a group ignores the group (ArduCopter's reading).
        let t = target(local_target(&msg(f, one_x), Some(&nav), &mut r));
        assert_eq!(t.position_ned_m, None);
        assert!(t.velocity_ned_m_s.is_some());
        for mask in [
            POSITION_IGNORED | VELOCITY_IGNORED | ACCELERATION_IGNORED,
            VELOCITY_IGNORED,
            PositionTargetTypemask::POSITION_TARGET_TYPEMASK_FORCE_SET,
        ] {
            assert_eq!(local_target(&msg(f, mask), Some(&nav), &mut r), Command::GuidedStop, "{mask:?}");
        }
        assert_eq!(r.combination, 3);
        let only_position = VELOCITY_IGNORED | ACCELERATION_IGNORED;
        let t = target(local_target(&msg(f, only_position | YAW | YAW_RATE), Some(&nav), &mut r));
        assert_eq!((t.velocity_ned_m_s, t.acceleration_ned_m_s2), (None, None));
        for bad in [
            SET_POSITION_TARGET_LOCAL_NED_DATA { vx: f32::NAN, ..msg(f, POSITION_IGNORED) },
            SET_POSITION_TARGET_LOCAL_NED_DATA { vx: 1001.0, ..msg(f, POSITION_IGNORED) },
            SET_POSITION_TARGET_LOCAL_NED_DATA { x: f32::INFINITY, ..msg(f, only_position) },
            SET_POSITION_TARGET_LOCAL_NED_DATA { yaw_rate: f32::NAN, ..msg(f, only_position) },
            SET_POSITION_TARGET_LOCAL_NED_DATA { afz: f32::NAN, ..msg(f, POSITION_IGNORED) },
        ] {
            assert_eq!(local_target(&bad, Some(&nav), &mut r), Command::GuidedStop, "{bad:?}");
        }
        assert_eq!(r.invalid, 5);
        let vx_nan_ignored = SET_POSITION_TARGET_LOCAL_NED_DATA { vx: f32::NAN, ..msg(f, only_position) };
        let t = target(local_target(&vx_nan_ignored, Some(&nav), &mut r));
        assert!(t.position_ned_m.is_some(), "a NaN in a part the mask ignores is not read");
        assert_eq!(
            local_target(&msg(MavFrame::MAV_FRAME_GLOBAL, POSITION_IGNORED), Some(&nav), &mut r),
            Command::GuidedStop
        );
        assert_eq!(
            local_target(&msg(MavFrame::MAV_FRAME_BODY_NED, POSITION_IGNORED), None, &mut r),
            Command::GuidedStop
        );
        assert_eq!((r.frame, r.no_origin), (1, 1));
    }

    proptest! {
        /// Any heading: a body velocity keeps its length and its angle to the nose, and the
        /// rotation agrees with the quaternion reference.
        #[test]
        fn body_velocities_turn_with_the_heading(yaw in -10.0f64..10.0, fwd in -20.0f32..20.0, right in -20.0f32..20.0) {
            let nav = nav_heading(yaw);
            let mut r = OffboardRejects::default();
            let m = SET_POSITION_TARGET_LOCAL_NED_DATA {
                vx: fwd, vy: right, vz: 0.0,
                ..msg(MavFrame::MAV_FRAME_BODY_OFFSET_NED, POSITION_IGNORED | ACCELERATION_IGNORED)
            };
            let v = target(local_target(&m, Some(&nav), &mut r)).velocity_ned_m_s.expect("v");
            let expected = reference([f64::from(fwd), f64::from(right), 0.0], euler_rad(nav.attitude)[2]);
            prop_assert!(close(v, expected), "{v:?} vs {expected:?}");
            prop_assert!((v[0].hypot(v[1]) - f64::from(fwd).hypot(f64::from(right))).abs() < 1e-3);
        }
    }

    #[test]
    fn global_targets_go_through_the_local_frame() {
        let mut r = OffboardRejects::default();
        let m = SET_POSITION_TARGET_GLOBAL_INT_DATA {
            lat_int: 67_971_000,
            lon_int: 799_017_000,
            alt: 30.0,
            coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            type_mask: VELOCITY_IGNORED | ACCELERATION_IGNORED | YAW_RATE,
            yaw: 1.0,
            ..Default::default()
        };
        let t = target(global_target(&m, Some(HOME), &mut r));
        let p = t.position_ned_m.expect("p");
        assert!(p[0].abs() < 0.01 && p[1].abs() < 0.01 && (p[2] + 30.0).abs() < 0.01, "{p:?}");
        assert_eq!(t.yaw_rad, Some(1.0), "earth-frame yaw");
        let amsl =
            SET_POSITION_TARGET_GLOBAL_INT_DATA { coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_INT, ..m };
        let p = target(global_target(&amsl, Some(HOME), &mut r)).position_ned_m.expect("p");
        assert!((p[2] + 10.0).abs() < 0.01, "30 m above sea level is 10 m above a 20 m origin: {p:?}");
        assert_eq!(global_target(&m, None, &mut r), Command::GuidedStop);
        let terrain = SET_POSITION_TARGET_GLOBAL_INT_DATA {
            coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
            ..m
        };
        assert_eq!(global_target(&terrain, Some(HOME), &mut r), Command::GuidedStop);
        let velocity = SET_POSITION_TARGET_GLOBAL_INT_DATA { vx: 2.0, type_mask: POSITION_IGNORED, ..m };
        let t = target(global_target(&velocity, None, &mut r));
        assert_eq!(t.velocity_ned_m_s, Some([2.0, 0.0, 0.0]), "a velocity needs no origin");
        assert_eq!((r.no_origin, r.frame), (1, 1));
    }

    #[test]
    fn attitude_targets_need_an_attitude_and_a_thrust() {
        let mut r = OffboardRejects::default();
        let q = UnitQuaternion::from_euler_angles(0.1, -0.2, 1.0);
        let m = SET_ATTITUDE_TARGET_DATA {
            q: [q.w as f32, q.i as f32, q.j as f32, q.k as f32],
            body_roll_rate: 0.0,
            body_pitch_rate: 0.0,
            body_yaw_rate: 0.3,
            thrust: 0.75,
            type_mask: AttitudeTargetTypemask::empty(),
            ..Default::default()
        };
        let Command::AttitudeTarget(t) = attitude_target(&m, &mut r) else { panic!("attitude") };
        assert!((t.yaw_rate_rad_s - 0.3).abs() < 1e-6 && (t.climb - 0.5).abs() < 1e-6, "{t:?}");
        let rates_ignored = AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE
            | AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE
            | AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE;
        let Command::AttitudeTarget(t) =
            attitude_target(&SET_ATTITUDE_TARGET_DATA { type_mask: rates_ignored, thrust: 0.5, ..m }, &mut r)
        else {
            panic!("attitude")
        };
        assert_eq!((t.yaw_rate_rad_s, t.climb), (0.0, 0.0), "0.5 holds the height");
        for bad in [
            SET_ATTITUDE_TARGET_DATA {
                type_mask: AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE,
                ..m
            },
            SET_ATTITUDE_TARGET_DATA {
                type_mask: AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE,
                ..m
            },
            SET_ATTITUDE_TARGET_DATA {
                type_mask: AttitudeTargetTypemask::ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE,
                ..m
            },
            SET_ATTITUDE_TARGET_DATA { q: [0.9, 0.0, 0.0, 0.0], ..m },
            SET_ATTITUDE_TARGET_DATA { thrust: f32::NAN, ..m },
            SET_ATTITUDE_TARGET_DATA { thrust: 1.2, ..m },
        ] {
            assert_eq!(attitude_target(&bad, &mut r), Command::GuidedStop, "{bad:?}");
        }
        assert_eq!((r.combination, r.invalid), (3, 3));
    }
}
