//! The estimator: IMU-driven prediction at a delayed fusion horizon, lagged GPS, barometer and
//! magnetometer fused against the state at their measurement time, and an output predictor
//! that carries the estimate to the present (thesis §3.1, laid out like PX4 EKF2).
//!
//! Every IMU sample goes into the delay buffer and moves the output predictor; samples older
//! than the horizon (the largest sensor lag) are taken out of the buffer and predict the
//! filter, after which every observation measured by then is fused. Pure and synchronous: the
//! actor shell, the replay and the tests all drive it the same way.

mod outputs;

use kestrel_proto::Time;
use kestrel_proto::geo::LocalFrame;
use kestrel_proto::messages::{BaroSample, GpsFix, ImuSample, LandedState, MagSample};
use nalgebra::Vector3;

use crate::aiding::baro::{ClimbRate, ClimbRateFit};
use crate::aiding::baro_control::BaroControl;
use crate::aiding::drag_control::DragControl;
use crate::aiding::gps_control::GpsControl;
use crate::aiding::mag_control::MagControl;
use crate::aiding::recent;
use crate::arrivals::Arrivals;
use crate::covariance::{ProcessNoise, SparseRow};
use crate::delay_buffer::DelayBuffer;
use crate::error::{InputError, ParamError};
use crate::filter::Filter;
use crate::init::Alignment;
use crate::output_predictor::OutputPredictor;
use crate::params::{EkfParams, MAX_LAG_S};
use crate::state::{Covariance, ImuDelta, POS, State};

/// Fastest IMU the delay buffer is sized for (Hz).
const MAX_IMU_RATE_HZ: f64 = 1000.0;
/// IMU samples the delay buffer and the output history hold: the longest lag at the fastest
/// IMU, with a margin.
const HISTORY_CAPACITY: usize = (MAX_LAG_S * MAX_IMU_RATE_HZ) as usize + 16;
/// Longest IMU interval accepted (s); a longer gap is a sensor fault.
const MAX_IMU_DT_S: f64 = 0.1;
/// A longer silence between two IMU samples is the stream stopping (s): the filter cannot have
/// predicted across it (see [`Ekf::resume_after_imu_gap`]).
const IMU_GAP_S: f64 = 0.1;
/// A GPS fix this recent lets the barometer fall back to GPS height (s).
const GPS_HEIGHT_AVAILABLE_S: f64 = 1.0;
/// Interval of the synthetic position fused while there is no horizontal aiding (s).
const NO_AIDING_INTERVAL_S: f64 = 0.2;

/// The filter and its output once aligned.
#[derive(Debug)]
struct Running {
    filter: Filter,
    output: OutputPredictor,
    last_no_aiding_fusion: Option<Time>,
    /// Where horizontal aiding was lost (m, north and east): the synthetic position fused since.
    held_position_ne_m: Option<[f64; 2]>,
    /// When the filter began: lagged samples measured before it (still in flight at alignment)
    /// are not fused, as samples before alignment are not, and are no fault to report.
    aligned_at: Time,
}

/// The 16-state EKF with its delay buffers, aiding logic and output predictor.
///
/// `clone_from` copies into the buffers it already has (the estimator keeps a copy for a
/// restarted successor every 20 ms, `KEEP_PERIOD_US`): no allocation once the copy holds a
/// filter with the same buffer capacities, which every filter of one process has.
#[derive(Debug)]
pub struct Ekf {
    params: EkfParams,
    noise: ProcessNoise,
    horizon_us: u64,
    alignment: Alignment,
    running: Option<Running>,
    imu_buffer: DelayBuffer<ImuDelta>,
    gps_buffer: DelayBuffer<GpsFix>,
    baro_buffer: DelayBuffer<BaroSample>,
    climb_buffer: DelayBuffer<ClimbRate>,
    mag_buffer: DelayBuffer<MagSample>,
    climb_fit: ClimbRateFit,
    gps: GpsControl,
    baro: BaroControl,
    mag: MagControl,
    drag: DragControl,
    /// The commander's landed state (PX4 passes its land detector's to EKF2,
    /// `set_in_air_status`): drag is measured only in the air.
    landed: LandedState,
    frame: Option<LocalFrame>,
    newest_imu: Option<Time>,
    newest_gyro_rad_s: Vector3<f64>,
    imu_rejected: u64,
    /// Times the IMU stream stopped and resumed in flight.
    imu_gaps: u32,
    /// Times the prediction moved to another IMU ([`Ekf::push_imu_from_new_source`]).
    imu_switches: u32,
    /// Times this filter resumed in a restarted estimator ([`Ekf::resumed`]).
    warm_starts: u32,
    /// Times an aligned filter was dropped to align again after a sensor calibration changed
    /// ([`Ekf::realign`]); a burst of changes before the new alignment counts once.
    realignments: u32,
    /// Accepted IMU samples with a clipped axis, for the health report.
    imu_clipped: u64,
    /// Whether the previous accepted IMU sample was clipped: one warning per clipping episode,
    /// not one per sample at 400 Hz.
    imu_clipping: bool,
    arrivals: DroppedSamples<Arrivals>,
}

impl Clone for Running {
    fn clone(&self) -> Self {
        let Running { filter, output, last_no_aiding_fusion, held_position_ne_m, aligned_at } = self;
        Running {
            filter: filter.clone(),
            output: output.clone(),
            last_no_aiding_fusion: *last_no_aiding_fusion,
            held_position_ne_m: *held_position_ne_m,
            aligned_at: *aligned_at,
        }
    }

    fn clone_from(&mut self, source: &Self) {
        let Running { filter, output, last_no_aiding_fusion, held_position_ne_m, aligned_at } = source;
        self.filter.clone_from(filter);
        self.output.clone_from(output);
        self.last_no_aiding_fusion = *last_no_aiding_fusion;
        self.held_position_ne_m = *held_position_ne_m;
        self.aligned_at = *aligned_at;
    }
}

impl Clone for Ekf {
    /// A filter with the same buffer capacities, then the copy.
    fn clone(&self) -> Self {
        let mut copy = Ekf::with_valid(self.params.clone());
        copy.clone_from(self);
        copy
    }

    /// Field by field, into the buffers this filter has (the derived one would build a new
    /// filter and drop this one). The pattern names every field, so a new one cannot be missed.
    fn clone_from(&mut self, source: &Self) {
        let Ekf {
            params,
            noise,
            horizon_us,
            alignment,
            running,
            imu_buffer,
            gps_buffer,
            baro_buffer,
            climb_buffer,
            mag_buffer,
            climb_fit,
            gps,
            baro,
            mag,
            drag,
            landed,
            frame,
            newest_imu,
            newest_gyro_rad_s,
            imu_rejected,
            imu_gaps,
            imu_switches,
            warm_starts,
            realignments,
            imu_clipped,
            imu_clipping,
            arrivals,
        } = source;
        self.params.clone_from(params);
        self.noise.clone_from(noise);
        self.horizon_us = *horizon_us;
        self.alignment.clone_from(alignment);
        self.running.clone_from(running);
        self.imu_buffer.clone_from(imu_buffer);
        self.gps_buffer.clone_from(gps_buffer);
        self.baro_buffer.clone_from(baro_buffer);
        self.climb_buffer.clone_from(climb_buffer);
        self.mag_buffer.clone_from(mag_buffer);
        self.climb_fit.clone_from(climb_fit);
        self.gps.clone_from(gps);
        self.baro.clone_from(baro);
        self.mag.clone_from(mag);
        self.drag.clone_from(drag);
        self.landed = *landed;
        self.frame.clone_from(frame);
        self.newest_imu = *newest_imu;
        self.newest_gyro_rad_s = *newest_gyro_rad_s;
        self.imu_rejected = *imu_rejected;
        self.imu_gaps = *imu_gaps;
        self.imu_switches = *imu_switches;
        self.warm_starts = *warm_starts;
        self.realignments = *realignments;
        self.imu_clipped = *imu_clipped;
        self.imu_clipping = *imu_clipping;
        self.arrivals.clone_from(arrivals);
    }
}

/// Per aiding sensor: lagged samples refused on arrival (see [`crate::arrivals`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DroppedSamples<T = u64> {
    pub gps: T,
    pub baro: T,
    pub mag: T,
}

impl Ekf {
    /// A filter waiting for a still vehicle to align.
    pub fn new(params: EkfParams) -> Result<Ekf, ParamError> {
        params.validate()?;
        Ok(Ekf::with_valid(params))
    }

    /// A filter waiting to align, with parameters that have validated.
    fn with_valid(params: EkfParams) -> Ekf {
        let noise = process_noise(&params);
        Ekf {
            horizon_us: (params.fusion_horizon_s() * 1e6).round() as u64,
            noise,
            alignment: Alignment::default(),
            running: None,
            imu_buffer: DelayBuffer::new(HISTORY_CAPACITY),
            gps_buffer: DelayBuffer::new(32),
            baro_buffer: DelayBuffer::new(128),
            climb_buffer: DelayBuffer::new(128),
            mag_buffer: DelayBuffer::new(128),
            climb_fit: ClimbRateFit::default(),
            gps: GpsControl::default(),
            baro: BaroControl::default(),
            mag: MagControl::default(),
            drag: DragControl::default(),
            landed: LandedState::OnGround,
            frame: None,
            newest_imu: None,
            newest_gyro_rad_s: Vector3::zeros(),
            imu_rejected: 0,
            imu_gaps: 0,
            imu_switches: 0,
            warm_starts: 0,
            realignments: 0,
            imu_clipped: 0,
            imu_clipping: false,
            arrivals: DroppedSamples::default(),
            params,
        }
    }

    /// Takes new noises and gates from the next step on (the state and covariance are kept).
    /// Refused, with nothing changed, when `params` do not validate or would change what sizes
    /// the delay buffers (the lags, lag compensation): those need a new filter.
    pub fn retune(&mut self, params: EkfParams) -> Result<(), ParamError> {
        params.validate()?;
        let lags =
            |p: &EkfParams| (p.gps_lag_s, p.baro_lag_s, p.mag_lag_s, p.arrival_margin_s, p.lag_compensation);
        if lags(&params) != lags(&self.params) {
            return Err(ParamError::new("gps_lag_s", "sensor lags cannot change while the filter runs"));
        }
        self.noise = process_noise(&params);
        self.params = params;
        Ok(())
    }

    /// The commander's landed state, for drag fusion.
    pub fn set_landed_state(&mut self, landed: LandedState) {
        self.landed = landed;
    }

    /// The parameters in use.
    pub fn params(&self) -> &EkfParams {
        &self.params
    }

    /// Whether the filter has aligned and is running.
    pub fn is_aligned(&self) -> bool {
        self.running.is_some()
    }

    /// The state at the delayed fusion horizon.
    pub fn delayed_state(&self) -> Option<&State> {
        self.running.as_ref().map(|r| &r.filter.state)
    }

    /// The error-state covariance at the delayed fusion horizon.
    pub fn covariance(&self) -> Option<&Covariance> {
        self.running.as_ref().map(|r| &r.filter.cov)
    }

    /// The pressure altitude of zero height (m above mean sea level), once aligned with a
    /// barometer: the mean over the still window.
    pub fn baro_datum_m(&self) -> Option<f64> {
        self.baro.datum_m()
    }

    /// Lagged samples refused on arrival, per sensor: out of order, behind the delayed fusion
    /// horizon or stamped in the future (see [`crate::arrivals`]).
    pub fn dropped_samples(&self) -> DroppedSamples {
        let a = &self.arrivals;
        DroppedSamples { gps: a.gps.dropped, baro: a.baro.dropped, mag: a.mag.dropped }
    }

    /// The local NED frame, once the first good GPS fix has set it.
    pub fn frame(&self) -> Option<&LocalFrame> {
        self.frame.as_ref()
    }

    /// Takes one IMU sample: predicts the output to its time and moves the delayed horizon.
    pub fn push_imu(&mut self, sample: &ImuSample) -> Result<(), InputError> {
        if let Err(e) = self.check_imu(sample) {
            self.imu_rejected += 1;
            return Err(e);
        }
        self.count_clipping(sample);
        if self.newest_imu.is_some_and(|newest| (sample.time - newest).as_secs_f64() > IMU_GAP_S) {
            self.resume_after_imu_gap(sample.time);
        }
        self.newest_imu = Some(sample.time);
        self.newest_gyro_rad_s = Vector3::from(sample.gyro_rad_s);
        let delta = ImuDelta {
            accel_clipped: sample.accel_clipped.contains(&true),
            ..ImuDelta::from_rates(sample.time, sample.gyro_rad_s, sample.accel_m_s2, sample.dt_s)
        };
        let Some(running) = self.running.as_mut() else {
            if let Some(aligned) = self.alignment.push_imu(sample, &self.params) {
                let state = State::at_rest(aligned.time, aligned.attitude);
                let horizon_s = self.params.fusion_horizon_s();
                let output =
                    OutputPredictor::new(&state, HISTORY_CAPACITY, horizon_s, self.params.output_tau_s);
                if let Some(field) = aligned.mag_earth_ned_gauss {
                    self.mag.set_earth_field(field);
                }
                if let Some(altitude_m) = aligned.baro_altitude_m {
                    self.baro.set_datum(altitude_m);
                }
                let filter = Filter::aligned(state, aligned.mag_earth_ned_gauss.is_some());
                tracing::info!(time = %aligned.time, "estimator aligned");
                self.running = Some(Running {
                    filter,
                    output,
                    last_no_aiding_fusion: None,
                    held_position_ne_m: None,
                    aligned_at: aligned.time,
                });
            }
            return Ok(());
        };
        let f = &running.filter.state;
        running.output.predict(&delta, &f.gyro_bias_rad_s, &f.accel_bias_m_s2);
        self.imu_buffer.push(delta);
        let newest = sample.time.as_micros();
        while let Some(d) = self.imu_buffer.pop_oldest_if(|d| d.time.as_micros() + self.horizon_us <= newest)
        {
            self.step_delayed(&d);
        }
        Ok(())
    }

    /// Takes the first sample of another IMU after the one in use fell silent
    /// ([`crate::imu_selection`]). What the filter learnt of the old IMU's biases is forgotten
    /// (zero, with their initial uncertainty, for GPS velocity to find the new ones), and the
    /// sample's rate and specific force are held over the whole silence since the last sample
    /// (at most [`IMU_GAP_S`]): the switch waits out a timeout, and that time must be predicted
    /// across, not dropped. A longer silence is an IMU gap as for one IMU.
    pub fn push_imu_from_new_source(&mut self, sample: &ImuSample) -> Result<(), InputError> {
        self.check_imu(sample)?;
        self.imu_switches += 1;
        let mut bridged = sample.clone();
        if let Some(newest) = self.newest_imu {
            let silence_s = (sample.time - newest).as_secs_f64();
            if silence_s <= IMU_GAP_S {
                bridged.dt_s = silence_s.clamp(sample.dt_s, MAX_IMU_DT_S);
            }
        }
        if let Some(running) = self.running.as_mut() {
            tracing::warn!(time = %sample.time, switches = self.imu_switches, "IMU in use changed: its biases are learnt again");
            running.filter.forget_imu_biases();
        }
        self.push_imu(&bridged)
    }

    /// Whether this filter can be resumed by a restarted estimator: aligned, with a finite
    /// state and covariance (a filter that failed numerically is not handed on).
    pub fn is_sound(&self) -> bool {
        self.running.as_ref().is_some_and(|r| r.filter.is_finite())
    }

    /// This filter, resuming in a restarted estimator: counted, reported in the status.
    pub fn resumed(mut self) -> Ekf {
        self.warm_starts += 1;
        self
    }

    /// Forgets the estimate and aligns again from samples measured at or after `after`, as a
    /// freshly started filter does: the sensor calibration changed at `after`, and what the
    /// filter learnt before (tilt from the old accelerometer correction, yaw and the Earth field
    /// from the old compass correction, biases and the height datum from both) is wrong by the
    /// change. PX4 resets EKF2's biases and heading when a sensor's calibration count changes
    /// (`EKF2::UpdateImuSample`, `UpdateMagSample`) rather than asking for a reboot as
    /// ArduPilot does. For a vehicle at rest only: the caller keeps it from an armed vehicle.
    /// The counters of rejected and clipped samples are kept; the NED origin is set again by
    /// the first good GPS fix. A change while the filter is still aligning restarts the
    /// alignment from `after`.
    pub fn realign(&mut self, after: Time) {
        let fresh = Ekf::with_valid(self.params.clone());
        let kept = Ekf {
            newest_imu: self.newest_imu,
            imu_rejected: self.imu_rejected,
            imu_gaps: self.imu_gaps,
            imu_switches: self.imu_switches,
            warm_starts: self.warm_starts,
            realignments: self.realignments + u32::from(self.running.is_some()),
            imu_clipped: self.imu_clipped,
            arrivals: self.arrivals,
            alignment: Alignment::from(after),
            ..fresh
        };
        *self = kept;
        tracing::info!(time = %after, realignments = self.realignments, "sensor calibration changed: aligning again");
    }

    /// The IMU stream resumed at `time` after a silence: what was buffered before it is
    /// predicted and fused as usual, then the filter is taken to `time` with the uncertainty of
    /// the gap ([`Filter::resume_after_imu_gap`]), the output predictor restarts from it, and
    /// the next GPS fix resets position and velocity. Until then the position is reported
    /// invalid, which is what makes the commander land. Without this the filter, confident in
    /// the state before the gap, gates out every observation after it and diverges.
    fn resume_after_imu_gap(&mut self, time: Time) {
        while let Some(d) = self.imu_buffer.pop_oldest_if(|_| true) {
            self.step_delayed(&d);
        }
        let Some(running) = self.running.as_mut() else { return };
        self.imu_gaps += 1;
        tracing::warn!(
            time = %time,
            since = %running.filter.state.time,
            gaps = self.imu_gaps,
            "IMU stream resumed after a gap: state uncertainty reset, waiting for GPS to reset position"
        );
        running.filter.resume_after_imu_gap(time);
        // Observations measured during the gap cannot be fused against a state that never was
        // at their time: the oldest GPS fix would reset the position to where the vehicle was
        // seconds ago.
        while self.gps_buffer.pop_oldest_if(|f| f.time < time).is_some() {}
        while self.baro_buffer.pop_oldest_if(|s| s.time < time).is_some() {}
        while self.climb_buffer.pop_oldest_if(|c| c.time < time).is_some() {}
        while self.mag_buffer.pop_oldest_if(|s| s.time < time).is_some() {}
        running.filter.take_reset();
        running.output = OutputPredictor::new(
            &running.filter.state,
            HISTORY_CAPACITY,
            self.params.fusion_horizon_s(),
            self.params.output_tau_s,
        );
        self.gps.force_reset();
    }

    /// Takes a GPS fix stamped with its time of validity.
    pub fn push_gps(&mut self, fix: &GpsFix) -> Result<(), InputError> {
        let finite = [fix.lat_deg, fix.lon_deg, fix.alt_msl_m, fix.h_acc_m, fix.v_acc_m, fix.s_acc_m_s]
            .iter()
            .chain(&fix.vel_ned_m_s)
            .all(|x| x.is_finite());
        if !finite {
            return Err(InputError::NotFinite { sensor: "gps", time: fix.time });
        }
        if let Some(time) = self.admit(|a| &mut a.gps, "gps", fix.time)? {
            self.gps_buffer.push(GpsFix { time, ..fix.clone() });
        }
        Ok(())
    }

    /// Takes a barometer sample stamped with its measurement time.
    pub fn push_baro(&mut self, sample: &BaroSample) -> Result<(), InputError> {
        if !sample.altitude_m.is_finite() {
            return Err(InputError::NotFinite { sensor: "baro", time: sample.time });
        }
        if let Some(time) = self.admit(|a| &mut a.baro, "baro", sample.time)? {
            let sample = BaroSample { time, ..sample.clone() };
            if self.params.fuse_baro_climb_rate
                && let Some(climb) = self.climb_fit.push(&sample)
            {
                self.climb_buffer.push(climb);
            }
            self.baro_buffer.push(sample);
        } else if !self.is_aligned() {
            self.alignment.push_baro(sample, &self.params);
        }
        Ok(())
    }

    /// Takes a magnetometer sample stamped with its measurement time.
    pub fn push_mag(&mut self, sample: &MagSample) -> Result<(), InputError> {
        if !sample.field_gauss.iter().all(|x| x.is_finite()) {
            return Err(InputError::NotFinite { sensor: "mag", time: sample.time });
        }
        if let Some(time) = self.admit(|a| &mut a.mag, "mag", sample.time)? {
            self.mag_buffer.push(MagSample { time, ..sample.clone() });
        } else if !self.is_aligned() {
            self.alignment.push_mag(sample);
        }
        Ok(())
    }

    /// Once aligned: the time a lagged sample measured at `measured` is fused at, or the
    /// refusal (counted in `sensor`'s arrivals) when it cannot be used. `None` before alignment
    /// and for samples measured before it.
    fn admit(
        &mut self,
        sensor: impl FnOnce(&mut DroppedSamples<Arrivals>) -> &mut Arrivals,
        name: &'static str,
        measured: Time,
    ) -> Result<Option<Time>, InputError> {
        let (Some(running), Some(newest_imu)) = (self.running.as_ref(), self.newest_imu) else {
            return Ok(None);
        };
        if measured < running.aligned_at {
            return Ok(None);
        }
        let horizon = self.params.lag_compensation.then_some(running.filter.state.time);
        sensor(&mut self.arrivals).admit(name, measured, horizon, newest_imu)?;
        Ok(Some(self.fusion_time(measured)))
    }

    /// The time an observation is fused at: its own with lag compensation, else its arrival
    /// (the newest IMU time).
    fn fusion_time(&self, measured: Time) -> Time {
        match self.newest_imu {
            Some(newest) if !self.params.lag_compensation => newest,
            _ => measured,
        }
    }

    /// Counts a clipped sample, warning when clipping starts. The sample is still used: a
    /// saturated reading is the best there is, and dropping it would lose the interval; the
    /// prediction over it adds `accel_clip_velocity_noise_m_s` to the velocity's uncertainty
    /// (`step_delayed`).
    fn count_clipping(&mut self, sample: &ImuSample) {
        let clipped = sample.is_clipped();
        if clipped {
            self.imu_clipped += 1;
            if !self.imu_clipping {
                tracing::warn!(
                    time = %sample.time,
                    gyro_axes = ?sample.gyro_clipped,
                    accel_axes = ?sample.accel_clipped,
                    total = self.imu_clipped,
                    "IMU clipping: readings at full scale, the prediction understates the motion"
                );
            }
        }
        self.imu_clipping = clipped;
    }

    fn check_imu(&self, s: &ImuSample) -> Result<(), InputError> {
        if !(s.gyro_rad_s.iter().chain(&s.accel_m_s2).all(|x| x.is_finite())) {
            return Err(InputError::NotFinite { sensor: "imu", time: s.time });
        }
        if !(s.dt_s > 0.0 && s.dt_s <= MAX_IMU_DT_S) {
            return Err(InputError::BadInterval { time: s.time, dt_s: s.dt_s });
        }
        match self.newest_imu {
            Some(newest) if s.time <= newest => {
                Err(InputError::OutOfOrder { sensor: "imu", time: s.time, newest })
            }
            _ => Ok(()),
        }
    }

    /// Predicts the filter over `d`, fuses what was measured by then and corrects the output.
    fn step_delayed(&mut self, d: &ImuDelta) {
        let Some(running) = self.running.as_mut() else { return };
        let filter = &mut running.filter;
        filter.predict(d, &self.noise);
        if d.accel_clipped {
            filter.add_velocity_variance(self.params.accel_clip_velocity_noise_m_s.powi(2));
        }
        let t = filter.state.time;
        let params = &self.params;
        while let Some(fix) = self.gps_buffer.pop_oldest_if(|f| f.time <= t) {
            self.gps.fuse(filter, &fix, &mut self.frame, params, self.baro.height_from_gps());
            if let Some((at, obs)) = self.gps.newest
                && at == t
            {
                self.baro.check_against_gps(filter, &obs, params);
            }
        }
        let gps_available = recent(self.gps.newest.map(|n| n.0), t, GPS_HEIGHT_AVAILABLE_S);
        while let Some(sample) = self.baro_buffer.pop_oldest_if(|s| s.time <= t) {
            self.baro.fuse_height(filter, &sample, params, gps_available);
        }
        while let Some(climb) = self.climb_buffer.pop_oldest_if(|c| c.time <= t) {
            self.baro.fuse_climb_rate(filter, &climb, params);
        }
        while let Some(sample) = self.mag_buffer.pop_oldest_if(|s| s.time <= t) {
            self.mag.fuse(filter, &sample, params);
        }
        let gps_velocity = self.gps.velocity_aiding(t, params);
        self.drag.step(filter, d, params, gps_velocity, self.landed);
        // Without horizontal aiding (no GPS yet, or GPS lost past the position timeout), a
        // synthetic "still here" position is fused, as EKF2's fake position: the origin before
        // the first fix, the position where aiding was lost after it. It keeps velocity and the
        // covariance bounded while the vehicle lands without position.
        let unaided = self.frame.is_none()
            || !self.gps.horizontal_aiding_within(t, params.horizontal_position_timeout_s);
        if !unaided {
            running.held_position_ne_m = None;
        } else if running
            .last_no_aiding_fusion
            .is_none_or(|last| (t - last).as_secs_f64() >= NO_AIDING_INTERVAL_S)
        {
            let held = if self.frame.is_none() {
                [0.0, 0.0]
            } else {
                *running
                    .held_position_ne_m
                    .get_or_insert([filter.state.pos_ned_m.x, filter.state.pos_ned_m.y])
            };
            let r = params.no_aiding_position_noise_m.powi(2);
            for (axis, held_m) in held.iter().enumerate() {
                let y = held_m - filter.state.pos_ned_m[axis];
                filter.fuse(&SparseRow::unit(POS + axis), y, r);
            }
            running.last_no_aiding_fusion = Some(t);
        }
        if let Some(reset) = filter.take_reset() {
            running.output.apply_reset(&reset);
        }
        running.output.correct(&filter.state, d.dt_s);
    }
}

/// The process noise of `params` (white noises and bias random walks).
fn process_noise(params: &EkfParams) -> ProcessNoise {
    ProcessNoise {
        gyro_rad_s: params.gyro_noise_rad_s,
        accel_m_s2: params.accel_noise_m_s2,
        gyro_bias_rad_s2: params.gyro_bias_noise_rad_s2,
        accel_bias_m_s3: params.accel_bias_noise_m_s3,
    }
}
