//! The estimator actor: feeds the [`Ekf`] from its mailbox and publishes what it estimates.
//!
//! Ports: inputs `imu` ([`ImuSample`]) and, on a board with two IMUs, `imu2` (the prediction
//! moves to it when `imu` falls silent: [`crate::imu_selection`]), `gps` ([`GpsFix`]), `baro`
//! ([`BaroSample`]), `mag` ([`MagSample`]) — route them with *queue* mailboxes, every sample
//! matters — `param_set` ([`ParamSet`], queue) and `vehicle_status` ([`VehicleStatus`], latest:
//! a sensor calibration changed on a disarmed vehicle makes the filter align again,
//! [`crate::realign`]); outputs `nav_state` ([`NavState`], one per IMU sample once aligned),
//! `estimator_status` ([`EstimatorStatus`], every 100 ms of IMU time) and `param_decl`
//! ([`ParamDecl`]: the live noises and gates of [`crate::live_params`], at start and after each
//! `param_set` naming one of them). Parameters: [`EkfParams`]. The actor never
//! reads the clock for its estimate (only to stamp the parameter declaration it publishes at
//! start): all timing comes from the samples' own stamps, so it replays exactly.
//!
//! A restarted estimator (after a panic) resumes the filter its predecessor kept every
//! [`KEEP_PERIOD_US`] ([`Keepsake`]) when that filter is sound, instead of aligning again — which
//! needs a still vehicle and so, in flight, would never happen. The IMU samples that arrived
//! while it was down wait in its queue and are predicted through.

use kestrel_proto::messages::{
    BaroSample, EstimatorStatus, GpsFix, ImuSample, MagSample, NavState, ParamDecl, ParamSet, VehicleStatus,
};
use kestrel_proto::param_def::{self, ParamChange};
use kestrel_proto::{Actor, ActorError, Context, Keepsake, Publisher, Setup, Time};

use crate::ekf::Ekf;
use crate::error::InputError;
use crate::imu_selection::{ImuSelection, ImuVerdict};
use crate::live_params;
use crate::params::EkfParams;
use crate::realign::RealignPolicy;

/// Interval of `estimator_status` in IMU time (µs).
const STATUS_PERIOD_US: u64 = 100_000;
/// Interval at which the filter is kept for a restarted successor, in IMU time (µs): what a
/// restart loses is at most this much prediction (an attitude error of rate × interval), and
/// keeping copies the filter this often: 4080 B of `Ekf` and the 14 232 B of entries its
/// buffers held in a simulated flight (18.3 kB; measured in tests/keep_allocation.rs, the
/// entries as the allocations of a whole clone). `Ekf::clone_from` copies them into the kept
/// filter's buffers, 167 488 B of capacity allocated by the first keep only.
pub const KEEP_PERIOD_US: u64 = 20_000;

/// Everything the estimator handles.
#[derive(Clone, Debug)]
pub enum EstimatorInput {
    /// A sample of IMU `.0` (0 for `imu`, 1 for `imu2`).
    Imu(usize, ImuSample),
    Gps(GpsFix),
    Baro(BaroSample),
    Mag(MagSample),
    /// A parameter change from the link (applied when it names one of our noises or gates).
    Param(ParamSet),
    /// The commander's status: whether the vehicle is armed, and in the air.
    Status(VehicleStatus),
}

/// The estimator in the actor graph.
pub struct EstimatorActor {
    ekf: Ekf,
    nav_state: Publisher<NavState>,
    status: Publisher<EstimatorStatus>,
    param_decl: Publisher<ParamDecl>,
    /// Our name in the config: the owner named in `param_decl`.
    name: String,
    last_status: Option<Time>,
    rejected_inputs: u64,
    imus: ImuSelection,
    /// The filter as last kept for a successor, and when (IMU time).
    keepsake: Keepsake<Ekf>,
    last_kept: Option<Time>,
    realign: RealignPolicy,
}

impl EstimatorActor {
    fn handle_sample(&mut self, input: EstimatorInput) -> Result<(), InputError> {
        match input {
            EstimatorInput::Imu(instance, sample) => {
                match self.imus.on_sample(instance, sample.time) {
                    ImuVerdict::Use => self.ekf.push_imu(&sample)?,
                    ImuVerdict::SwitchedTo(_) => self.ekf.push_imu_from_new_source(&sample)?,
                    ImuVerdict::Watch => return Ok(()),
                }
                if self.last_kept.is_none_or(|t| sample.time.as_micros() >= t.as_micros() + KEEP_PERIOD_US)
                    && self.ekf.is_sound()
                    && self.keepsake.keep(&self.ekf)
                {
                    self.last_kept = Some(sample.time);
                }
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
            EstimatorInput::Param(p) => {
                let was_pending = self.realign.pending();
                if let Some(after) = self.realign.on_param(&p.name, p.value, p.time) {
                    self.ekf.realign(after);
                } else if self.realign.pending() && !was_pending {
                    tracing::info!(param = %p.name, "sensor calibration changed on a vehicle not known to be disarmed: aligning again once it is");
                }
                self.on_param(&p);
                Ok(())
            }
            EstimatorInput::Status(status) => {
                self.ekf.set_landed_state(status.landed);
                if let Some(after) = self.realign.on_status(status.armed, status.time) {
                    self.ekf.realign(after);
                }
                Ok(())
            }
        }
    }

    /// Samples refused so far (non-finite, out of order, …): counted and logged, never fatal.
    pub fn rejected_inputs(&self) -> u64 {
        self.rejected_inputs
    }

    /// Applies a `ParamSet` naming one of our noises or gates; applied or refused, the link is
    /// told the values in use (stamped with the change's own time: the actor reads no clock).
    fn on_param(&mut self, p: &ParamSet) {
        let mut params = self.ekf.params().clone();
        let outcome = match live_params::apply(&mut params, &p.name, p.value) {
            Ok(ParamChange::Applied) => {
                self.ekf.retune(params).map(|()| ParamChange::Applied).map_err(|e| e.to_string())
            }
            other => other.map_err(|e| e.to_string()),
        };
        if param_def::answer(&self.name, p, outcome) {
            self.param_decl.publish(live_params::decl(self.ekf.params(), &self.name, false, p.time));
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
        let fresh = Ekf::new(params.clone()).map_err(|e| ActorError::Params(e.to_string()))?;
        let keepsake = setup.keepsake::<Ekf>("filter");
        let ekf = match keepsake.take() {
            Some(kept) if kept.is_sound() => {
                tracing::warn!(
                    actor = setup.name(),
                    "restarted: resuming the filter kept before the failure"
                );
                kept.resumed()
            }
            _ => fresh,
        };
        setup.input("imu", |s| EstimatorInput::Imu(0, s));
        setup.input("imu2", |s| EstimatorInput::Imu(1, s));
        setup.input("gps", EstimatorInput::Gps);
        setup.input("baro", EstimatorInput::Baro);
        setup.input("mag", EstimatorInput::Mag);
        setup.input("param_set", EstimatorInput::Param);
        setup.input("vehicle_status", EstimatorInput::Status);
        Ok(EstimatorActor {
            ekf,
            nav_state: setup.output("nav_state"),
            status: setup.output("estimator_status"),
            param_decl: setup.output("param_decl"),
            name: setup.name().to_owned(),
            last_status: None,
            rejected_inputs: 0,
            imus: ImuSelection::default(),
            keepsake,
            last_kept: None,
            realign: RealignPolicy::default(),
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        self.param_decl.publish(live_params::decl(self.ekf.params(), &self.name, true, ctx.now()));
        Ok(())
    }

    async fn handle(&mut self, ctx: &Context, input: EstimatorInput) -> Result<(), ActorError> {
        if let Err(e) = self.handle_sample(input) {
            self.rejected_inputs += 1;
            tracing::warn!(actor = ctx.name(), rejected = self.rejected_inputs, "{e}");
        }
        Ok(())
    }
}
