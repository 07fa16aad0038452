//! `PilotScriptActor`: a pilot on a timetable. It plays a list of steps, each at a set time
//! after the actor started: stick positions, which it then sends at `rate_hz` as an RC
//! receiver would, and commands, each sent once as a ground station would.
//!
//! On the lockstep clock the sticks arrive at exactly the same simulated times in every run,
//! which MAVLink `MANUAL_CONTROL` from outside the graph cannot promise (the graph does not
//! wait for a socket): closed-loop tests of the pilot's modes use it (tests/flight_poshold_avoidance.rs
//! flies POSHOLD at a wall), and so can a bench without a radio. The sticks are a receiver's
//! (`StickSource::Radio`): they win over a ground station's MAVLink sticks, stopping them is
//! the RC-loss failsafe, and they do not hold off the ground station's (commander
//! `pilot_input`).
//!
//! Ports — outputs `manual` (ManualControl, from the first step on) and `command`
//! (VehicleCommand); timer `tick` at `rate_hz`.
//!
//! ```toml
//! [actors.pilot]
//! type = "pilot_script"
//! outputs.manual = "manual_control"
//! outputs.command = "vehicle_command"
//! params.steps = [
//!     { at_s = 10.0, throttle = 0.5, command = { set_mode = "pos_hold" } },
//!     { at_s = 12.0, pitch = 1.0 },       # full forward
//!     { at_s = 20.0, pitch = 0.0 },       # let go: hold
//! ]
//! ```

use kestrel_proto::messages::{Command, ManualControl, VehicleCommand};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;

/// One step of the script. A stick left out keeps its position.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PilotStep {
    /// When, after the actor started (s).
    pub at_s: f64,
    /// Right stick left/right, -1..1 (right positive).
    pub roll: Option<f64>,
    /// Right stick forward/back, -1..1 (forward positive).
    pub pitch: Option<f64>,
    /// Left stick left/right, -1..1 (clockwise positive).
    pub yaw: Option<f64>,
    /// Left stick up/down, 0..1.
    pub throttle: Option<f64>,
    /// A command sent once at `at_s`, after the sticks (snake case, as in `Command`:
    /// `"arm"`, `{ set_mode = "pos_hold" }`, `{ takeoff = { altitude_m = 6.0 } }`).
    pub command: Option<Command>,
}

/// `[actors.NAME.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PilotScriptParams {
    /// How often the sticks are sent (Hz); an RC receiver sends at 50 Hz or more.
    pub rate_hz: f64,
    /// The steps, in time order. Before the first one the sticks are centred with the
    /// throttle down, as a transmitter at power-up, and nothing is sent.
    pub steps: Vec<PilotStep>,
}

impl Default for PilotScriptParams {
    fn default() -> PilotScriptParams {
        PilotScriptParams { rate_hz: 50.0, steps: Vec::new() }
    }
}

impl PilotScriptParams {
    /// Rate within 1..=1000 Hz, steps at finite non-negative times in order, sticks in range.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.rate_hz.is_finite() && (1.0..=1000.0).contains(&self.rate_hz)) {
            return Err(format!("rate_hz {} not within 1..=1000", self.rate_hz));
        }
        let mut last = 0.0;
        for (i, step) in self.steps.iter().enumerate() {
            if !(step.at_s.is_finite() && step.at_s >= last) {
                return Err(format!("step {i}: at_s {} is not a time at or after {last} s", step.at_s));
            }
            last = step.at_s;
            let sticks = [(step.roll, -1.0), (step.pitch, -1.0), (step.yaw, -1.0), (step.throttle, 0.0)];
            if let Some((v, lo)) = sticks.iter().find(|(v, lo)| v.is_some_and(|v| !(*lo..=1.0).contains(&v)))
            {
                return Err(format!("step {i}: stick {v:?} not within {lo}..=1"));
            }
        }
        Ok(())
    }
}

/// What the script handles.
#[derive(Debug)]
pub enum PilotScriptInput {
    Tick(Time),
}

/// The scripted pilot.
pub struct PilotScriptActor {
    steps: Vec<PilotStep>,
    /// Index of the next step to play.
    next: usize,
    /// The sticks now, once the first step has played.
    sticks: Option<ManualControl>,
    started: Time,
    manual: Publisher<ManualControl>,
    command: Publisher<VehicleCommand>,
}

impl Actor for PilotScriptActor {
    type Params = PilotScriptParams;
    type Input = PilotScriptInput;

    fn build(
        params: &PilotScriptParams,
        setup: &mut impl Setup<PilotScriptInput>,
    ) -> Result<Self, ActorError> {
        params.validate().map_err(ActorError::Params)?;
        let tick = kestrel_proto::timing::period_of_rate("rate_hz", params.rate_hz, 1.0, 1000.0)?;
        setup.timer("tick", tick, PilotScriptInput::Tick);
        Ok(PilotScriptActor {
            steps: params.steps.clone(),
            next: 0,
            sticks: None,
            started: Time::ZERO,
            manual: setup.output("manual"),
            command: setup.output("command"),
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        self.started = ctx.now();
        Ok(())
    }

    async fn handle(&mut self, _ctx: &Context, input: PilotScriptInput) -> Result<(), ActorError> {
        let PilotScriptInput::Tick(now) = input;
        let elapsed_s = now.saturating_since(self.started).as_secs_f64();
        while let Some(step) = self.steps.get(self.next).filter(|s| s.at_s <= elapsed_s) {
            let s = self.sticks.get_or_insert(ManualControl::default());
            s.roll = step.roll.unwrap_or(s.roll);
            s.pitch = step.pitch.unwrap_or(s.pitch);
            s.yaw = step.yaw.unwrap_or(s.yaw);
            s.throttle = step.throttle.unwrap_or(s.throttle);
            if let Some(command) = step.command {
                tracing::info!(at_s = step.at_s, ?command, "pilot script");
                self.command.publish(VehicleCommand { id: 0, time: now, command });
            }
            self.next += 1;
        }
        if let Some(sticks) = &self.sticks {
            self.manual.publish(ManualControl { time: now, ..*sticks });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use kestrel_proto::messages::FlightMode;

    fn parse(json: &str) -> PilotScriptParams {
        serde_json::from_str(json).expect("params")
    }

    #[test]
    fn steps_parse_with_commands_and_partial_sticks() {
        let p = parse(
            r#"{ "steps": [
                { "at_s": 1.0, "throttle": 0.5, "command": { "set_mode": "pos_hold" } },
                { "at_s": 2.0, "command": "arm" },
                { "at_s": 3.0, "pitch": 1.0, "command": { "takeoff": { "altitude_m": 6.0 } } }
            ] }"#,
        );
        assert_eq!(p.validate(), Ok(()));
        assert_eq!(p.rate_hz, 50.0);
        assert_eq!(p.steps[0].command, Some(Command::SetMode(FlightMode::PosHold)));
        assert_eq!(p.steps[1].command, Some(Command::Arm));
        assert_eq!((p.steps[2].pitch, p.steps[2].roll), (Some(1.0), None));
        assert!(
            serde_json::from_str::<PilotScriptParams>(r#"{ "steps": [{ "at_s": 1, "bogus": 1 }] }"#).is_err()
        );
    }

    #[test]
    fn bad_scripts_are_refused_with_a_reason() {
        let step = |at_s, pitch, throttle| PilotStep { at_s, pitch, throttle, ..PilotStep::default() };
        let script = |steps| PilotScriptParams { steps, ..PilotScriptParams::default() };
        let cases = [
            (PilotScriptParams { rate_hz: 0.0, ..PilotScriptParams::default() }, "rate_hz"),
            (script(vec![step(2.0, None, None), step(1.0, None, None)]), "step 1"),
            (script(vec![step(f64::NAN, None, None)]), "step 0"),
            (script(vec![step(1.0, Some(1.5), None)]), "-1..=1"),
            (script(vec![step(1.0, None, Some(-0.1))]), "0..=1"),
        ];
        for (params, why) in cases {
            let err = params.validate().expect_err(why);
            assert!(err.contains(why), "{params:?}: {err}");
        }
    }

    #[test]
    fn steps_play_on_time_and_the_sticks_are_sent_every_tick_from_the_first_one() {
        use kestrel_proto::testing::{TestSetup, ready};
        let params = parse(
            r#"{ "rate_hz": 10, "steps": [
                { "at_s": 0.2, "throttle": 0.5, "command": { "set_mode": "pos_hold" } },
                { "at_s": 0.35, "pitch": 1.0 }
            ] }"#,
        );
        let mut setup = TestSetup::new("pilot", ".");
        let mut actor = PilotScriptActor::build(&params, &mut setup).expect("build");
        assert_eq!(setup.timers(), vec![("tick", Duration::from_millis(100))]);
        let ctx = setup.context();
        ready(actor.start(&ctx)).expect("start");
        for ms in (100..=500).step_by(100) {
            ready(actor.handle(&ctx, setup.tick("tick", Time::from_micros(ms * 1000)))).expect("tick");
        }
        let sticks: Vec<ManualControl> = setup.published("manual");
        let at = |ms: u64| Time::from_micros(ms * 1000);
        let expected =
            |ms, pitch| ManualControl { time: at(ms), pitch, throttle: 0.5, ..ManualControl::default() };
        assert_eq!(
            sticks,
            vec![expected(200, 0.0), expected(300, 0.0), expected(400, 1.0), expected(500, 1.0)]
        );
        let commands: Vec<VehicleCommand> = setup.published("command");
        assert_eq!(
            commands,
            vec![VehicleCommand { id: 0, time: at(200), command: Command::SetMode(FlightMode::PosHold) }]
        );
    }
}
