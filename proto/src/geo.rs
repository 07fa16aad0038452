//! WGS-84 geodetic coordinates and the local NED frame around home: the one place where
//! latitude/longitude/altitude become metres and back.
//!
//! The conversion goes through Earth-centred, Earth-fixed (ECEF) coordinates, so it stays
//! exact over any distance a multirotor flies, unlike the flat-earth approximation.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// WGS-84 semi-major axis (m).
const A: f64 = 6_378_137.0;
/// WGS-84 flattening.
const F: f64 = 1.0 / 298.257_223_563;
/// First eccentricity squared.
const E2: f64 = F * (2.0 - F);
/// Semi-minor axis (m).
const B: f64 = A * (1.0 - F);
/// Second eccentricity squared.
const EP2: f64 = (A * A - B * B) / (B * B);

/// An angle (degrees) in MAVLink's (and u-blox's) integer unit, degrees × 10⁷ (about 1.1 cm
/// of latitude), rounded to the nearest unit. Values beyond ±214.7° saturate (Rust's
/// float-to-int cast), which no latitude or longitude reaches.
pub fn deg_e7(deg: f64) -> i32 {
    (deg * 1e7).round() as i32
}

/// An angle in degrees × 10⁷ (MAVLink's `lat`/`lon`, `x`/`y` of `*_INT` messages), in degrees.
/// Takes `f64` so that COMMAND_INT's `x`/`y`, carried as floats, convert the same way.
pub fn deg_from_e7(deg_e7: f64) -> f64 {
    deg_e7 * 1e-7
}

/// A point on the WGS-84 ellipsoid.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Geodetic {
    /// Latitude (degrees, north positive).
    pub lat_deg: f64,
    /// Longitude (degrees, east positive).
    pub lon_deg: f64,
    /// Height (m). Kestrel treats this as altitude above mean sea level and ignores the
    /// geoid separation, which is constant over a flight and cancels in local coordinates.
    pub alt_m: f64,
}

impl Geodetic {
    fn to_ecef(self) -> [f64; 3] {
        let (lat, lon) = (self.lat_deg.to_radians(), self.lon_deg.to_radians());
        let n = A / (1.0 - E2 * lat.sin().powi(2)).sqrt();
        [
            (n + self.alt_m) * lat.cos() * lon.cos(),
            (n + self.alt_m) * lat.cos() * lon.sin(),
            (n * (1.0 - E2) + self.alt_m) * lat.sin(),
        ]
    }

    /// Bowring's closed form with one refinement, accurate to well under a millimetre near the
    /// Earth's surface.
    fn from_ecef(p: [f64; 3]) -> Geodetic {
        let [x, y, z] = p;
        let lon = y.atan2(x);
        let r = x.hypot(y);
        let theta = (z * A).atan2(r * B);
        let mut lat = (z + EP2 * B * theta.sin().powi(3)).atan2(r - E2 * A * theta.cos().powi(3));
        let mut n = A / (1.0 - E2 * lat.sin().powi(2)).sqrt();
        let mut alt = r / lat.cos() - n;
        for _ in 0..2 {
            lat = z.atan2(r * (1.0 - E2 * n / (n + alt)));
            n = A / (1.0 - E2 * lat.sin().powi(2)).sqrt();
            alt = r / lat.cos() - n;
        }
        Geodetic { lat_deg: lat.to_degrees(), lon_deg: lon.to_degrees(), alt_m: alt }
    }
}

/// The local tangent frame (north, east, down) with its origin at `home`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    home: Geodetic,
    home_ecef: [f64; 3],
    /// Rows: north, east, down unit vectors in ECEF.
    ecef_to_ned: [[f64; 3]; 3],
}

impl LocalFrame {
    /// A frame whose origin is `home`.
    pub fn new(home: Geodetic) -> LocalFrame {
        let (lat, lon) = (home.lat_deg.to_radians(), home.lon_deg.to_radians());
        let (sl, cl, so, co) = (lat.sin(), lat.cos(), lon.sin(), lon.cos());
        LocalFrame {
            home,
            home_ecef: home.to_ecef(),
            ecef_to_ned: [[-sl * co, -sl * so, cl], [-so, co, 0.0], [-cl * co, -cl * so, -sl]],
        }
    }

    /// The frame's origin.
    pub fn home(&self) -> Geodetic {
        self.home
    }

    /// North, east, down of `p` from home (m).
    pub fn to_ned(&self, p: Geodetic) -> [f64; 3] {
        let e = p.to_ecef();
        let d = [e[0] - self.home_ecef[0], e[1] - self.home_ecef[1], e[2] - self.home_ecef[2]];
        self.ecef_to_ned.map(|row| row[0] * d[0] + row[1] * d[1] + row[2] * d[2])
    }

    /// The geodetic point `ned` metres north, east, down of home.
    pub fn to_geodetic(&self, ned: [f64; 3]) -> Geodetic {
        let m = &self.ecef_to_ned;
        let mut e = self.home_ecef;
        for (i, ei) in e.iter_mut().enumerate() {
            *ei += m[0][i] * ned[0] + m[1][i] * ned[1] + m[2][i] * ned[2];
        }
        Geodetic::from_ecef(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const MORATUWA: Geodetic = Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 };

    #[test]
    fn degrees_e7_round_to_the_nearest_unit_and_back() {
        assert_eq!(deg_e7(MORATUWA.lat_deg), 67_971_000);
        assert_eq!(deg_e7(-33.866_661_4), -338_666_614);
        assert_eq!(deg_e7(180.0), 1_800_000_000);
        assert!((deg_from_e7(f64::from(deg_e7(MORATUWA.lon_deg))) - MORATUWA.lon_deg).abs() < 1e-9);
    }

    #[test]
    fn one_arcsecond_north_is_about_thirty_metres() {
        // Independent figure: a meridian arc-second at 6.8° latitude is 30.71 m on WGS-84
        // (M = a(1−e²)/(1−e² sin²φ)^{3/2}, times π/648000).
        let frame = LocalFrame::new(MORATUWA);
        let p = Geodetic { lat_deg: MORATUWA.lat_deg + 1.0 / 3600.0, ..MORATUWA };
        let ned = frame.to_ned(p);
        assert!((ned[0] - 30.71).abs() < 0.01, "{ned:?}");
        assert!(ned[1].abs() < 1e-6 && ned[2].abs() < 1e-3, "{ned:?}");
    }

    #[test]
    fn up_is_negative_down() {
        let frame = LocalFrame::new(MORATUWA);
        let ned = frame.to_ned(Geodetic { alt_m: 120.0, ..MORATUWA });
        assert!((ned[2] + 100.0).abs() < 1e-6, "{ned:?}");
    }

    proptest! {
        #[test]
        fn ned_round_trip_is_exact_to_a_millimetre(
            lat in -80.0f64..80.0, lon in -180.0f64..180.0, alt in -100.0f64..3000.0,
            n in -5000.0f64..5000.0, e in -5000.0f64..5000.0, d in -1000.0f64..100.0,
        ) {
            let frame = LocalFrame::new(Geodetic { lat_deg: lat, lon_deg: lon, alt_m: alt });
            let back = frame.to_ned(frame.to_geodetic([n, e, d]));
            for (got, want) in back.iter().zip([n, e, d]) {
                prop_assert!((got - want).abs() < 1e-3, "{back:?} vs {:?}", [n, e, d]);
            }
        }
    }
}
