//! Closed-loop harness: the `kestrel-sim` core stepped synchronously at 400 Hz with the
//! control cores in the loop.
//!
//! The estimator is not in this loop: it was being written in parallel when these tests were,
//! and keeping it out makes them measure the controllers alone. The NavState the controller
//! sees is the simulator's *true* state at each tick (a test adapter, `truth_nav`), so sensor
//! noise, lag and estimator error are out of the loop here; whole-graph runs with the EKF are
//! the runtime's integration tests.

#![allow(dead_code)]

use kestrel_control::{ControlParams, FlightController};
use kestrel_proto::Time;
use kestrel_proto::messages::{
    ActuatorOutputs, MAX_MOTORS, NavState, Setpoint, SetpointTarget, TrajectorySetpoint,
};
use kestrel_sim::{
    InitialState, RigidBodyState, SimOptions, Simulator, VehicleParams, World, hover_throttle,
};
use nalgebra::{UnitQuaternion, Vector3};

/// The shipped quad-X vehicle file.
pub fn quad_x() -> VehicleParams {
    let file = format!("{}/../../config/vehicles/quad_x.toml", env!("CARGO_MANIFEST_DIR"));
    VehicleParams::load(file.as_ref()).expect("shipped vehicle loads")
}

/// The controller's view of a simulator vehicle file.
pub fn airframe_of(vehicle: &VehicleParams) -> kestrel_control::AirframeParams {
    let m = &vehicle.motor;
    kestrel_control::AirframeParams {
        mass_kg: vehicle.mass_kg,
        inertia_frd_kg_m2: vehicle.inertia_frd_kg_m2,
        arm_length_m: vehicle.arm_length_m,
        frame: vehicle.frame,
        max_thrust_per_motor_n: m.max_thrust_n(),
        torque_to_thrust_m: m.torque_coefficient_n_m_per_rad2_s2 / m.thrust_coefficient_n_per_rad2_s2,
    }
}

/// A shipped vehicle file by name (`quad_x`, `hexa_x`, `octo_x`).
pub fn vehicle(name: &str) -> VehicleParams {
    let file = format!("{}/../../config/vehicles/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    VehicleParams::load(file.as_ref()).expect("shipped vehicle loads")
}

/// The NavState a perfect estimator would publish: the simulator's true state (test adapter).
pub fn truth_nav(sim: &Simulator) -> NavState {
    let s = sim.state();
    let q = s.attitude.into_inner();
    NavState::exact(
        sim.time(),
        [q.w, q.i, q.j, q.k],
        s.angular_velocity_frd_rad_s.into(),
        s.velocity_ned_m_s.into(),
        s.position_ned_m.into(),
    )
}

/// The simulator and the controller, stepped together.
pub struct Loop {
    pub sim: Simulator,
    pub ctl: FlightController,
    /// The failed motor the setpoints of [`Loop::fly`] name (what the commander would say).
    pub failed_motor: Option<u8>,
}

impl Loop {
    /// Vehicle at `position` with `attitude`, motors settled at hover (or stopped on the ground).
    pub fn new(world: World, position: [f64; 3], attitude: UnitQuaternion<f64>) -> Loop {
        Loop::with_vehicle(quad_x(), world, position, attitude)
    }

    /// As [`Loop::new`] for any vehicle file, with the controller's airframe taken from it.
    pub fn with_vehicle(
        vehicle: VehicleParams,
        world: World,
        position: [f64; 3],
        attitude: UnitQuaternion<f64>,
    ) -> Loop {
        let hover = hover_throttle(&vehicle);
        let airborne = position[2] < 0.0;
        let mut motors = [0.0; MAX_MOTORS];
        motors[..vehicle.frame.motor_count()].fill(hover);
        let options = SimOptions {
            initial: InitialState {
                body: RigidBodyState {
                    position_ned_m: position.into(),
                    attitude,
                    ..RigidBodyState::default()
                },
                actuators: ActuatorOutputs { time: Time::ZERO, armed: airborne, motors },
            },
            ..SimOptions::default()
        };
        let params = ControlParams { airframe: airframe_of(&vehicle), ..ControlParams::default() };
        let sim = Simulator::new(vehicle, world, options).expect("valid simulator");
        let ctl = FlightController::new(params).expect("valid params");
        Loop { sim, ctl, failed_motor: None }
    }

    /// One 400 Hz iteration: truth → controller → motors → physics.
    pub fn step(&mut self) -> ActuatorOutputs {
        let nav = truth_nav(&self.sim);
        let out = self.ctl.update(&nav);
        self.sim.set_actuators(&out);
        self.sim.step();
        self.sim.drain().for_each(drop);
        out
    }

    /// Holds `target` for `seconds`, calling `watch` after every step.
    pub fn fly(&mut self, target: SetpointTarget, seconds: f64, mut watch: impl FnMut(&Simulator)) {
        let steps = (seconds * 400.0).round() as usize;
        for _ in 0..steps {
            let failed_motor = self.failed_motor;
            let sp = Setpoint { time: self.sim.time(), armed: true, target, landing: false, failed_motor };
            self.ctl.set_setpoint(&sp).expect("valid setpoint");
            self.step();
            watch(&self.sim);
        }
    }

    pub fn position(&self) -> Vector3<f64> {
        self.sim.state().position_ned_m
    }

    /// Angle between the body's thrust axis and vertical (rad).
    pub fn tilt(&self) -> f64 {
        (self.sim.state().attitude * Vector3::z()).angle(&Vector3::z())
    }
}

/// Hold this NED position with heading `yaw_rad`.
pub fn hold(position: [f64; 3], yaw_rad: f64) -> SetpointTarget {
    SetpointTarget::Trajectory(TrajectorySetpoint {
        position_ned_m: position.map(Some),
        yaw_rad: Some(yaw_rad),
        ..TrajectorySetpoint::default()
    })
}

/// The simulator, the commander and the controller, stepped together at 400 Hz; the commander
/// runs on every NavState, as the lockstep actor does.
pub struct Flight {
    pub l: Loop,
    pub commander: kestrel_control::Commander,
    /// Battery reports are replaced by this share when set (to provoke battery failsafes).
    pub battery_override: Option<f64>,
    /// NavStates are withheld from the commander and controller while true.
    pub nav_blackout: bool,
    /// Edits every NavState before it is delivered (to provoke estimator failsafes).
    pub nav_edit: fn(&mut NavState),
    /// Sticks sent on every step, as a radio does; `None` sends none.
    pub sticks: Option<kestrel_proto::messages::ManualControl>,
    /// A ground station's MANUAL_CONTROL sent on every 40th step (10 Hz, as QGroundControl's
    /// virtual joystick), with its own `source`; `None` sends none.
    pub gcs_sticks: Option<kestrel_proto::messages::ManualControl>,
    steps: u64,
}

impl Flight {
    pub fn new(params: kestrel_control::CommanderParams) -> Flight {
        let mut l = Loop::new(World::default(), [0.0, 0.0, 0.0], UnitQuaternion::identity());
        l.step();
        let commander = kestrel_control::Commander::new(params).expect("valid commander params");
        let mut f = Flight {
            l,
            commander,
            battery_override: None,
            nav_blackout: false,
            nav_edit: |_| {},
            sticks: None,
            gcs_sticks: None,
            steps: 0,
        };
        f.run(0.2);
        f
    }

    pub fn now(&self) -> Time {
        self.l.sim.time()
    }

    pub fn command(
        &mut self,
        command: kestrel_proto::messages::Command,
    ) -> Result<(), kestrel_control::Refusal> {
        let cmd = kestrel_proto::messages::VehicleCommand { id: 0, time: self.now(), command };
        self.commander.on_command(&cmd)
    }

    /// One 400 Hz step of the whole stack.
    pub fn step(&mut self) {
        let mut nav = truth_nav(&self.l.sim);
        nav.origin = Some(self.l.sim.world().home.geodetic());
        (self.nav_edit)(&mut nav);
        if let Some(sticks) = self.sticks {
            self.commander.on_manual(&kestrel_proto::messages::ManualControl { time: self.now(), ..sticks });
        }
        if let Some(sticks) = self.gcs_sticks.filter(|_| self.steps.is_multiple_of(40)) {
            self.commander.on_manual(&kestrel_proto::messages::ManualControl { time: self.now(), ..sticks });
        }
        self.steps += 1;
        if !self.nav_blackout {
            self.commander.on_nav(&nav);
        }
        let sp = self.commander.update(self.now());
        self.l.ctl.set_setpoint(&sp).expect("commander setpoints are valid");
        let out = if self.nav_blackout { self.l.ctl.fly_blind(self.now()) } else { self.l.ctl.update(&nav) };
        self.l.sim.set_actuators(&out);
        self.l.sim.step();
        let outputs: Vec<_> = self.l.sim.drain().collect();
        for o in outputs {
            if let kestrel_sim::SimOutput::Battery(mut b) = o {
                if let Some(r) = self.battery_override {
                    b.remaining = r;
                }
                self.commander.on_battery(&b);
            }
        }
    }

    pub fn run(&mut self, seconds: f64) {
        for _ in 0..(seconds * 400.0).round() as usize {
            self.step();
        }
    }

    /// Steps until `done` or `seconds` pass; returns whether `done` happened.
    pub fn run_until(&mut self, seconds: f64, mut done: impl FnMut(&Flight) -> bool) -> bool {
        for _ in 0..(seconds * 400.0).round() as usize {
            self.step();
            if done(self) {
                return true;
            }
        }
        false
    }

    /// Height above the ground (m).
    pub fn height(&self) -> f64 {
        -self.l.position().z
    }
}
