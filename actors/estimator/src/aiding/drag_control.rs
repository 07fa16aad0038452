//! Drag, when to fuse (PX4 EKF2's `drag_fusion.cpp` with `EKF2_DRAG_CTRL`; ArduPilot EKF3's
//! dead reckoning on `EK3_DRAG_*`). The maths is [`crate::aiding::drag`]'s.
//!
//! * The accelerometer's specific force, less the filter's bias, is averaged over
//!   [`DRAG_INTERVAL_S`] (the noise of one 400 Hz sample is several times the drag of a
//!   hover in a breeze) and turned into a body x and y air velocity; an interval with a
//!   clipped sample is dropped.
//! * Only in the air: on the ground the contact forces, not drag, hold the vehicle, and drag
//!   fused there would read the wind as the vehicle's own velocity (PX4 fuses drag only while its
//!   land detector says in air). The commander's landed state tells, except at the end of a
//!   landing, which it calls `Landing` until it disarms: then only while the filter still
//!   descends faster than [`LANDING_DESCENT_M_S`] (a touchdown stops the descent; LAND comes
//!   down at 0.6 m/s or more) or is more than [`LANDING_HEIGHT_M`] above the take-off point
//!   (where LAND first stops and levels before it descends). A landing on ground that much
//!   higher than the take-off point, without GPS, fuses drag on the ground until the disarm.
//! * While GPS velocity is fused, each average is a wind observation: the filter's velocity
//!   less the air velocity. The wind is their running mean at first, then a low pass of
//!   [`WIND_TAU_S`] (a breeze changes over tens of seconds, a gust is noise to it).
//! * Without GPS velocity, once the wind has been learnt for [`WIND_LEARN_S`] in the air, the
//!   air velocity is fused against the velocity states with the wind held, gated at
//!   [`DRAG_GATE_SIGMA`]. The velocity stays aided (reported valid) while it fuses: a landing
//!   without GPS holds still against the wind instead of drifting with it.

use kestrel_proto::Time;
use kestrel_proto::messages::{AidingCounters, Innovation, LandedState};
use nalgebra::Vector3;

use crate::aiding::drag::{self, DragModel};
use crate::aiding::{passes, recent};
use crate::filter::Filter;
use crate::params::EkfParams;
use crate::state::ImuDelta;

/// Length of the specific-force average fused or learnt from (s): 40 samples at 400 Hz take
/// the simulated MPU-9250's 0.05 m/s² per sample to 0.008 m/s², 0.08 m/s of airspeed at the
/// quad's 0.1 /s.
pub const DRAG_INTERVAL_S: f64 = 0.1;
/// Time constant of the wind estimate once learnt (s).
pub const WIND_TAU_S: f64 = 10.0;
/// In-air time with GPS velocity that the wind must have been learnt over before drag is fused
/// in its place (s).
pub const WIND_LEARN_S: f64 = 3.0;
/// Innovation gate of the air velocity (standard deviations), as GPS's.
pub const DRAG_GATE_SIGMA: f64 = 5.0;
/// Down velocity above which a landing vehicle is still in the air (m/s): half the commander's
/// slowest landing rate (`land_slow_m_s`, 0.6 m/s).
pub const LANDING_DESCENT_M_S: f64 = 0.3;

/// Height above the take-off point above which a landing vehicle is in the air (m).
pub const LANDING_HEIGHT_M: f64 = 2.0;

/// Whether drag acts on the vehicle: in the air, or landing and still coming down or high up.
/// `down_velocity_m_s` and `down_m` (below the take-off point) are the filter's.
pub fn flying(landed: LandedState, down_velocity_m_s: f64, down_m: f64) -> bool {
    match landed {
        LandedState::InAir => true,
        LandedState::Landing => down_velocity_m_s > LANDING_DESCENT_M_S || -down_m > LANDING_HEIGHT_M,
        LandedState::OnGround => false,
    }
}

/// Drag fusion state.
#[derive(Clone, Debug, Default)]
pub struct DragControl {
    /// Specific force summed over the current interval (m/s, body FRD) and its length (s).
    sum_delta_velocity_m_s: Vector3<f64>,
    sum_dt_s: f64,
    /// An accelerometer axis clipped in the current interval: its average understates the force.
    clipped: bool,
    /// The wind (m/s, north and east) and the in-air time it has been learnt over (s).
    wind_ne_m_s: [f64; 2],
    learnt_s: f64,
    /// When drag was last measured in flight with the wind learnt (fused, or learnt from while
    /// GPS velocity was still fused), and when last fused.
    last_measured: Option<Time>,
    last_fused: Option<Time>,
    pub counters: AidingCounters,
    pub air_velocity: [Innovation; 2],
}

impl DragControl {
    /// Whether drag measures the velocity at `now`: measured in flight with the wind learnt
    /// within `gps_timeout_s`. Measured, not only fused, so that the velocity stays valid across
    /// the handover from GPS (GPS velocity counts until its own timeout, the first drag fusion
    /// comes up to one averaging interval later).
    pub fn velocity_aiding(&self, now: Time, params: &EkfParams) -> bool {
        recent(self.last_measured, now, params.gps_timeout_s)
    }

    /// Whether drag was fused into the filter within `gps_timeout_s` of `now`.
    pub fn fusing(&self, now: Time, params: &EkfParams) -> bool {
        recent(self.last_fused, now, params.gps_timeout_s)
    }

    /// The wind (m/s, north and east) once learnt.
    pub fn wind_ne_m_s(&self) -> Option<[f64; 2]> {
        (self.learnt_s >= WIND_LEARN_S).then_some(self.wind_ne_m_s)
    }

    /// Takes the IMU interval `delta` the filter was just predicted over; at the end of each
    /// averaging interval learns the wind (`gps_velocity`: GPS velocity is being fused) or fuses
    /// the air velocity into `filter`. `landed`: the commander's landed state.
    pub fn step(
        &mut self,
        filter: &mut Filter,
        delta: &ImuDelta,
        params: &EkfParams,
        gps_velocity: bool,
        landed: LandedState,
    ) {
        let model = DragModel {
            linear_per_s: params.drag_linear_per_s,
            quadratic_per_m: params.drag_quadratic_per_m,
        };
        if !model.enabled() {
            return;
        }
        self.sum_delta_velocity_m_s += delta.delta_velocity_m_s;
        self.sum_dt_s += delta.dt_s;
        self.clipped |= delta.accel_clipped;
        if self.sum_dt_s < DRAG_INTERVAL_S {
            return;
        }
        let interval_s = self.sum_dt_s;
        let force = self.sum_delta_velocity_m_s / interval_s - filter.state.accel_bias_m_s2;
        let clipped = std::mem::take(&mut self.clipped);
        self.sum_delta_velocity_m_s = Vector3::zeros();
        self.sum_dt_s = 0.0;
        if landed == LandedState::OnGround {
            // A new flight learns its wind afresh: the last one's may be hours old.
            self.learnt_s = 0.0;
            self.last_measured = None;
        }
        let state = &filter.state;
        if !flying(landed, state.vel_ned_m_s.z, state.pos_ned_m.z) || clipped {
            return;
        }
        let down = drag::predicted_air_velocity(filter, self.wind_ne_m_s).z;
        let measured = model.air_velocity_xy([force.x, force.y], down);
        if gps_velocity {
            let observed = drag::wind_observation(filter, measured, self.wind_ne_m_s);
            self.learnt_s += interval_s;
            let gain = (interval_s / self.learnt_s).max(interval_s / WIND_TAU_S);
            for (wind, seen) in self.wind_ne_m_s.iter_mut().zip(observed) {
                *wind += gain * (seen - *wind);
            }
            if self.learnt_s >= WIND_LEARN_S {
                self.last_measured = Some(filter.state.time);
            }
            return;
        }
        let Some(wind) = self.wind_ne_m_s() else { return };
        let variance = params.drag_velocity_noise_m_s.powi(2);
        self.air_velocity = drag::air_velocity_innovations(filter, measured, wind, variance, DRAG_GATE_SIGMA);
        if !passes(&self.air_velocity) {
            self.counters.rejected += 1;
            return;
        }
        if drag::fuse_air_velocity(filter, measured, wind, variance) {
            self.counters.fused += 1;
            self.last_fused = Some(filter.state.time);
            self.last_measured = self.last_fused;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::Time;
    use nalgebra::UnitQuaternion;

    use crate::state::State;

    fn params() -> EkfParams {
        EkfParams { drag_linear_per_s: 0.1, drag_quadratic_per_m: 0.03, ..EkfParams::default() }
    }

    /// No drag learnt yet, and a level filter at rest.
    fn fresh() -> (DragControl, Filter) {
        (
            DragControl::default(),
            Filter::aligned(State::at_rest(Time::ZERO, UnitQuaternion::identity()), true),
        )
    }

    /// One averaging interval of a level, still vehicle reading `force_xy` (m/s², body x and y).
    fn interval(
        drag: &mut DragControl,
        filter: &mut Filter,
        force_xy: [f64; 2],
        gps: bool,
        landed: LandedState,
    ) {
        let samples = (DRAG_INTERVAL_S * 400.0).round() as usize;
        for _ in 0..samples {
            let delta = ImuDelta::from_rates(
                filter.state.time,
                [0.0; 3],
                [force_xy[0], force_xy[1], -9.81],
                1.0 / 400.0,
            );
            drag.step(filter, &delta, &params(), gps, landed);
        }
    }

    #[test]
    fn the_wind_is_learnt_in_the_air_with_gps_then_drag_is_fused_without_it() {
        let (mut drag, mut filter) = fresh();
        // Still over the ground in a 2 m/s wind towards the east: the air flows past at 2 m/s
        // towards the east, the body moves −2 m/s through it, drag pushes it east.
        let force = params_model().specific_force_xy(&nalgebra::Vector3::new(0.0, -2.0, 0.0));
        interval(&mut drag, &mut filter, force, true, LandedState::OnGround);
        assert_eq!(drag.wind_ne_m_s(), None, "nothing learnt on the ground");
        for _ in 0..29 {
            interval(&mut drag, &mut filter, force, true, LandedState::InAir);
        }
        assert_eq!(drag.wind_ne_m_s(), None, "2.9 s learnt: not yet");
        interval(&mut drag, &mut filter, force, true, LandedState::InAir);
        let wind = drag.wind_ne_m_s().expect("3 s learnt");
        assert!(wind[0].abs() < 1e-6 && (wind[1] - 2.0).abs() < 1e-6, "{wind:?}");
        assert_eq!(drag.counters.fused, 0, "GPS velocity in use: drag only learns");

        interval(&mut drag, &mut filter, force, false, LandedState::InAir);
        assert_eq!(drag.counters.fused, 1);
        assert!(drag.velocity_aiding(filter.state.time, &params()));
        // Landing: fused high up or while coming down, not once the descent has stopped near
        // the take-off point's height (ground contact).
        filter.state.pos_ned_m.z = -10.0;
        interval(&mut drag, &mut filter, force, false, LandedState::Landing);
        assert_eq!(drag.counters.fused, 2, "levelling off before the descent");
        filter.state.pos_ned_m.z = -1.0;
        filter.state.vel_ned_m_s.z = 0.6;
        interval(&mut drag, &mut filter, force, false, LandedState::Landing);
        assert_eq!(drag.counters.fused, 3, "coming down");
        filter.state.vel_ned_m_s.z = 0.05;
        interval(&mut drag, &mut filter, force, false, LandedState::Landing);
        assert_eq!(drag.counters.fused, 3, "touched down: the contact, not drag, holds it");
    }

    #[test]
    fn on_the_ground_the_wind_is_forgotten_for_the_next_flight_to_learn() {
        let (mut drag, mut filter) = fresh();
        let force = params_model().specific_force_xy(&nalgebra::Vector3::new(0.0, -2.0, 0.0));
        for _ in 0..40 {
            interval(&mut drag, &mut filter, force, true, LandedState::InAir);
        }
        assert!(drag.wind_ne_m_s().is_some() && drag.velocity_aiding(filter.state.time, &params()));
        interval(&mut drag, &mut filter, [0.0, 0.0], true, LandedState::OnGround);
        assert_eq!(drag.wind_ne_m_s(), None);
        assert!(!drag.velocity_aiding(filter.state.time, &params()));
        interval(&mut drag, &mut filter, force, false, LandedState::InAir);
        assert_eq!(drag.counters.fused, 0, "nothing fused against a forgotten wind");
    }

    #[test]
    fn an_interval_with_a_clipped_sample_teaches_nothing() {
        let (mut drag, mut filter) = fresh();
        let samples = (DRAG_INTERVAL_S * 400.0).round() as usize;
        for i in 0..samples * 40 {
            let delta = ImuDelta {
                accel_clipped: i % samples == 7,
                ..ImuDelta::from_rates(filter.state.time, [0.0; 3], [0.2, 0.0, -9.81], 1.0 / 400.0)
            };
            drag.step(&mut filter, &delta, &params(), true, LandedState::InAir);
        }
        assert_eq!(drag.wind_ne_m_s(), None, "every interval held a clipped sample");
    }

    #[test]
    fn without_a_model_nothing_is_learnt_or_fused() {
        let (mut drag, mut filter) = fresh();
        let off = EkfParams::default();
        for _ in 0..200 {
            let delta = ImuDelta::from_rates(filter.state.time, [0.0; 3], [0.2, 0.0, -9.81], 1.0 / 400.0);
            drag.step(&mut filter, &delta, &off, true, LandedState::InAir);
        }
        assert_eq!((drag.wind_ne_m_s(), drag.counters.fused), (None, 0));
    }

    fn params_model() -> DragModel {
        let p = params();
        DragModel { linear_per_s: p.drag_linear_per_s, quadratic_per_m: p.drag_quadratic_per_m }
    }
}
