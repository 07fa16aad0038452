//! A compass calibration applied while the vehicle stands disarmed makes the estimator align
//! again from the corrected samples, so the vehicle flies on it without a restart; applied to
//! an armed vehicle, the estimate is kept until the disarm.
//!
//! The simulated board reads a hard-iron field of (0.15, −0.1, 0.2) G. The test applies the
//! matching correction to the samples from the moment it sends the COMPASS_OFS_* changes, as
//! the sensor path (the simulator's, a driver's) does, and reads the yaw error against the
//! simulator's ground truth.

use kestrel_estimator::{EkfParams, EstimatorActor, EstimatorInput};
use kestrel_proto::attitude::{angle_difference_rad, euler_rad};
use kestrel_proto::calibration::{MagCalibration, SensorCalibration};
use kestrel_proto::messages::{EstimatorStatus, FlightMode, LandedState, NavState, ParamSet};
use kestrel_proto::testing::{TestSetup, ready, vehicle_status};
use kestrel_proto::{Actor, Context, Time};
use kestrel_sim::{SimOptions, SimOutput, Simulator, VehicleParams, World};

const HARD_IRON_GAUSS: [f64; 3] = [0.15, -0.1, 0.2];

struct Bench {
    setup: TestSetup<EstimatorInput>,
    actor: EstimatorActor,
    ctx: Context,
    sim: Simulator,
    /// The correction the sensor path applies, from when the test changed it.
    calibration: SensorCalibration,
    /// The newest ground-truth yaw (rad).
    truth_yaw_rad: f64,
}

impl Bench {
    fn new() -> Bench {
        let mut vehicle = VehicleParams::default();
        vehicle.sensors.mag.hard_iron_gauss = HARD_IRON_GAUSS;
        let world = World::default();
        let params =
            EkfParams { mag_declination_deg: world.magnetic_field.declination_deg, ..Default::default() };
        let mut setup = TestSetup::new("estimator", ".");
        let actor = EstimatorActor::build(&params, &mut setup).expect("builds");
        let ctx = setup.context();
        let sim = Simulator::new(vehicle, world, SimOptions::default()).expect("sim");
        Bench { setup, actor, ctx, sim, calibration: SensorCalibration::default(), truth_yaw_rad: 0.0 }
    }

    fn send(&mut self, input: EstimatorInput) {
        ready(self.actor.handle(&self.ctx, input)).expect("handled");
    }

    fn status(&mut self, armed: bool) {
        let status = vehicle_status(self.sim.time(), armed, FlightMode::PosHold, LandedState::OnGround);
        self.send(EstimatorInput::Status(status));
    }

    /// Sends the ground station's compass calibration and applies it to the samples from now.
    fn calibrate_compass(&mut self) {
        self.calibration.mag =
            MagCalibration::new(HARD_IRON_GAUSS, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
                .expect("valid calibration");
        for (axis, hard) in ["X", "Y", "Z"].iter().zip(HARD_IRON_GAUSS) {
            let set = ParamSet {
                time: self.sim.time(),
                name: format!("COMPASS_OFS_{axis}"),
                value: -hard * 1000.0,
                restore: false,
            };
            self.send(EstimatorInput::Param(set));
        }
    }

    /// Steps the simulator for `seconds`, every sample through the calibration in use.
    fn run(&mut self, seconds: f64) {
        let end = Time::from_secs_f64(self.sim.time().as_secs_f64() + seconds);
        while self.sim.time() < end {
            self.sim.step();
            let outputs: Vec<SimOutput> = self.sim.drain().collect();
            for out in outputs {
                let input = match out {
                    SimOutput::Imu(s) => EstimatorInput::Imu(0, self.calibration.apply_imu(&s)),
                    SimOutput::Gps(f) => EstimatorInput::Gps(f),
                    SimOutput::Baro(b) => EstimatorInput::Baro(b),
                    SimOutput::Mag(m) => EstimatorInput::Mag(self.calibration.apply_mag(&m)),
                    SimOutput::GroundTruth(t) => {
                        self.truth_yaw_rad = euler_rad(t.attitude)[2];
                        continue;
                    }
                    _ => continue,
                };
                self.send(input);
            }
        }
    }

    fn yaw_error_deg(&self) -> f64 {
        let nav = self.setup.published::<NavState>("nav_state");
        let last = nav.last().expect("a state");
        angle_difference_rad(euler_rad(last.attitude)[2], self.truth_yaw_rad).to_degrees().abs()
    }

    fn realignments(&self) -> u32 {
        self.setup
            .published::<EstimatorStatus>("estimator_status")
            .last()
            .expect("status")
            .health
            .realignments
    }
}

#[test]
fn a_compass_calibration_on_a_disarmed_vehicle_aligns_the_yaw_again_without_a_restart() {
    let mut b = Bench::new();
    b.status(false);
    b.run(5.0);
    let uncalibrated = b.yaw_error_deg();
    assert!(uncalibrated > 5.0, "the hard iron turns the yaw: {uncalibrated:.2}°");

    let states_before = b.setup.count("nav_state");
    b.calibrate_compass();
    b.run(0.5);
    assert_eq!(b.setup.count("nav_state"), states_before, "no state while aligning again");
    b.run(4.5);
    let calibrated = b.yaw_error_deg();
    println!("yaw error: {uncalibrated:.2}° before the calibration, {calibrated:.3}° after");
    assert!(calibrated < 1.0, "aligned on the corrected field: {calibrated:.3}°");
    assert_eq!(b.realignments(), 1, "once for the three offsets set together");
    let last = b.setup.published::<NavState>("nav_state").pop().expect("a state");
    assert!(last.valid.horizontal_position && last.origin.is_some(), "GPS set the origin again: {last:?}");
}

#[test]
fn an_armed_vehicle_keeps_its_estimate_until_the_disarm() {
    let mut b = Bench::new();
    b.status(false);
    b.run(4.0);
    b.status(true);
    b.calibrate_compass();
    let states_before = b.setup.count("nav_state");
    b.run(2.0);
    assert!(b.setup.count("nav_state") >= states_before + 790, "a state for every sample while armed");
    assert_eq!(b.realignments(), 0, "never while armed");

    b.status(false);
    let states_at_disarm = b.setup.count("nav_state");
    b.run(0.5);
    assert_eq!(b.setup.count("nav_state"), states_at_disarm, "aligning again once disarmed");
    b.run(4.0);
    assert_eq!(b.realignments(), 1);
    let calibrated = b.yaw_error_deg();
    assert!(calibrated < 1.0, "aligned on the corrected field: {calibrated:.3}°");
}
