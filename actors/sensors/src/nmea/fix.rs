//! Joining one epoch's NMEA sentences into a [`GpsFix`].
//!
//! GGA carries the position; RMC or VTG the horizontal velocity. A fix is released once a GGA
//! and a velocity of the same epoch (same UTC time for RMC; VTG has no time and pairs with the
//! GGA next to it) are both in, whichever comes first — receivers differ in their order.
//! NMEA has no accuracy estimates, so they are derived from HDOP and a configured user
//! equivalent range error, and no vertical velocity, so down velocity is 0 with the speed
//! accuracy saying how little that is worth. A GGA without a position gives a `NoFix` at
//! 0°, 0°, so losing the fix is reported rather than silent. Stamps are the GGA's arrival
//! minus the configured receiver lag.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{GpsFix, GpsFixType};

use crate::nmea::messages::{Gga, NmeaMessage};

/// How NMEA-only quantities are filled in.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct NmeaFixOptions {
    /// User equivalent range error (m): 1σ horizontal accuracy = HDOP × this.
    pub uere_m: f64,
    /// Vertical over horizontal accuracy (typical VDOP/HDOP).
    pub vertical_factor: f64,
    /// 1σ speed accuracy reported with every fix (m/s).
    pub speed_accuracy_m_s: f64,
    /// HDOP assumed when the receiver leaves the field empty.
    pub default_hdop: f64,
    /// Delay from the epoch to the GGA's arrival (s).
    pub lag_s: f64,
}

impl Default for NmeaFixOptions {
    fn default() -> NmeaFixOptions {
        NmeaFixOptions {
            uere_m: 4.0,
            vertical_factor: 1.5,
            speed_accuracy_m_s: 0.5,
            default_hdop: 2.0,
            lag_s: 0.2,
        }
    }
}

/// A velocity waiting for its GGA.
#[derive(Clone, Copy, Debug)]
struct GroundVelocity {
    /// UTC time of day from RMC; `None` for VTG.
    utc_s: Option<f64>,
    vel_ne_m_s: [f64; 2],
}

/// Pairs GGA with RMC/VTG.
#[derive(Clone, Debug, Default)]
pub struct NmeaFixAssembler {
    options: NmeaFixOptions,
    gga: Option<(Gga, Time)>,
    velocity: Option<GroundVelocity>,
}

impl NmeaFixAssembler {
    pub fn new(options: NmeaFixOptions) -> NmeaFixAssembler {
        NmeaFixAssembler { options, gga: None, velocity: None }
    }

    /// Takes a decoded sentence that arrived at `arrival`; returns a fix when an epoch is
    /// complete.
    pub fn push(&mut self, msg: NmeaMessage, arrival: Time) -> Option<GpsFix> {
        match msg {
            NmeaMessage::Gga(gga) => self.gga = Some((gga, arrival)),
            NmeaMessage::Rmc(rmc) => {
                self.velocity = rmc
                    .valid
                    .then(|| ground_velocity(rmc.speed_m_s, rmc.course_deg))
                    .flatten()
                    .map(|vel_ne_m_s| GroundVelocity { utc_s: Some(rmc.utc_s), vel_ne_m_s });
            }
            NmeaMessage::Vtg(vtg) => {
                self.velocity = ground_velocity(vtg.speed_m_s, vtg.course_deg)
                    .map(|vel_ne_m_s| GroundVelocity { utc_s: None, vel_ne_m_s });
            }
            NmeaMessage::Other(_) => return None,
        }
        let (gga, arrival) = self.gga.as_ref()?;
        let velocity = self.velocity?;
        if velocity.utc_s.is_some_and(|t| (t - gga.utc_s).abs() > 1e-3) {
            return None;
        }
        let fix = self.fix(gga, *arrival, velocity.vel_ne_m_s);
        self.gga = None;
        self.velocity = None;
        Some(fix)
    }

    fn fix(&self, gga: &Gga, arrival: Time, vel_ne_m_s: [f64; 2]) -> GpsFix {
        let o = &self.options;
        let h_acc_m = gga.hdop.unwrap_or(o.default_hdop) * o.uere_m;
        let position = gga.lat_deg.zip(gga.lon_deg);
        let fix_type = match (position, gga.quality, gga.alt_msl_m) {
            (None, _, _) => GpsFixType::NoFix,
            (Some(_), 1, None) => GpsFixType::Fix2d,
            (Some(_), 1, Some(_)) => GpsFixType::Fix3d,
            (Some(_), 2, _) => GpsFixType::Dgps,
            (Some(_), 4, _) => GpsFixType::RtkFixed,
            (Some(_), 5, _) => GpsFixType::RtkFloat,
            _ => GpsFixType::NoFix,
        };
        let (lat_deg, lon_deg) = position.unwrap_or((0.0, 0.0));
        GpsFix {
            time: arrival.saturating_sub(Duration::from_secs_f64(o.lag_s.max(0.0))),
            fix_type,
            satellites: gga.satellites,
            lat_deg,
            lon_deg,
            alt_msl_m: gga.alt_msl_m.unwrap_or(0.0),
            vel_ned_m_s: [vel_ne_m_s[0], vel_ne_m_s[1], 0.0],
            h_acc_m,
            v_acc_m: h_acc_m * o.vertical_factor,
            s_acc_m_s: o.speed_accuracy_m_s,
        }
    }
}

/// North and east velocity (m/s) from speed (m/s) and course (degrees from true north).
fn ground_velocity(speed_m_s: Option<f64>, course_deg: Option<f64>) -> Option<[f64; 2]> {
    let speed = speed_m_s?;
    let course = course_deg.unwrap_or(0.0).to_radians();
    Some([speed * course.cos(), speed * course.sin()])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::sentence::Sentence;

    fn msg(line: &str) -> NmeaMessage {
        NmeaMessage::decode(&Sentence::parse(line).expect("valid")).expect("decodes")
    }

    const GGA: &str = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47";
    const RMC: &str = "$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A";

    #[test]
    fn rmc_then_gga_make_one_fix() {
        let mut assembler = NmeaFixAssembler::new(NmeaFixOptions::default());
        assert_eq!(assembler.push(msg(RMC), Time::from_micros(1_000_000)), None);
        let fix = assembler.push(msg(GGA), Time::from_micros(1_050_000)).expect("complete epoch");
        assert_eq!(fix.time, Time::from_micros(850_000));
        assert_eq!((fix.fix_type, fix.satellites), (GpsFixType::Fix3d, 8));
        assert!((fix.alt_msl_m - 545.4).abs() < 1e-12);
        let speed = 22.4 * 1852.0 / 3600.0;
        let course = 84.4f64.to_radians();
        assert!((fix.vel_ned_m_s[0] - speed * course.cos()).abs() < 1e-9);
        assert!((fix.vel_ned_m_s[1] - speed * course.sin()).abs() < 1e-9);
        assert!((fix.h_acc_m - 3.6).abs() < 1e-12);
        assert!((fix.v_acc_m - 5.4).abs() < 1e-12);
    }

    #[test]
    fn gga_then_vtg_and_stale_velocities() {
        let mut assembler = NmeaFixAssembler::new(NmeaFixOptions::default());
        assert_eq!(assembler.push(msg(GGA), Time::from_micros(1_000_000)), None);
        let fix =
            assembler.push(msg("$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48"), Time::from_micros(1_010_000));
        assert!(fix.is_some());
        // An RMC of another second does not pair with this GGA.
        let mut assembler = NmeaFixAssembler::new(NmeaFixOptions::default());
        assembler
            .push(msg("$GPRMC,123518,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6B"), Time::ZERO);
        assert_eq!(assembler.push(msg(GGA), Time::ZERO), None);
    }
}
