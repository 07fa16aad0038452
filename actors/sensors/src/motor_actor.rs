//! The motor output actor: actuator commands in, PWM pulses out, with a watchdog timer that
//! reports a controller gone quiet while armed (the pulses are held; see
//! [`MotorOutput::watchdog`]).

use std::path::PathBuf;

use kestrel_proto::messages::ActuatorOutputs;
use kestrel_proto::{Actor, ActorError, Context, Setup, Time};
use serde::Deserialize;

use crate::pwm::{MotorOutput, PulseConfig};

/// `[actors.motors.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotorActorParams {
    /// The PWM class directory (a temporary directory in tests).
    pub root: PathBuf,
    /// `pwmchip` number (Navio2 RCIO: 0).
    pub chip: u32,
    /// PWM channel of motor 1, 2, ... in the frame's motor order.
    pub channels: Vec<u32>,
    pub pulses: PulseConfig,
    /// Silence from the controller after which it is reported (s).
    pub timeout_s: f64,
}

impl Default for MotorActorParams {
    fn default() -> MotorActorParams {
        MotorActorParams {
            root: PathBuf::from("/sys/class/pwm"),
            chip: 0,
            channels: vec![0, 1, 2, 3],
            pulses: PulseConfig::default(),
            timeout_s: 0.1,
        }
    }
}

/// What the motor actor handles.
#[derive(Debug)]
pub enum MotorInput {
    /// Port `actuators`.
    Actuators(ActuatorOutputs),
    /// Timer `watchdog`, at a quarter of the timeout.
    Watchdog(Time),
}

/// The motor output actor. No outputs.
pub struct MotorActor {
    motors: MotorOutput,
}

impl Actor for MotorActor {
    type Params = MotorActorParams;
    type Input = MotorInput;

    fn build(
        params: &MotorActorParams,
        setup: &mut impl Setup<MotorInput>,
    ) -> Result<MotorActor, ActorError> {
        let timeout = kestrel_proto::timing::positive_seconds("timeout_s", params.timeout_s, 60.0)?;
        let root = setup.config_dir().join(&params.root);
        let motors = MotorOutput::open(
            &root,
            params.chip,
            &params.channels,
            params.pulses.clone(),
            timeout,
            &mut std::thread::sleep,
        )
        .map_err(|e| ActorError::Failed(e.to_string()))?;
        setup.input("actuators", MotorInput::Actuators);
        setup.timer("watchdog", timeout / 4, MotorInput::Watchdog);
        Ok(MotorActor { motors })
    }

    async fn handle(&mut self, ctx: &Context, input: MotorInput) -> Result<(), ActorError> {
        let result = match input {
            MotorInput::Actuators(outputs) => self.motors.apply(&outputs, ctx.now()),
            MotorInput::Watchdog(now) => {
                if self.motors.watchdog(now) {
                    tracing::warn!(
                        silences = self.motors.silences(),
                        "no actuator commands for the timeout while armed: holding the last pulses"
                    );
                }
                Ok(())
            }
        };
        result.map_err(|e| ActorError::Failed(e.to_string()))
    }

    async fn stop(&mut self, _ctx: &Context) {
        if let Err(e) = self.motors.disarm() {
            tracing::error!("could not disarm the motors: {e}");
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use kestrel_proto::messages::MAX_MOTORS;
    use kestrel_proto::testing::{TestSetup, ready};

    use super::*;
    use crate::pwm::sysfs::tests::FakePwmRoot;

    #[test]
    fn drives_the_motors_and_holds_them_when_the_controller_stops() {
        let fake = FakePwmRoot::new("actor", 0, &[0, 1, 2, 3]);
        let params = MotorActorParams { root: fake.root.clone(), ..MotorActorParams::default() };
        let mut setup = TestSetup::new("motors", "/");
        let mut actor = MotorActor::build(&params, &mut setup).expect("build");
        assert_eq!(setup.timers(), [("watchdog", Duration::from_millis(25))]);
        let ctx = setup.context();
        setup.manual_clock().set(Time::from_micros(1_000_000));
        let armed =
            ActuatorOutputs { time: Time::from_micros(1_000_000), armed: true, motors: [0.25; MAX_MOTORS] };
        ready(actor.handle(&ctx, setup.input("actuators", armed))).expect("apply");
        assert_eq!(fake.read("pwmchip0/pwm2/duty_cycle"), "1250000");
        ready(actor.handle(&ctx, setup.tick("watchdog", Time::from_micros(1_200_000)))).expect("watchdog");
        assert_eq!(fake.read("pwmchip0/pwm2/duty_cycle"), "1250000", "held, not cut");
    }

    #[test]
    fn a_missing_pwm_chip_names_its_path() {
        let fake = FakePwmRoot::new("actor-missing", 0, &[]);
        let params = MotorActorParams { root: fake.root.clone(), chip: 7, ..MotorActorParams::default() };
        let err = MotorActor::build(&params, &mut TestSetup::new("motors", "/")).err().expect("no chip");
        assert!(err.to_string().contains("pwmchip7/export"), "{err}");
    }
}
