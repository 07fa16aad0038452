//! What the filter publishes: the present estimate for the controllers ([`NavState`], with what
//! each part is vouched for by) and the innovations, counters and health behind it
//! ([`EstimatorStatus`]).

use kestrel_proto::Time;
use kestrel_proto::messages::{EstimatorHealth, EstimatorStatus, NavState, NavValidity};

use super::Ekf;

impl Ekf {
    /// The present estimate for the controllers; `None` until aligned.
    pub fn nav_state(&self) -> Option<NavState> {
        let running = self.running.as_ref()?;
        let f = &running.filter.state;
        let o = running.output.current();
        let q = o.attitude.quaternion();
        let params = &self.params;
        let t = f.time;
        let gps_velocity = self.gps.velocity_aiding(t, params);
        let from_drag = !gps_velocity && self.drag.velocity_aiding(t, params);
        let height = self.baro.height_aiding(t, params)
            || (self.baro.height_from_gps() && self.gps.position_aiding(t, params));
        Some(NavState {
            time: o.time,
            attitude: [q.w, q.i, q.j, q.k],
            angular_velocity_rad_s: (self.newest_gyro_rad_s - f.gyro_bias_rad_s).into(),
            velocity_ned_m_s: o.vel_ned_m_s.into(),
            position_ned_m: o.pos_ned_m.into(),
            gyro_bias_rad_s: f.gyro_bias_rad_s.into(),
            accel_bias_m_s2: f.accel_bias_m_s2.into(),
            covariance_diagonal: running.filter.thesis_variances(),
            origin: self.frame.map(|frame| frame.home()),
            valid: NavValidity {
                attitude: true,
                horizontal_velocity: gps_velocity || from_drag,
                horizontal_velocity_from_drag: from_drag,
                // A refused GPS reset leaves an estimate GPS contradicts by more than
                // `gps_reset_max_m`: not vouched for, so the commander's estimator failsafe acts.
                horizontal_position: self
                    .gps
                    .horizontal_aiding_within(t, params.horizontal_position_timeout_s)
                    && self.gps.reset_refused().is_none(),
                vertical_velocity: gps_velocity || height,
                vertical_position: height,
            },
        })
    }

    /// Innovations, counters and health.
    pub fn status(&self) -> EstimatorStatus {
        let t = self.delayed_state().map_or(Time::ZERO, |s| s.time);
        let params = &self.params;
        let aligned = self.running.is_some();
        EstimatorStatus {
            time: self.newest_imu.unwrap_or(Time::ZERO),
            gps_position_ne: self.gps.position,
            gps_velocity_ned: self.gps.velocity,
            baro_height: self.baro.height,
            baro_climb_rate: self.baro.climb_rate,
            mag_field: self.mag.field,
            drag_air_velocity: self.drag.air_velocity,
            gps: self.gps.counters,
            baro: self.baro.counters,
            mag: self.mag.counters,
            drag: self.drag.counters,
            wind_ne_m_s: self.drag.wind_ne_m_s(),
            health: EstimatorHealth {
                tilt_aligned: aligned,
                yaw_aligned: aligned && self.mag.fusing(t, params),
                origin_set: self.frame.is_some(),
                gps_fusing: self.gps.horizontal_aiding_within(t, params.gps_timeout_s),
                baro_fusing: self.baro.height_aiding(t, params),
                mag_fusing: self.mag.fusing(t, params),
                drag_fusing: self.drag.fusing(t, params),
                dead_reckoning: aligned && !self.gps.position_aiding(t, params),
                // Refused fusions plus covariance resets (each also logged as it happens).
                numerical_faults: self
                    .running
                    .as_ref()
                    .map_or(0, |r| r.filter.numerical_faults + r.filter.covariance_resets),
                imu_rejected: self.imu_rejected,
                imu_gaps: self.imu_gaps,
                imu_switches: self.imu_switches,
                warm_starts: self.warm_starts,
                realignments: self.realignments,
                baro_faulty: self.baro.faulty(),
                gps_height_faulty: self.baro.gps_height_faulty(),
                // Whole metres (saturating: a reset refused is at least `gps_reset_max_m`).
                gps_reset_refused_m: self
                    .gps
                    .reset_refused()
                    .map(|m| m.round().min(f64::from(u32::MAX)) as u32),
                imu_clipped: self.imu_clipped,
            },
            fusion_horizon_s: self.newest_imu.map_or(0.0, |n| (n - t).as_secs_f64()),
        }
    }
}
