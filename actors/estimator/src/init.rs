//! Alignment of a still vehicle: roll and pitch from the mean specific force, yaw from the mean
//! magnetometer reading (plus declination), the Earth field for magnetometer fusion from that
//! mean rotated into NED (thesis §3.1.2 after eq. 3.28), and the barometric height datum from the
//! mean pressure altitude. Every reference is an average over the still window, not one sample:
//! a single sample's noise would otherwise stay in the yaw, the reference field (and so in
//! every later magnetometer innovation) and every height the filter reports. The NED origin
//! comes later, from the first good 3D GPS fix (see `aiding::gps`).

use kestrel_proto::Time;
use kestrel_proto::messages::{BaroSample, ImuSample, MagSample};
use nalgebra::{UnitQuaternion, Vector3};

use crate::params::EkfParams;

/// What the alignment found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aligned {
    /// Time of the last sample of the still window.
    pub time: Time,
    /// Rotation from body FRD to NED.
    pub attitude: UnitQuaternion<f64>,
    /// The Earth's field in NED (gauss), when a magnetometer sample was available.
    pub mag_earth_ned_gauss: Option<Vector3<f64>>,
    /// Mean pressure altitude over the window (m above mean sea level): the height datum, when
    /// a barometer sample was available.
    pub baro_altitude_m: Option<f64>,
}

/// A running sum and count, for a mean over the still window.
#[derive(Clone, Copy, Debug, Default)]
struct Mean<T> {
    sum: T,
    count: u32,
}

impl<T: Copy + std::ops::AddAssign + std::ops::Div<f64, Output = T>> Mean<T> {
    fn add(&mut self, value: T) {
        self.sum += value;
        self.count += 1;
    }

    fn get(&self) -> Option<T> {
        (self.count > 0).then(|| self.sum / f64::from(self.count))
    }
}

/// Collects IMU samples until they have been still for the alignment window.
#[derive(Clone, Debug, Default)]
pub struct Alignment {
    start: Option<Time>,
    samples: u32,
    accel_sum_m_s2: Vector3<f64>,
    accel_norm_min_m_s2: f64,
    accel_norm_max_m_s2: f64,
    /// Body-frame field measured within the still window (gauss).
    mag_body_gauss: Mean<Vector3<f64>>,
    /// Pressure altitudes measured within the still window (m), and their range.
    baro_altitude_m: Mean<f64>,
    baro_min_max_m: Option<(f64, f64)>,
    /// The newest magnetometer sample, for a magnetometer slower than the window.
    latest_mag: Option<MagSample>,
    /// Samples measured before this are left out: they predate a sensor calibration
    /// ([`Alignment::from`]).
    not_before: Time,
}

impl Alignment {
    /// An alignment from samples measured at or after `time` only: those earlier were corrected
    /// by a calibration since replaced, and would tilt or turn the new alignment.
    pub fn from(time: Time) -> Alignment {
        Alignment { not_before: time, ..Alignment::default() }
    }

    /// Adds a magnetometer sample measured within the still window to the yaw's mean.
    pub fn push_mag(&mut self, sample: &MagSample) {
        if sample.time < self.not_before {
            return;
        }
        if self.start.is_some_and(|start| sample.time >= start) {
            self.mag_body_gauss.add(Vector3::from(sample.field_gauss));
        }
        self.latest_mag = Some(sample.clone());
    }

    /// Adds a barometer sample measured within the still window to the height datum's mean; a
    /// sample that spreads the window's altitudes past `align_max_baro_spread_m` starts the
    /// window again at the next IMU sample (the sample is dropped, the next window judges anew).
    pub fn push_baro(&mut self, sample: &BaroSample, params: &EkfParams) {
        if self.start.is_none_or(|start| sample.time < start) {
            return;
        }
        let altitude = sample.altitude_m;
        let (lo, hi) =
            self.baro_min_max_m.map_or((altitude, altitude), |(lo, hi)| (lo.min(altitude), hi.max(altitude)));
        if hi - lo > params.align_max_baro_spread_m {
            tracing::warn!(
                altitude_m = altitude,
                window_m = ?self.baro_min_max_m,
                "alignment: barometer altitudes spread over {:.1} m while still; starting the window again",
                hi - lo
            );
            self.start = None;
            return;
        }
        self.baro_min_max_m = Some((lo, hi));
        self.baro_altitude_m.add(altitude);
    }

    /// Adds an IMU sample (finite, checked by the caller); returns the alignment once the vehicle
    /// has been still for `align_duration_s`.
    pub fn push_imu(&mut self, sample: &ImuSample, params: &EkfParams) -> Option<Aligned> {
        if sample.time < self.not_before {
            return None;
        }
        let accel = Vector3::from(sample.accel_m_s2);
        let gyro = Vector3::from(sample.gyro_rad_s);
        let norm = accel.norm();
        let moving = gyro.norm() > params.align_max_rate_rad_s || norm < 1.0;
        let start = match self.start {
            Some(start) if !moving => start,
            _ => {
                self.restart(sample.time, accel);
                return None;
            }
        };
        self.samples += 1;
        self.accel_sum_m_s2 += accel;
        self.accel_norm_min_m_s2 = self.accel_norm_min_m_s2.min(norm);
        self.accel_norm_max_m_s2 = self.accel_norm_max_m_s2.max(norm);
        if self.accel_norm_max_m_s2 - self.accel_norm_min_m_s2 > params.align_max_accel_spread_m_s2 {
            self.restart(sample.time, accel);
            return None;
        }
        if (sample.time - start).as_secs_f64() < params.align_duration_s {
            return None;
        }
        let mean = self.accel_sum_m_s2 / f64::from(self.samples);
        let roll = (-mean.y).atan2(-mean.z);
        let pitch = mean.x.atan2(mean.y.hypot(mean.z));
        let tilt = UnitQuaternion::from_euler_angles(roll, pitch, 0.0);
        let mag_body = self.mag_body_gauss.get().or(self.latest_mag.as_ref().map(|m| m.field_gauss.into()));
        let (attitude, mag_earth_ned_gauss) = match mag_body {
            Some(body) => {
                let level = tilt * body;
                let yaw = params.mag_declination_deg.to_radians() - level.y.atan2(level.x);
                let attitude = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
                (attitude, Some(attitude * body))
            }
            None => (tilt, None),
        };
        let baro_altitude_m = self.baro_altitude_m.get();
        Some(Aligned { time: sample.time, attitude, mag_earth_ned_gauss, baro_altitude_m })
    }

    fn restart(&mut self, time: Time, accel: Vector3<f64>) {
        let norm = accel.norm();
        self.start = Some(time);
        self.samples = 1;
        self.accel_sum_m_s2 = accel;
        self.accel_norm_min_m_s2 = norm;
        self.accel_norm_max_m_s2 = norm;
        self.mag_body_gauss = Mean::default();
        self.baro_altitude_m = Mean::default();
        self.baro_min_max_m = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::units::GRAVITY_M_S2;

    fn still(attitude: UnitQuaternion<f64>, field_ned: Vector3<f64>, params: &EkfParams) -> Aligned {
        let mut a = Alignment::default();
        let specific_force = attitude.inverse() * Vector3::new(0.0, 0.0, -GRAVITY_M_S2);
        a.push_mag(&MagSample { time: Time::ZERO, field_gauss: (attitude.inverse() * field_ned).into() });
        for i in 0..1000u64 {
            let s = ImuSample {
                time: Time::from_micros(2500 * i),
                gyro_rad_s: [0.0; 3],
                accel_m_s2: specific_force.into(),
                dt_s: 0.0025,
                gyro_clipped: [false; 3],
                accel_clipped: [false; 3],
            };
            if let Some(aligned) = a.push_imu(&s, params) {
                return aligned;
            }
        }
        panic!("never aligned");
    }

    /// A 400 Hz sample of a still, level vehicle.
    fn level_still(time: Time) -> ImuSample {
        ImuSample {
            time,
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
            dt_s: 0.0025,
            gyro_clipped: [false; 3],
            accel_clipped: [false; 3],
        }
    }

    /// Alternating noise on the magnetometer and barometer: the references are the window's
    /// means, exactly; samples from before the window are left out.
    #[test]
    fn references_are_the_means_over_the_still_window() {
        let params = EkfParams::default();
        let field = Vector3::new(0.4, 0.0, 0.1);
        let mut a = Alignment::default();
        a.push_baro(
            &BaroSample { time: Time::ZERO, pressure_pa: 0.0, altitude_m: 99.0, temperature_c: 0.0 },
            &params,
        );
        let mut aligned = None;
        for i in 0..1000u64 {
            let time = Time::from_micros(2500 * i);
            let s = level_still(time);
            if i % 4 == 1 {
                let sign = if i % 8 == 1 { 1.0 } else { -1.0 };
                let noisy = field + Vector3::new(0.0, 0.05 * sign, 0.0);
                a.push_mag(&MagSample { time, field_gauss: noisy.into() });
                let altitude_m = 20.0 + 2.0 * sign;
                a.push_baro(&BaroSample { time, pressure_pa: 0.0, altitude_m, temperature_c: 0.0 }, &params);
            }
            aligned = aligned.or(a.push_imu(&s, &params));
        }
        let aligned = aligned.expect("aligned");
        assert!((aligned.baro_altitude_m.unwrap() - 20.0).abs() < 1e-9, "{aligned:?}");
        assert!(aligned.attitude.angle_to(&UnitQuaternion::identity()) < 1e-9, "{aligned:?}");
        assert!((aligned.mag_earth_ned_gauss.unwrap() - field).norm() < 1e-9, "{aligned:?}");
    }

    /// The datum a still, level vehicle aligns with under `params`, its barometer reading
    /// `altitude_m(i)` every 40th IMU sample `i` (10 Hz).
    fn datum_with_baro(params: &EkfParams, altitude_m: impl Fn(u64) -> f64) -> Option<f64> {
        let mut a = Alignment::default();
        let mut aligned = None;
        for i in 0..1000u64 {
            let time = Time::from_micros(2500 * i);
            if i % 40 == 1 {
                let sample =
                    BaroSample { time, pressure_pa: 0.0, altitude_m: altitude_m(i), temperature_c: 0.0 };
                a.push_baro(&sample, params);
            }
            let s = level_still(time);
            aligned = aligned.or(a.push_imu(&s, params));
        }
        aligned.and_then(|a| a.baro_altitude_m)
    }

    /// A barometer sample 80 m off inside the still window (what a first MS5611 conversion
    /// against a stale temperature gave in HIL) starts the window again: the datum is the clean
    /// samples' mean, not pulled 8 m by one sample in ten.
    #[test]
    fn a_baro_outlier_in_the_window_restarts_it_and_stays_out_of_the_datum() {
        let outlier_then_noise =
            |i: u64| if i == 41 { 99.4 } else { 20.0 + if i % 80 == 1 { 0.2 } else { -0.2 } };
        let datum = datum_with_baro(&EkfParams::default(), outlier_then_noise).expect("a datum");
        assert!((datum - 20.0).abs() <= 0.2, "datum {datum} m: the outlier leaked in");
        let unguarded = EkfParams { align_max_baro_spread_m: 100.0, ..EkfParams::default() };
        let leaked = datum_with_baro(&unguarded, |i| if i == 41 { 99.4 } else { 20.0 }).expect("a datum");
        assert!(leaked > 25.0, "without the spread check the outlier shows ({leaked} m): the test sees it");
    }

    #[test]
    fn recovers_roll_pitch_yaw_of_a_still_vehicle() {
        let params = EkfParams { mag_declination_deg: -2.0, ..EkfParams::default() };
        let truth = UnitQuaternion::from_euler_angles(0.1, -0.2, 2.5);
        let dec = (-2.0f64).to_radians();
        let field = Vector3::new(0.4 * dec.cos(), 0.4 * dec.sin(), 0.1);
        let aligned = still(truth, field, &params);
        assert!(aligned.attitude.angle_to(&truth) < 1e-9, "{:?}", aligned.attitude.euler_angles());
        assert!((aligned.mag_earth_ned_gauss.unwrap() - field).norm() < 1e-9);
    }
}
