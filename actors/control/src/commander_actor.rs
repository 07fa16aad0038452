//! `CommanderActor`: the actor shell of the [`Commander`].
//!
//! Ports — inputs `nav` (NavState, `latest`), `backup_nav` (NavState, `latest`: the controller's
//! backup attitude, flown on while the estimator's state is stale), `battery` (BatteryStatus,
//! `latest`), `manual` (ManualControl, `queue`: the receiver's and ground stations' sticks on one
//! topic, each naming its source), `command` (VehicleCommand, `queue`), `mission` (Mission,
//! `queue`), `fence` (FencePlan, `queue`: the geofence a ground station uploaded; optional),
//! `supervisor` (SupervisorEvent, `queue`), `avoidance` (AvoidanceCommand,
//! `latest`; optional: routed only where the obstacle avoider runs, and from its first command
//! on AUTO/GUIDED legs and POSHOLD's forward sticks blend its correction in and hold when it
//! goes stale); timer `tick` at `tick_rate_hz`;
//! input `param_set` (ParamSet, `queue`); inputs `actuators` (ActuatorOutputs, `latest`) and
//! `esc_telemetry` (EscTelemetry, `latest`; optional: routed only where ESCs report, as the
//! simulator's do) for the motor-failure check; outputs `setpoint` (Setpoint), `status`
//! (VehicleStatus), `command_result` (CommandResult: the answer to each command with an id, at
//! once) and `param_decl` (ParamDecl: the live parameters, at start and after every
//! `param_set` naming one of them, so the link serves the value really in use).
//!
//! The state machine runs on every NavState (so a flip's setpoints follow the vehicle at the
//! estimator's rate) and on the tick when NavStates stop (so a silent estimator is noticed).
//! Setpoints are published when they change and at least at `setpoint_rate_hz`; the status on
//! every change and at least at `status_rate_hz`.

use std::path::PathBuf;
use std::time::Duration;

use kestrel_proto::messages::{
    ActuatorOutputs, AvoidanceCommand, BatteryStatus, CalibrationStatus, Command, CommandResult,
    EscTelemetry, FencePlan, FlightMode, LandedState, ManualControl, Mission, NavState, ParamDecl, ParamSet,
    RallyPoints, RangefinderSample, Setpoint, SpeedCapStatus, SupervisorEvent, VehicleCommand, VehicleStatus,
    VerticalLimitStatus,
};
use kestrel_proto::{Actor, ActorError, Context, Publisher, Setup, Time};
use serde::Deserialize;

use crate::commander::{Commander, CommanderParams};
use crate::plan::load_plan;
use kestrel_proto::param_def;

/// How often `auto` retries arming while the pre-arm checks fail (s).
const AUTO_RETRY_S: f64 = 1.0;

/// `[actors.commander.params]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CommanderActorParams {
    pub commander: CommanderParams,
    /// A QGroundControl `.plan` to load at start, relative to the config file.
    pub mission: Option<PathBuf>,
    /// Arm in AUTO and fly the mission as soon as the pre-arm checks pass (once per run).
    pub auto: bool,
    /// End the whole run once the vehicle has flown and is disarmed on the ground again
    /// (`kestrel run --exit-on-land`).
    pub exit_on_land: bool,
    /// Rate of the `tick` timer (Hz).
    pub tick_rate_hz: f64,
}

impl Default for CommanderActorParams {
    fn default() -> CommanderActorParams {
        CommanderActorParams {
            commander: CommanderParams::default(),
            mission: None,
            auto: false,
            exit_on_land: false,
            tick_rate_hz: 50.0,
        }
    }
}

/// What the commander actor handles.
#[derive(Debug)]
pub enum CommanderInput {
    /// Boxed: a NavState is several times larger than the other inputs.
    Nav(Box<NavState>),
    /// The controller's backup attitude (boxed as `Nav`).
    BackupNav(Box<NavState>),
    Battery(BatteryStatus),
    Manual(ManualControl),
    Command(VehicleCommand),
    Mission(Mission),
    /// The geofence a ground station uploaded (port `fence`).
    Fence(FencePlan),
    /// Rally points uploaded or cleared (port `rally`; optional): where RTL may return.
    Rally(RallyPoints),
    Supervisor(SupervisorEvent),
    /// Boxed: the avoider's command carries its rule activations and shares.
    Avoidance(Box<AvoidanceCommand>),
    /// A parameter changed by the ground station (port `param_set`).
    Param(ParamSet),
    /// Calibrations missing or running (port `calibration`; optional), for the pre-arm check.
    Calibration(CalibrationStatus),
    /// The loop's motor commands (port `actuators`), for the motor check.
    Actuators(ActuatorOutputs),
    /// What the motors produce (port `esc_telemetry`; optional).
    Esc(EscTelemetry),
    /// The up- or downward rangefinder (ports `rangefinder_up`, `rangefinder_down`; optional).
    Rangefinder(RangefinderSample),
    Tick(Time),
}

/// The commander actor.
pub struct CommanderActor {
    commander: Commander,
    setpoint: Publisher<Setpoint>,
    status: Publisher<VehicleStatus>,
    command_result: Publisher<CommandResult>,
    param_decl: Publisher<ParamDecl>,
    /// Our name in the config: the owner named in `param_decl`.
    name: String,
    auto: bool,
    auto_started: bool,
    exit_on_land: bool,
    /// Set once the vehicle has been airborne, for `exit_on_land`.
    flew: bool,
    last_auto_try: Option<Time>,
    last_setpoint: Option<Setpoint>,
    last_status: Option<VehicleStatus>,
    last_step: Option<Time>,
    tick_period: Duration,
}

impl Actor for CommanderActor {
    type Params = CommanderActorParams;
    type Input = CommanderInput;

    fn build(
        params: &CommanderActorParams,
        setup: &mut impl Setup<CommanderInput>,
    ) -> Result<Self, ActorError> {
        let mut commander =
            Commander::new(params.commander.clone()).map_err(|e| ActorError::Params(e.to_string()))?;
        if let Some(path) = &params.mission {
            let path = setup.config_dir().join(path);
            let mission = load_plan(&path).map_err(|e| ActorError::Params(e.to_string()))?;
            // A plan of no items is a mistake here, not a request to clear.
            mission.check_fields().map_err(|e| ActorError::Params(format!("{}: {e}", path.display())))?;
            commander
                .on_mission(mission)
                .map_err(|e| ActorError::Params(format!("{}: {e}", path.display())))?;
        }
        let tick_period =
            kestrel_proto::timing::period_of_rate("tick_rate_hz", params.tick_rate_hz, 1.0, 1000.0)?;
        setup.input("nav", |nav| CommanderInput::Nav(Box::new(nav)));
        setup.input("backup_nav", |nav| CommanderInput::BackupNav(Box::new(nav)));
        setup.input("battery", CommanderInput::Battery);
        setup.input("manual", CommanderInput::Manual);
        setup.input("command", CommanderInput::Command);
        setup.input("mission", CommanderInput::Mission);
        setup.input("fence", CommanderInput::Fence);
        setup.input("rally", CommanderInput::Rally);
        setup.input("supervisor", CommanderInput::Supervisor);
        setup.input("avoidance", |cmd| CommanderInput::Avoidance(Box::new(cmd)));
        setup.input("param_set", CommanderInput::Param);
        setup.input("calibration", CommanderInput::Calibration);
        setup.input("actuators", CommanderInput::Actuators);
        setup.input("esc_telemetry", CommanderInput::Esc);
        setup.input("rangefinder_up", CommanderInput::Rangefinder);
        setup.input("rangefinder_down", CommanderInput::Rangefinder);
        setup.timer("tick", tick_period, CommanderInput::Tick);
        Ok(CommanderActor {
            commander,
            setpoint: setup.output("setpoint"),
            status: setup.output("status"),
            command_result: setup.output("command_result"),
            param_decl: setup.output("param_decl"),
            name: setup.name().to_owned(),
            auto: params.auto,
            auto_started: false,
            exit_on_land: params.exit_on_land,
            flew: false,
            last_auto_try: None,
            last_setpoint: None,
            last_status: None,
            last_step: None,
            tick_period,
        })
    }

    async fn start(&mut self, ctx: &Context) -> Result<(), ActorError> {
        self.param_decl.publish(self.commander.param_decl(&self.name, true, ctx.now()));
        Ok(())
    }

    async fn handle(&mut self, ctx: &Context, input: CommanderInput) -> Result<(), ActorError> {
        match input {
            CommanderInput::Nav(nav) => {
                self.commander.on_nav(&nav);
                self.step(ctx, nav.time);
            }
            CommanderInput::BackupNav(nav) => {
                self.commander.on_backup_nav(&nav);
                if self.commander.on_backup_attitude() {
                    self.step(ctx, nav.time);
                }
            }
            CommanderInput::Tick(time) => {
                if self.last_step.is_none_or(|t| time.saturating_since(t) >= self.tick_period) {
                    self.step(ctx, time);
                }
            }
            CommanderInput::Battery(b) => self.commander.on_battery(&b),
            CommanderInput::Calibration(c) => self.commander.on_calibration(&c),
            CommanderInput::Actuators(a) => self.commander.on_actuators(&a),
            CommanderInput::Esc(e) => {
                let known = self.commander.failed_motor();
                self.commander.on_esc_telemetry(&e);
                // A failure goes to the loop and the status at once, not at the next NavState.
                if self.commander.failed_motor() != known {
                    self.step(ctx, e.time);
                }
            }
            CommanderInput::Manual(m) => self.commander.on_manual(&m),
            CommanderInput::Supervisor(e) => self.commander.on_supervisor(&e),
            CommanderInput::Avoidance(cmd) => self.commander.on_avoidance(&cmd),
            CommanderInput::Rangefinder(sample) => self.commander.on_rangefinder(&sample),
            CommanderInput::Param(p) => {
                // The link already checked the range; a value the commander still refuses is
                // reported and the old one kept, never applied half-way.
                if param_def::answer(ctx.name(), &p, self.commander.on_param(&p.name, p.value)) {
                    self.param_decl.publish(self.commander.param_decl(&self.name, false, ctx.now()));
                }
            }
            CommanderInput::Command(cmd) => {
                // A refusal is answered and shown in the status; it is not an actor failure.
                let result = self.commander.on_command(&cmd);
                if cmd.id != 0 {
                    self.command_result.publish(CommandResult {
                        time: ctx.now(),
                        id: cmd.id,
                        command: cmd.command,
                        refusal: result.err().map(|r| r.0),
                    });
                }
                self.step(ctx, ctx.now());
            }
            CommanderInput::Mission(mission) => {
                let _ = self.commander.on_mission(mission);
                self.step(ctx, ctx.now());
            }
            CommanderInput::Fence(plan) => {
                self.commander.on_fence(plan);
                // FENCE_TOTAL follows the fence.
                self.param_decl.publish(self.commander.param_decl(&self.name, false, ctx.now()));
                self.step(ctx, ctx.now());
            }
            CommanderInput::Rally(rally) => {
                // The link checked every point before it ACKed; a refusal is in the status.
                let _ = self.commander.on_rally(rally);
            }
        }
        Ok(())
    }
}

impl CommanderActor {
    fn step(&mut self, ctx: &Context, now: Time) {
        self.try_auto(now);
        self.last_step = Some(now);
        let sp = self.commander.update(now);
        let p = self.commander.params();
        let due = |last: Option<Time>, rate_hz: f64| {
            last.is_none_or(|t| now.saturating_since(t).as_secs_f64() >= 1.0 / rate_hz)
        };
        let changed = self.last_setpoint.is_none_or(|l| {
            l.target != sp.target || l.armed != sp.armed || l.failed_motor != sp.failed_motor
        });
        if changed || due(self.last_setpoint.map(|s| s.time), p.setpoint_rate_hz) {
            self.setpoint.publish(sp);
            self.last_setpoint = Some(sp);
        }
        let status = self.commander.status(now);
        // The speed cap's figures move with every depth grid: only its reason and whether it
        // limits are a change (the figures go out at the status rate).
        let steady = |s: &VehicleStatus| VehicleStatus {
            time: now,
            speed_cap: s.speed_cap.map(|c| SpeedCapStatus { cap_m_s: 0.0, range_m: 0.0, ..c }),
            vertical_limit: s.vertical_limit.map(|v| VerticalLimitStatus { distance_m: 0.0, ..v }),
            ..s.clone()
        };
        let status_changed = self.last_status.as_ref().is_none_or(|l| steady(l) != steady(&status));
        if status_changed || due(self.last_status.as_ref().map(|s| s.time), p.status_rate_hz) {
            self.status.publish(status.clone());
            self.last_status = Some(status);
        }
        self.flew |= self.commander.landed() != LandedState::OnGround;
        if self.exit_on_land && self.flew && !self.commander.armed() {
            tracing::info!("landed and disarmed: ending the run");
            self.exit_on_land = false;
            ctx.end_run();
        }
    }

    fn try_auto(&mut self, now: Time) {
        if !self.auto
            || self.auto_started
            || self.last_auto_try.is_some_and(|t| now.saturating_since(t).as_secs_f64() < AUTO_RETRY_S)
        {
            return;
        }
        self.last_auto_try = Some(now);
        let command = |command| VehicleCommand { id: 0, time: now, command };
        let result = self
            .commander
            .on_command(&command(Command::SetMode(FlightMode::Auto)))
            .and_then(|()| self.commander.on_command(&command(Command::Arm)));
        match result {
            Ok(()) => {
                tracing::info!("auto: armed, flying the mission");
                self.auto_started = true;
            }
            Err(why) => tracing::info!(%why, "auto: waiting for the pre-arm checks"),
        }
    }
}
