//! The estimator's tuning, from the `[actors.estimator.params]` table of the config.
//!
//! Defaults are the thesis's (§3.1, §4.1): accelerometer process noise 0.25 m/s², GPS position
//! 0.5 m and velocity 0.5 m/s, barometer height 2 m and climb rate 1.5 m/s, GPS lag 220 ms and
//! barometer lag 50 ms. Where the thesis is silent the values are PX4 EKF2's defaults.

use serde::{Deserialize, Serialize};

use crate::error::ParamError;

/// Every tuning value of the filter. Units are in the names; noises are 1σ.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EkfParams {
    /// Gyro white noise driving attitude uncertainty (rad/s); PX4 EKF2_GYR_NOISE.
    pub gyro_noise_rad_s: f64,
    /// Accelerometer white noise driving velocity uncertainty (m/s²); thesis 0.25.
    pub accel_noise_m_s2: f64,
    /// Gyro bias random walk (rad/s²); PX4 EKF2_GYR_B_NOISE.
    pub gyro_bias_noise_rad_s2: f64,
    /// Accelerometer bias random walk (m/s³); PX4 EKF2_ACC_B_NOISE.
    pub accel_bias_noise_m_s3: f64,
    /// GPS north/east position noise (m); the receiver's own `h_acc_m` is used when larger.
    pub gps_position_noise_m: f64,
    /// GPS velocity noise per axis (m/s); the receiver's `s_acc_m_s` is used when larger.
    pub gps_velocity_noise_m_s: f64,
    /// Barometric height noise (m).
    pub baro_height_noise_m: f64,
    /// Noise of the climb rate differentiated from the barometer (m/s).
    pub baro_climb_rate_noise_m_s: f64,
    /// Fuse the barometric climb rate (thesis eq. 3.21) besides the height.
    pub fuse_baro_climb_rate: bool,
    /// Magnetometer noise per axis (gauss); PX4 EKF2_MAG_NOISE.
    pub mag_noise_gauss: f64,
    /// Innovation gate of GPS position and velocity (standard deviations).
    pub gps_gate_sigma: f64,
    /// Innovation gate of barometric height and climb rate (standard deviations).
    pub baro_gate_sigma: f64,
    /// Innovation gate of each magnetometer axis (standard deviations).
    pub mag_gate_sigma: f64,
    /// How long after its time of validity a GPS fix arrives (s).
    pub gps_lag_s: f64,
    /// How long after measurement a barometer sample arrives (s).
    pub baro_lag_s: f64,
    /// How long after measurement a magnetometer sample arrives (s).
    pub mag_lag_s: f64,
    /// Fuse each sample against the state at its measurement time (a delayed fusion horizon
    /// as long as the largest lag plus `arrival_margin_s`). Off: fuse on arrival against the
    /// newest state, as a filter without a delay buffer would.
    pub lag_compensation: bool,
    /// How much later than its nominal lag a sample may arrive and still be fused (s): the
    /// horizon runs this much further behind. A sample stamped with its time of validity (the
    /// u-blox driver) or conversion (the MS5611's) reaches the estimator through a UART, a
    /// tokio task and a mailbox, each adding jitter on a loaded board; with no margin every
    /// sample a millisecond late was refused ("older than the delayed fusion horizon") and the
    /// HIL flights dead-reckoned under load. 0 in lockstep, where lags are exact. PX4 and
    /// ArduPilot stamp samples on arrival minus the configured delay instead
    /// (`EKF2_GPS_DELAY`, `EK3_GPS_DELAY`), which hides the jitter in the timestamp.
    pub arrival_margin_s: f64,
    /// Angle from true north to magnetic north, east positive (degrees).
    pub mag_declination_deg: f64,
    /// Relative deviation of the field strength from the aligned one beyond which a magnetometer
    /// sample counts as disturbed and is not fused (0.3 = ±30 %).
    pub mag_strength_tolerance: f64,
    /// Realign yaw and the reference field from the magnetometer once in flight, above
    /// `mag_yaw_reset_height_m` (PX4 EKF2's in-flight yaw alignment): the field on the ground is
    /// often disturbed (steel, the launch pad), and the alignment took it as the Earth's.
    pub in_flight_yaw_reset: bool,
    /// Height above the take-off point (the alignment's height datum) at which the in-flight
    /// yaw realignment happens (m); PX4 realigns at 1.5 m.
    pub mag_yaw_reset_height_m: f64,
    /// GPS position (or velocity) rejected continuously for this long resets it to GPS (s);
    /// PX4 EKF2's `reset_timeout_max`, 7 s.
    pub gps_reset_timeout_s: f64,
    /// Longest horizontal move a GPS position reset (after `gps_reset_timeout_s` of rejection)
    /// may make (m): a longer one is refused, reported, and the position flagged invalid, so the
    /// commander's estimator failsafe lands or holds where the vehicle is rather than flying
    /// to a home that GPS has moved. Well under the geofence's 300 m radius; ArduPilot's
    /// nearest is `EK3_GLITCH_RAD` (25 m). Resets after a GPS loss are not limited: dead
    /// reckoning has no bound to hold them to.
    pub gps_reset_max_m: f64,
    /// GPS velocity rejected continuously for this long resets velocity to GPS and raises the
    /// tilt and bias uncertainty (s): the inertial prediction, not GPS velocity, is wrong.
    pub gps_velocity_reset_timeout_s: f64,
    /// No GPS observation fused for this long and GPS is lost: the next usable fix resets
    /// position and velocity (s).
    pub gps_timeout_s: f64,
    /// GPS height noise floor (m), fused when the barometer is faulty; the receiver's `v_acc_m`
    /// is used when larger.
    pub gps_height_noise_m: f64,
    /// Barometric height not fused for this long: vertical position not aided; a rejection run
    /// this long makes the barometer faulty (or resets the height to it without GPS) (s); PX4
    /// EKF2's `hgt_fusion_timeout_max`, 5 s.
    pub baro_timeout_s: f64,
    /// Largest change of the baro-minus-GPS height difference before the two count as
    /// disagreeing (m).
    pub baro_gps_tolerance_m: f64,
    /// Barometer and GPS height disagreeing for this long: the one that moved away from the
    /// height propagated on GPS's Doppler vertical velocity is faulty (s); see [`crate::aiding::baro_control`].
    pub baro_fault_timeout_s: f64,
    /// Magnetometer not fused for this long: reported not fusing (s).
    pub mag_timeout_s: f64,
    /// Without horizontal aiding (GPS position or velocity) for this long the position is
    /// flagged invalid (s); PX4 EKF2_NOAID_TOUT, 5 s.
    pub horizontal_position_timeout_s: f64,
    /// Noise of the synthetic "stay here" position fused while there is no GPS at all (m).
    pub no_aiding_position_noise_m: f64,
    /// Fewest satellites for a fix to be used.
    pub gps_min_satellites: u8,
    /// Largest reported horizontal accuracy for a fix to be used (m).
    pub gps_max_h_acc_m: f64,
    /// Length of the still period the alignment averages (s).
    pub align_duration_s: f64,
    /// Largest gyro rate during alignment (rad/s).
    pub align_max_rate_rad_s: f64,
    /// Largest spread of the specific force magnitude during alignment (m/s²).
    pub align_max_accel_spread_m_s2: f64,
    /// Largest spread of the pressure altitudes during alignment (m): beyond any still
    /// barometer's noise (an MS5611 reads about 0.25 m; the thesis's model, 2 m, spreads 10
    /// samples over some 12 m), so only a gross error trips it (a first MS5611 conversion
    /// against a stale temperature read 80 m high in HIL), which would put its share of the
    /// error into the height datum: the window starts again without it.
    pub align_max_baro_spread_m: f64,
    /// Time constant with which the output predictor tracks the delayed state (s).
    pub output_tau_s: f64,
    /// Velocity uncertainty added per axis for each IMU sample with a clipped accelerometer
    /// axis (m/s, one sigma): full scale again over the sample's interval (16 g × 2.5 ms). A
    /// touchdown clipped at ±16 g in HIL left 0.3 m/s of descent in the estimate, which GPS and
    /// baro, against a confident covariance, did not take out for seconds: the land detector
    /// never saw the vehicle stop and the controller wound up on the ground.
    pub accel_clip_velocity_noise_m_s: f64,
    /// Drag per unit mass per unit airspeed, k₁ (1/s): the linear (rotor) part of the specific
    /// force the air puts on the body's x and y axes, −(k₁ + k₂·|v_air|)·v_air. With k₂ it
    /// lets the accelerometer measure the air-relative velocity, and so, with the wind learnt
    /// while GPS velocity is fused, the velocity once GPS is lost ([`crate::aiding::drag`]).
    /// PX4 EKF2_MCOEF (with EKF2_DRAG_CTRL), ArduPilot EK3_DRAG_MCOEF. 0 with k₂ 0: off, as
    /// both default: the coefficients belong to one airframe (the simulator's quad sets them
    /// from its vehicle file, config/sim.toml).
    pub drag_linear_per_s: f64,
    /// Drag per unit mass per unit airspeed squared, k₂ (1/m): the body's form drag, ½ρ·C_D·A/m
    /// (PX4's EKF2_BCOEF_X/Y and ArduPilot's EK3_DRAG_BCOEF_X/Y are ballistic coefficients
    /// m/(C_D·A) in kg/m², k₂ = ½ρ/BCOEF).
    pub drag_quadratic_per_m: f64,
    /// Noise of the air-relative velocity measured from drag, per body axis (m/s): the averaged
    /// accelerometer noise divided by the drag slope (0.08 m/s in the simulator), plus what the
    /// wind, held at its last estimate, leaves in it: gusts, which the drag cannot tell from
    /// the vehicle's own motion (0.3–0.8 m/s per axis in the simulated worlds), and the
    /// estimate's own error. An accelerometer bias the filter has not learnt reads as drag too:
    /// b m/s² is b/k₁ m/s of airspeed (10·b for the simulated quad).
    pub drag_velocity_noise_m_s: f64,
}

impl Default for EkfParams {
    fn default() -> EkfParams {
        EkfParams {
            gyro_noise_rad_s: 0.015,
            accel_noise_m_s2: 0.25,
            gyro_bias_noise_rad_s2: 1e-3,
            accel_bias_noise_m_s3: 3e-3,
            gps_position_noise_m: 0.5,
            gps_velocity_noise_m_s: 0.5,
            baro_height_noise_m: 2.0,
            baro_climb_rate_noise_m_s: 1.5,
            fuse_baro_climb_rate: true,
            mag_noise_gauss: 0.05,
            gps_gate_sigma: 5.0,
            baro_gate_sigma: 5.0,
            mag_gate_sigma: 3.0,
            gps_lag_s: 0.22,
            baro_lag_s: 0.05,
            mag_lag_s: 0.0,
            lag_compensation: true,
            arrival_margin_s: 0.0,
            mag_declination_deg: 0.0,
            mag_strength_tolerance: 0.3,
            in_flight_yaw_reset: true,
            mag_yaw_reset_height_m: 1.5,
            gps_reset_timeout_s: 7.0,
            gps_reset_max_m: 50.0,
            gps_velocity_reset_timeout_s: 1.0,
            gps_timeout_s: 1.0,
            gps_height_noise_m: 1.0,
            baro_timeout_s: 5.0,
            baro_gps_tolerance_m: 4.0,
            baro_fault_timeout_s: 1.0,
            mag_timeout_s: 5.0,
            horizontal_position_timeout_s: 5.0,
            no_aiding_position_noise_m: 10.0,
            gps_min_satellites: 6,
            gps_max_h_acc_m: 5.0,
            align_duration_s: 1.0,
            align_max_rate_rad_s: 0.1,
            align_max_accel_spread_m_s2: 0.5,
            align_max_baro_spread_m: 20.0,
            output_tau_s: 0.25,
            accel_clip_velocity_noise_m_s: 0.4,
            drag_linear_per_s: 0.0,
            drag_quadratic_per_m: 0.0,
            drag_velocity_noise_m_s: 1.0,
        }
    }
}

impl EkfParams {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ParamError> {
        let positive = [
            ("gyro_noise_rad_s", self.gyro_noise_rad_s),
            ("accel_noise_m_s2", self.accel_noise_m_s2),
            ("gyro_bias_noise_rad_s2", self.gyro_bias_noise_rad_s2),
            ("accel_bias_noise_m_s3", self.accel_bias_noise_m_s3),
            ("gps_position_noise_m", self.gps_position_noise_m),
            ("gps_velocity_noise_m_s", self.gps_velocity_noise_m_s),
            ("baro_height_noise_m", self.baro_height_noise_m),
            ("baro_climb_rate_noise_m_s", self.baro_climb_rate_noise_m_s),
            ("mag_noise_gauss", self.mag_noise_gauss),
            ("gps_gate_sigma", self.gps_gate_sigma),
            ("baro_gate_sigma", self.baro_gate_sigma),
            ("mag_gate_sigma", self.mag_gate_sigma),
            ("mag_strength_tolerance", self.mag_strength_tolerance),
            ("mag_yaw_reset_height_m", self.mag_yaw_reset_height_m),
            ("gps_reset_timeout_s", self.gps_reset_timeout_s),
            ("gps_reset_max_m", self.gps_reset_max_m),
            ("gps_velocity_reset_timeout_s", self.gps_velocity_reset_timeout_s),
            ("gps_timeout_s", self.gps_timeout_s),
            ("gps_height_noise_m", self.gps_height_noise_m),
            ("baro_timeout_s", self.baro_timeout_s),
            ("baro_gps_tolerance_m", self.baro_gps_tolerance_m),
            ("baro_fault_timeout_s", self.baro_fault_timeout_s),
            ("mag_timeout_s", self.mag_timeout_s),
            ("horizontal_position_timeout_s", self.horizontal_position_timeout_s),
            ("no_aiding_position_noise_m", self.no_aiding_position_noise_m),
            ("gps_max_h_acc_m", self.gps_max_h_acc_m),
            ("align_duration_s", self.align_duration_s),
            ("align_max_rate_rad_s", self.align_max_rate_rad_s),
            ("align_max_accel_spread_m_s2", self.align_max_accel_spread_m_s2),
            ("align_max_baro_spread_m", self.align_max_baro_spread_m),
            ("output_tau_s", self.output_tau_s),
            ("accel_clip_velocity_noise_m_s", self.accel_clip_velocity_noise_m_s),
            ("drag_velocity_noise_m_s", self.drag_velocity_noise_m_s),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ParamError::new(name, format!("must be finite and positive, got {value}")));
            }
        }
        for (name, value) in
            [("gps_lag_s", self.gps_lag_s), ("baro_lag_s", self.baro_lag_s), ("mag_lag_s", self.mag_lag_s)]
        {
            if !(value.is_finite() && (0.0..=MAX_LAG_S).contains(&value)) {
                return Err(ParamError::new(name, format!("must be within 0..={MAX_LAG_S} s, got {value}")));
            }
        }
        let largest_lag_s = self.gps_lag_s.max(self.baro_lag_s).max(self.mag_lag_s);
        if !(self.arrival_margin_s.is_finite()
            && self.arrival_margin_s >= 0.0
            && largest_lag_s + self.arrival_margin_s <= MAX_LAG_S)
        {
            return Err(ParamError::new(
                "arrival_margin_s",
                format!(
                    "must be at least 0 and at most {MAX_LAG_S} s with the largest lag ({largest_lag_s} s), got {}",
                    self.arrival_margin_s
                ),
            ));
        }
        for (name, value) in [
            ("drag_linear_per_s", self.drag_linear_per_s),
            ("drag_quadratic_per_m", self.drag_quadratic_per_m),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParamError::new(name, format!("must be finite and at least 0, got {value}")));
            }
        }
        if !(self.mag_declination_deg.is_finite() && self.mag_declination_deg.abs() <= 180.0) {
            return Err(ParamError::new("mag_declination_deg", "must be within ±180°"));
        }
        Ok(())
    }

    /// The delayed fusion horizon: how far behind the newest IMU sample the filter runs (s).
    pub fn fusion_horizon_s(&self) -> f64 {
        if self.lag_compensation {
            self.gps_lag_s.max(self.baro_lag_s).max(self.mag_lag_s) + self.arrival_margin_s
        } else {
            0.0
        }
    }
}

/// Longest sensor lag the delay buffer is sized for (s).
pub const MAX_LAG_S: f64 = 1.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_thesis_values_and_valid() {
        let p = EkfParams::default();
        p.validate().unwrap();
        assert_eq!((p.accel_noise_m_s2, p.gps_position_noise_m, p.gps_velocity_noise_m_s), (0.25, 0.5, 0.5));
        assert_eq!((p.baro_height_noise_m, p.baro_climb_rate_noise_m_s), (2.0, 1.5));
        assert_eq!((p.gps_gate_sigma, p.baro_gate_sigma, p.mag_gate_sigma), (5.0, 5.0, 3.0));
        assert_eq!((p.gps_lag_s, p.baro_lag_s), (0.22, 0.05));
    }

    #[test]
    fn bad_values_name_the_field() {
        let p = EkfParams { gps_lag_s: -0.1, ..EkfParams::default() };
        assert!(p.validate().unwrap_err().to_string().contains("gps_lag_s"));
        let p = EkfParams { accel_noise_m_s2: f64::NAN, ..EkfParams::default() };
        assert!(p.validate().unwrap_err().to_string().contains("accel_noise_m_s2"));
    }
}
