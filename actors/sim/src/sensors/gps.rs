//! The GNSS receiver: position on WGS-84 (through `kestrel_proto::geo`, the one conversion),
//! NED velocity, accuracies and fix quality, stamped with the time of validity and released
//! `lag_s` later.

use kestrel_proto::Time;
use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{GpsFix, GpsFixType};
use nalgebra::Vector3;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, non_negative, rate};
use crate::rigid_body::RigidBodyState;
use crate::sensors::noise::standard_normal3;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GpsParams {
    /// Solution rate (Hz).
    pub rate_hz: f64,
    /// Delay from time of validity to delivery (s).
    pub lag_s: f64,
    /// 1σ white noise of north and east position (m); reported as `h_acc_m`.
    pub horizontal_noise_m: f64,
    /// 1σ white noise of down position (m); reported as `v_acc_m`.
    pub vertical_noise_m: f64,
    /// 1σ white noise of each velocity component (m/s); reported as `s_acc_m_s`.
    pub velocity_noise_m_s: f64,
    /// Satellites the receiver reports using.
    pub satellites: u8,
}

impl Default for GpsParams {
    /// u-blox M8N at 5 Hz, 220 ms lag and 0.5 m horizontal noise as in the thesis (§4.1).
    fn default() -> GpsParams {
        GpsParams {
            rate_hz: 5.0,
            lag_s: 0.22,
            horizontal_noise_m: 0.5,
            vertical_noise_m: 0.8,
            velocity_noise_m_s: 0.1,
            satellites: 12,
        }
    }
}

impl GpsParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        rate("rate_hz", self.rate_hz)?;
        non_negative("lag_s", self.lag_s)?;
        if self.lag_s > 10.0 {
            return Err(InvalidParam::new("lag_s", "must not exceed 10 s"));
        }
        non_negative("horizontal_noise_m", self.horizontal_noise_m)?;
        non_negative("vertical_noise_m", self.vertical_noise_m)?;
        non_negative("velocity_noise_m_s", self.velocity_noise_m_s)
    }
}

/// What the active faults do to the receiver (`faults.rs` says when; see
/// [`FaultKind`](crate::faults::FaultKind) for each kind).
#[derive(Clone, Debug, PartialEq)]
pub struct GpsFaults {
    /// `gps_off`: fixes flagged as no fix.
    pub off: bool,
    /// `gps_jump`: added to the reported position (m, NED).
    pub offset_ned_m: Vector3<f64>,
    /// `gps_noise`: multiplies the position and velocity noise 1σ.
    pub noise_factor: f64,
}

impl Default for GpsFaults {
    fn default() -> GpsFaults {
        GpsFaults { off: false, offset_ned_m: Vector3::zeros(), noise_factor: 1.0 }
    }
}

/// The accuracy a u-blox reports without a fix: `hAcc`/`vAcc`/`sAcc` all ones (0xFFFF_FFFF mm
/// or mm/s).
pub const NO_FIX_ACCURACY: f64 = 4_294_967.295;

/// The receiver's random stream, and the last position it had a fix at.
#[derive(Clone, Debug)]
pub(crate) struct Gps {
    params: GpsParams,
    rng: Pcg64,
    /// Latitude, longitude, altitude of the last fix, held while the fix is lost.
    last_position: Option<(f64, f64, f64)>,
}

impl Gps {
    pub(crate) fn new(params: &GpsParams, rng: Pcg64) -> Gps {
        Gps { params: params.clone(), rng, last_position: None }
    }

    /// A fix valid at `time` for the vehicle in `state`, as `faults` leave it. The noise is
    /// drawn whatever the faults, so a run's stream after a fault is the same as without it.
    pub(crate) fn measure(
        &mut self,
        time: Time,
        state: &RigidBodyState,
        frame: &LocalFrame,
        faults: &GpsFaults,
    ) -> GpsFix {
        let p = &self.params;
        let position_noise = standard_normal3(&mut self.rng).component_mul(&Vector3::new(
            p.horizontal_noise_m,
            p.horizontal_noise_m,
            p.vertical_noise_m,
        )) * faults.noise_factor;
        let velocity_noise = standard_normal3(&mut self.rng) * (p.velocity_noise_m_s * faults.noise_factor);
        if faults.off {
            let (lat_deg, lon_deg, alt_msl_m) = self.last_position.unwrap_or_else(|| {
                let home = frame.to_geodetic([0.0; 3]);
                (home.lat_deg, home.lon_deg, home.alt_m)
            });
            return GpsFix {
                time,
                fix_type: GpsFixType::NoFix,
                satellites: 0,
                lat_deg,
                lon_deg,
                alt_msl_m,
                vel_ned_m_s: [0.0; 3],
                h_acc_m: NO_FIX_ACCURACY,
                v_acc_m: NO_FIX_ACCURACY,
                s_acc_m_s: NO_FIX_ACCURACY,
            };
        }
        let position =
            frame.to_geodetic((state.position_ned_m + position_noise + faults.offset_ned_m).into());
        self.last_position = Some((position.lat_deg, position.lon_deg, position.alt_m));
        let velocity = state.velocity_ned_m_s + velocity_noise;
        GpsFix {
            time,
            fix_type: GpsFixType::Fix3d,
            satellites: p.satellites,
            lat_deg: position.lat_deg,
            lon_deg: position.lon_deg,
            alt_msl_m: position.alt_m,
            vel_ned_m_s: velocity.into(),
            h_acc_m: p.horizontal_noise_m,
            v_acc_m: p.vertical_noise_m,
            s_acc_m_s: p.velocity_noise_m_s,
        }
    }
}
