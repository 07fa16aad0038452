//! Position reports of other systems for FOLLOW: FOLLOW_TARGET and GLOBAL_POSITION_INT decoded
//! as ArduPilot's `AP_Follow` reads them, into a [`FollowTarget`] for the commander, which
//! chooses the system followed (`FOLL_SYSID`) and keeps the newest report. Our own messages never
//! get here (the hub refuses frames with our system id).
//!
//! * Latitude and longitude both 0 is no fix: ignored, as ArduPilot does.
//! * FOLLOW_TARGET counts only with its position bit (`est_capabilities` bit 0); velocity
//!   (bit 1), acceleration (bit 2) and attitude with body rates (bit 3) are read only when their
//!   bit says so, and are zero (no heading) otherwise: MAVSDK's `follow_me` sends only bit 0,
//!   with NaN in the fields it does not fill. Its altitude is above mean sea level.
//! * GLOBAL_POSITION_INT carries both altitudes (`FOLL_ALT_TYPE` chooses), a velocity in cm/s
//!   and a heading unless `hdg` is above 36000 (UINT16_MAX: unknown).
//! * A number the message claims but that is not finite, or a place off the globe, is refused.
//!
//! The report is stamped with its arrival: the sender's own clock (`timestamp`,
//! `time_boot_ms`) is not ours. Held by `tests`.

use kestrel_proto::geo::deg_from_e7;
use kestrel_proto::messages::{Command, FollowSource, FollowTarget};
use mavlink::dialects::ardupilotmega::{FOLLOW_TARGET_DATA, GLOBAL_POSITION_INT_DATA, MavMessage};

use super::Sender;

/// Why a report was not passed on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ReportRefused {
    #[error("latitude and longitude are both 0: no fix")]
    NoFix,
    #[error("FOLLOW_TARGET without its position bit (est_capabilities bit 0)")]
    NoPosition,
    #[error("a field the message claims is not a number, or the place is off the globe")]
    Invalid,
}

/// The commander's command for `msg` from `from`, if it is a position report at all.
pub fn report(from: Sender, msg: &MavMessage) -> Option<Result<Command, ReportRefused>> {
    let system_id = from.target_system();
    let r = match msg {
        MavMessage::FOLLOW_TARGET(m) => follow_target(system_id, m),
        MavMessage::GLOBAL_POSITION_INT(m) => global_position_int(system_id, m),
        _ => return None,
    };
    Some(r.map(Command::FollowTarget))
}

/// FOLLOW_TARGET as `AP_Follow::handle_follow_target_message` reads it.
pub fn follow_target(system_id: u8, m: &FOLLOW_TARGET_DATA) -> Result<FollowTarget, ReportRefused> {
    let (lat_deg, lon_deg) = place(m.lat, m.lon)?;
    if m.est_capabilities & 1 == 0 {
        return Err(ReportRefused::NoPosition);
    }
    let alt_amsl_m = finite(f64::from(m.alt))?;
    let vector = |bit: u8, v: [f32; 3]| -> Result<[f64; 3], ReportRefused> {
        if m.est_capabilities & bit == 0 {
            return Ok([0.0; 3]);
        }
        Ok([finite(f64::from(v[0]))?, finite(f64::from(v[1]))?, finite(f64::from(v[2]))?])
    };
    let velocity_ned_m_s = vector(1 << 1, m.vel)?;
    let acceleration_ned_m_s2 = vector(1 << 2, m.acc)?;
    let (heading_rad, heading_rate_rad_s) = if m.est_capabilities & (1 << 3) != 0 {
        let [w, x, y, z] = m.attitude_q.map(f64::from);
        let rates = m.rates.map(f64::from);
        let norm = (w * w + x * x + y * y + z * z).sqrt();
        if !(norm.is_finite() && (norm - 1.0).abs() < 0.01 && rates.iter().all(|r| r.is_finite())) {
            return Err(ReportRefused::Invalid);
        }
        let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
        // The earth frame's down component of the body rates: the third row of the rotation
        // body → NED applied to them.
        let row = [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)];
        (Some(yaw), row[0] * rates[0] + row[1] * rates[1] + row[2] * rates[2])
    } else {
        (None, 0.0)
    };
    Ok(FollowTarget {
        system_id,
        source: FollowSource::FollowTarget,
        lat_deg,
        lon_deg,
        alt_amsl_m,
        alt_above_home_m: None,
        velocity_ned_m_s,
        acceleration_ned_m_s2,
        heading_rad,
        heading_rate_rad_s,
    })
}

/// GLOBAL_POSITION_INT as `AP_Follow::handle_global_position_int_message` reads it.
pub fn global_position_int(
    system_id: u8,
    m: &GLOBAL_POSITION_INT_DATA,
) -> Result<FollowTarget, ReportRefused> {
    let (lat_deg, lon_deg) = place(m.lat, m.lon)?;
    let heading_rad = (m.hdg <= 36000).then(|| (f64::from(m.hdg) * 0.01).to_radians());
    Ok(FollowTarget {
        system_id,
        source: FollowSource::GlobalPositionInt,
        lat_deg,
        lon_deg,
        alt_amsl_m: f64::from(m.alt) * 1e-3,
        alt_above_home_m: Some(f64::from(m.relative_alt) * 1e-3),
        velocity_ned_m_s: [m.vx, m.vy, m.vz].map(|v| f64::from(v) * 0.01),
        acceleration_ned_m_s2: [0.0; 3],
        heading_rad,
        heading_rate_rad_s: 0.0,
    })
}

fn place(lat_e7: i32, lon_e7: i32) -> Result<(f64, f64), ReportRefused> {
    if lat_e7 == 0 && lon_e7 == 0 {
        return Err(ReportRefused::NoFix);
    }
    let (lat, lon) = (deg_from_e7(f64::from(lat_e7)), deg_from_e7(f64::from(lon_e7)));
    if lat.abs() > 90.0 || lon.abs() > 180.0 {
        return Err(ReportRefused::Invalid);
    }
    Ok((lat, lon))
}

fn finite(v: f64) -> Result<f64, ReportRefused> {
    if v.is_finite() { Ok(v) } else { Err(ReportRefused::Invalid) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn mavsdk_follow_target() -> FOLLOW_TARGET_DATA {
        // What MAVSDK's follow_me sends: position bit only, NaN in everything it does not fill.
        FOLLOW_TARGET_DATA {
            timestamp: 1234,
            est_capabilities: 1,
            lat: 67_971_000,
            lon: 799_017_000,
            alt: 25.0,
            vel: [3.0, 0.0, 0.0],
            acc: [f32::NAN; 3],
            attitude_q: [1.0, f32::NAN, f32::NAN, f32::NAN],
            rates: [f32::NAN; 3],
            position_cov: [f32::NAN; 3],
            ..FOLLOW_TARGET_DATA::default()
        }
    }

    #[test]
    fn mavsdks_follow_target_is_a_position_with_no_velocity_or_heading() {
        let t = follow_target(245, &mavsdk_follow_target()).expect("taken");
        assert_eq!((t.system_id, t.source), (245, FollowSource::FollowTarget));
        assert!((t.lat_deg - 6.7971).abs() < 1e-9 && (t.lon_deg - 79.9017).abs() < 1e-9);
        assert_eq!((t.alt_amsl_m, t.alt_above_home_m), (25.0, None));
        assert_eq!(t.velocity_ned_m_s, [0.0; 3], "velocity bit not set: not read");
        assert_eq!((t.heading_rad, t.heading_rate_rad_s), (None, 0.0));
    }

    #[test]
    fn follow_target_bits_choose_what_is_read_and_a_claimed_nan_is_refused() {
        // Heading east (90° about down), turning at 0.2 rad/s about the body's down axis.
        let h = FRAC_PI_2 / 2.0;
        let m = FOLLOW_TARGET_DATA {
            est_capabilities: 0b1111,
            acc: [0.5, 0.0, 0.0],
            attitude_q: [h.cos() as f32, 0.0, 0.0, h.sin() as f32],
            rates: [0.0, 0.0, 0.2],
            ..mavsdk_follow_target()
        };
        let t = follow_target(3, &m).expect("taken");
        assert_eq!(t.velocity_ned_m_s, [3.0, 0.0, 0.0]);
        assert_eq!(t.acceleration_ned_m_s2, [0.5, 0.0, 0.0]);
        assert!((t.heading_rad.expect("heading") - FRAC_PI_2).abs() < 1e-6);
        assert!((t.heading_rate_rad_s - 0.2).abs() < 1e-6);
        let nan_velocity = FOLLOW_TARGET_DATA { est_capabilities: 0b11, vel: [f32::NAN; 3], ..m };
        assert_eq!(follow_target(3, &nan_velocity), Err(ReportRefused::Invalid));
        let no_position = FOLLOW_TARGET_DATA { est_capabilities: 0b10, ..m };
        assert_eq!(follow_target(3, &no_position), Err(ReportRefused::NoPosition));
        let no_fix = FOLLOW_TARGET_DATA { lat: 0, lon: 0, ..m };
        assert_eq!(follow_target(3, &no_fix), Err(ReportRefused::NoFix));
    }

    #[test]
    fn global_position_int_gives_both_altitudes_a_velocity_and_a_heading_unless_unknown() {
        let m = GLOBAL_POSITION_INT_DATA {
            lat: 67_971_000,
            lon: 799_017_000,
            alt: 27_500,
            relative_alt: 7_500,
            vx: 300,
            vy: -150,
            vz: 20,
            hdg: 9000,
            ..GLOBAL_POSITION_INT_DATA::default()
        };
        let t = global_position_int(2, &m).expect("taken");
        assert_eq!((t.alt_amsl_m, t.alt_above_home_m), (27.5, Some(7.5)));
        assert_eq!(t.velocity_ned_m_s, [3.0, -1.5, 0.2]);
        assert!((t.heading_rad.expect("heading") - FRAC_PI_2).abs() < 1e-12);
        let unknown = GLOBAL_POSITION_INT_DATA { hdg: u16::MAX, ..m };
        assert_eq!(global_position_int(2, &unknown).expect("taken").heading_rad, None);
        let from = Sender { system_id: 2, component_id: 1 };
        assert!(matches!(
            report(from, &MavMessage::GLOBAL_POSITION_INT(m)),
            Some(Ok(Command::FollowTarget(_)))
        ));
        assert!(report(from, &MavMessage::HEARTBEAT(Default::default())).is_none());
    }
}
