//! GLOBAL_POSITION_INT: the estimated position in WGS-84 (degE7, mm above sea level and above
//! the origin), velocity (cm/s, NED) and heading (cdeg).

use kestrel_proto::geo::{LocalFrame, deg_e7};
use kestrel_proto::messages::NavState;
use mavlink::dialects::ardupilotmega::GLOBAL_POSITION_INT_DATA;

use super::heading_cdeg;

/// GLOBAL_POSITION_INT from `nav`, stamped `boot_ms`; `None` before the estimator has a
/// geodetic origin.
pub fn global_position_int(nav: &NavState, boot_ms: u32) -> Option<GLOBAL_POSITION_INT_DATA> {
    let home = nav.origin?;
    let p = LocalFrame::new(home).to_geodetic(nav.position_ned_m);
    let v = nav.velocity_ned_m_s;
    Some(GLOBAL_POSITION_INT_DATA {
        time_boot_ms: boot_ms,
        lat: deg_e7(p.lat_deg),
        lon: deg_e7(p.lon_deg),
        alt: (p.alt_m * 1000.0).round() as i32,
        relative_alt: (-nav.position_ned_m[2] * 1000.0).round() as i32,
        vx: (v[0] * 100.0).round() as i16,
        vy: (v[1] * 100.0).round() as i16,
        vz: (v[2] * 100.0).round() as i16,
        hdg: heading_cdeg(nav.attitude),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::services::telemetry::encode::nav_facing_east;

    #[test]
    fn position_is_in_degrees_e7_and_millimetres_and_needs_an_origin() {
        let g = global_position_int(&nav_facing_east(), 0).expect("an origin");
        assert_eq!(g.relative_alt, 30_000);
        assert_eq!(g.alt, 50_000);
        assert_eq!(g.hdg, 9_000, "facing east");
        assert_eq!((g.vx, g.vy, g.vz), (100, 0, -50));
        assert!((f64::from(g.lat) * 1e-7 - 6.79710 - 10.0 / 110_600.0).abs() < 1e-5, "{}", g.lat);
        let mut lost = nav_facing_east();
        lost.origin = None;
        assert!(global_position_int(&lost, 0).is_none());
    }
}
