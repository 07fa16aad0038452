//! How wind is written down. The estimator and the simulator carry it as a vector, the velocity
//! of the air over the ground (m/s, north and east); ground stations and ArduPilot's `SIM_WIND_*`
//! and WIND message give the direction it blows *from* (degrees clockwise from north) and a
//! speed. One convention, both ways, here.

/// The air's velocity (m/s, north and east) of a wind of `speed_m_s` blowing from `from_deg`.
pub fn from_direction(speed_m_s: f64, from_deg: f64) -> [f64; 2] {
    let towards = (from_deg + 180.0).to_radians();
    [speed_m_s * towards.cos(), speed_m_s * towards.sin()]
}

/// The direction the wind `ne_m_s` (the air's velocity, m/s, north and east) blows from
/// (degrees clockwise from north, 0..360) and its speed (m/s).
pub fn direction(ne_m_s: [f64; 2]) -> (f64, f64) {
    let [north, east] = ne_m_s;
    ((-east).atan2(-north).to_degrees().rem_euclid(360.0), north.hypot(east))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wind_from_a_direction_blows_towards_the_opposite_one_and_back() {
        // From the east: the air moves west.
        let [n, e] = from_direction(10.0, 90.0);
        assert!(n.abs() < 1e-9 && (e + 10.0).abs() < 1e-9, "{n} {e}");
        for (ne, from_deg) in [([0.0, 1.0], 270.0), ([-2.0, 0.0], 0.0), ([1.0, 1.0], 225.0)] {
            let (from, speed) = direction(ne);
            assert!((from - from_deg).abs() < 1e-9 && (speed - ne[0].hypot(ne[1])).abs() < 1e-12, "{ne:?}");
        }
        for from_deg in [0.0, 33.0, 225.0, 359.0] {
            let (back, speed) = direction(from_direction(3.0, from_deg));
            // 0° and 360° are one direction: compare round the circle.
            let apart = (back - from_deg + 180.0).rem_euclid(360.0) - 180.0;
            assert!(apart.abs() < 1e-9 && (speed - 3.0).abs() < 1e-12, "{from_deg}: {back}");
        }
    }
}
