//! VFR_HUD: what a head-up display shows — ground speed (no airspeed sensor: the same), altitude
//! above sea level (m), climb rate (m/s, up positive) and heading (deg).

use kestrel_proto::messages::NavState;
use mavlink::dialects::ardupilotmega::VFR_HUD_DATA;

use super::heading_cdeg;

/// VFR_HUD from `nav`; the altitude is above the origin when the estimator has none.
pub fn vfr_hud(nav: &NavState) -> VFR_HUD_DATA {
    let v = nav.velocity_ned_m_s;
    let alt = nav.origin.map_or(-nav.position_ned_m[2], |o| o.alt_m - nav.position_ned_m[2]);
    VFR_HUD_DATA {
        airspeed: v[0].hypot(v[1]) as f32,
        groundspeed: v[0].hypot(v[1]) as f32,
        alt: alt as f32,
        climb: -v[2] as f32,
        heading: (heading_cdeg(nav.attitude) / 100) as i16,
        throttle: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::services::telemetry::encode::nav_facing_east;

    #[test]
    fn climb_is_up_positive_and_altitude_above_sea_level() {
        let h = vfr_hud(&nav_facing_east());
        assert_eq!((h.groundspeed, h.airspeed, h.climb, h.alt, h.heading), (1.0, 1.0, 0.5, 50.0, 90));
        let mut no_origin = nav_facing_east();
        no_origin.origin = None;
        assert_eq!(vfr_hud(&no_origin).alt, 30.0);
    }
}
