//! The estimator actor: feeds the [`Ekf`] from its mailbox and publishes what it estimates.
//!
//! Ports: inputs `imu` ([`ImuSample`]), `gps` ([`GpsFix`]), `baro` ([`BaroSample`]), `mag`
//! ([`MagSample`]) — route them with *queue* mailboxes, every sample matters; outputs
//! `nav_state` ([`NavState`], one per IMU sample once aligned) and `estimator_status`
//! ([`EstimatorStatus`], every 100 ms of IMU time). Parameters: [`EkfParams`]. The actor never
//! reads the clock: all timing comes from the samples' own stamps, so it replays exactly.

use kestrel_proto::messages::{BaroSample, EstimatorStatus, GpsFix, ImuSample, MagSample, NavState};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};

use crate::ekf::Ekf;
use crate::error::InputError;
use crate::params::EkfParams;

/// Interval of `estimator_status` in IMU time (µs).
const STATUS_PERIOD_US: u64 = 100_000;

/// Everything the estimator handles.
#[derive(Clone, Debug)]
pub enum EstimatorInput {
    Imu(ImuSample),
    Gps(GpsFix),
    Baro(BaroSample),
    Mag(MagSample),
}

/// The estimator in the actor graph.
pub struct EstimatorActor {
    ekf: Ekf,
    nav_state: Publisher<NavState>,
    status: Publisher<EstimatorStatus>,
    last_status: Option<Time>,
    rejected_inputs: u64,
}

impl EstimatorActor {
    fn handle_sample(&mut self, input: EstimatorInput) -> Result<(), InputError> {
        match input {
            EstimatorInput::Imu(sample) => {
                self.ekf.push_imu(&sample)?;
                if let Some(nav) = self.ekf.nav_state() {
                    self.nav_state.publish(nav);
                }
                if self
                    .last_status
                    .is_none_or(|t| sample.time.as_micros() >= t.as_micros() + STATUS_PERIOD_US)
                {
                    self.last_status = Some(sample.time);
                    self.status.publish(self.ekf.status());
                }
                Ok(())
            }
            EstimatorInput::Gps(fix) => self.ekf.push_gps(&fix),
            EstimatorInput::Baro(sample) => self.ekf.push_baro(&sample),
            EstimatorInput::Mag(sample) => self.ekf.push_mag(&sample),
        }
    }
}

impl Actor for EstimatorActor {
    type Params = EkfParams;
    type Input = EstimatorInput;

    fn build(
        params: &EkfParams,
        setup: &mut impl Setup<EstimatorInput>,
    ) -> Result<EstimatorActor, ActorError> {
        let ekf = Ekf::new(params.clone()).map_err(|e| ActorError::Params(e.to_string()))?;
        setup.input("imu", EstimatorInput::Imu);
        setup.input("gps", EstimatorInput::Gps);
        setup.input("baro", EstimatorInput::Baro);
        setup.input("mag", EstimatorInput::Mag);
        Ok(EstimatorActor {
            ekf,
            nav_state: setup.output("nav_state"),
            status: setup.output("estimator_status"),
            last_status: None,
            rejected_inputs: 0,
        })
    }

    async fn handle(&mut self, ctx: &Context, input: EstimatorInput) -> Result<(), ActorError> {
        if let Err(e) = self.handle_sample(input) {
            self.rejected_inputs += 1;
            tracing::warn!(actor = ctx.name(), rejected = self.rejected_inputs, "{e}");
        }
        Ok(())
    }
}
