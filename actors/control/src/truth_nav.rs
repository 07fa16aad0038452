//! `TruthNavActor`: a stand-in for the estimator that republishes the simulator's ground truth
//! as a perfect `NavState`, so the control stack can fly whole simulated graphs before (or
//! without) the EKF. Bench use only: it hides every sensor and estimator error, and it says so
//! in the log at start. Route the simulator's `ground_truth` at the IMU rate (the sim actor's
//! `ground_truth_rate_hz = 400`) so the loop runs at 400 Hz.
//!
//! Ports — input `ground_truth` (GroundTruth, `latest`); output `nav` (NavState).

use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{GroundTruth, NavState};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup};
use serde::Deserialize;

/// `[actors.NAME.params]` (none yet; the table may be left out).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TruthNavParams {}

/// What the adapter handles.
#[derive(Debug)]
pub enum TruthNavInput {
    /// Boxed: large, and this is a bench adapter, not the real-time path.
    GroundTruth(Box<GroundTruth>),
}

/// Ground truth → NavState.
pub struct TruthNavActor {
    nav: Publisher<NavState>,
    origin: Option<Geodetic>,
}

/// A perfect NavState from ground truth; `origin` is the NED frame's anchor (home).
pub fn nav_from_truth(truth: &GroundTruth, origin: Geodetic) -> NavState {
    NavState {
        origin: Some(origin),
        ..NavState::exact(
            truth.time,
            truth.attitude,
            truth.angular_velocity_rad_s,
            truth.velocity_ned_m_s,
            truth.position_ned_m,
        )
    }
}

/// Home, from a ground-truth sample: the point whose local frame puts the vehicle at
/// `position_ned_m`. Starts from the point that far back in the vehicle's own tangent frame
/// (off by about d²/2R) and corrects the residual twice, which makes it exact to well under a
/// millimetre within several kilometres.
pub fn home_of(truth: &GroundTruth) -> Geodetic {
    let here = Geodetic { lat_deg: truth.lat_deg, lon_deg: truth.lon_deg, alt_m: truth.alt_msl_m };
    let mut home = LocalFrame::new(here).to_geodetic(truth.position_ned_m.map(|v| -v));
    for _ in 0..2 {
        let frame = LocalFrame::new(home);
        let seen = frame.to_ned(here);
        let residual = [0, 1, 2].map(|i| seen[i] - truth.position_ned_m[i]);
        home = frame.to_geodetic(residual);
    }
    home
}

impl Actor for TruthNavActor {
    type Params = TruthNavParams;
    type Input = TruthNavInput;

    fn build(_params: &TruthNavParams, setup: &mut impl Setup<TruthNavInput>) -> Result<Self, ActorError> {
        setup.input("ground_truth", |t| TruthNavInput::GroundTruth(Box::new(t)));
        Ok(TruthNavActor { nav: setup.output("nav"), origin: None })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        tracing::warn!(
            actor = ctx.name(),
            "NavState is the simulator's ground truth: no estimator in the loop"
        );
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: TruthNavInput) -> Result<(), ActorError> {
        let TruthNavInput::GroundTruth(truth) = input;
        let origin = *self.origin.get_or_insert_with(|| home_of(&truth));
        self.nav.publish(nav_from_truth(&truth, origin));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::Time;

    #[test]
    fn home_is_recovered_from_a_displaced_sample() {
        let home = Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 };
        let ned = [300.0, -200.0, -50.0];
        let at = LocalFrame::new(home).to_geodetic(ned);
        let truth = GroundTruth {
            time: Time::ZERO,
            position_ned_m: ned,
            velocity_ned_m_s: [0.0; 3],
            acceleration_ned_m_s2: [0.0; 3],
            attitude: [1.0, 0.0, 0.0, 0.0],
            angular_velocity_rad_s: [0.0; 3],
            lat_deg: at.lat_deg,
            lon_deg: at.lon_deg,
            alt_msl_m: at.alt_m,
            landed: false,
            crashed: false,
            collisions: 0,
            clearance_m: None,
        };
        let back = LocalFrame::new(home).to_ned(home_of(&truth));
        assert!(back.iter().all(|v| v.abs() < 1e-3), "{back:?}");
    }
}
