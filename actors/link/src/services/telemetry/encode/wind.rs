//! WIND: the estimator's learnt wind as ArduPilot sends it.

use mavlink::dialects::ardupilotmega::WIND_DATA;

/// WIND from the estimator's wind (m/s, north and east: the air's velocity over the ground):
/// the direction it blows *from* (degrees clockwise from north, 0..360) and its speed; no
/// vertical wind is estimated.
pub fn wind(wind_ne_m_s: [f64; 2]) -> WIND_DATA {
    let (from_deg, speed_m_s) = kestrel_proto::wind::direction(wind_ne_m_s);
    WIND_DATA { direction: from_deg as f32, speed: speed_m_s as f32, speed_z: 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wind_says_where_the_learnt_wind_blows_from() {
        for (ne, from_deg) in
            [([0.0, 1.0], 270.0), ([-2.0, 0.0], 0.0), ([1.0, 1.0], 225.0), ([0.0, -3.0], 90.0)]
        {
            let w = wind(ne);
            assert!((f64::from(w.direction) - from_deg).abs() < 1e-4, "{ne:?}: {w:?}");
            assert!((f64::from(w.speed) - ne[0].hypot(ne[1])).abs() < 1e-6, "{ne:?}: {w:?}");
            assert_eq!(w.speed_z, 0.0);
        }
    }
}
