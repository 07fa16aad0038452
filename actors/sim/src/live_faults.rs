//! Faults set while the simulator runs, onto the same schedule as the world file's
//! `[[faults]]`: live `SIM_*` parameters, as ArduPilot's SITL has them (set from any ground
//! station), and MAV_CMD_INJECT_FAILURE, as PX4's SITL answers it (MAVSDK's Failure plugin),
//! allowed only while `SYS_FAILURE_EN` is 1.
//!
//! Each parameter group is one fault kind. Setting a group to its neutral value (0, or 1 for a
//! factor) ends its fault; any other value ends the old one and starts one with the new values
//! at the next tick. The names are ours where ArduPilot's differ in unit or meaning (its
//! `SIM_GPS_GLITCH_*` are degrees of latitude; ours are metres), ArduPilot's where they agree
//! (`SIM_BARO_DRIFT` m/s, `SIM_ENGINE_MUL`, `SIM_WIND_SPD`/`_DIR`/`_TURB`, the direction the
//! wind blows *from*). The stereo camera's faults are injected on `FAILURE_UNIT_SYSTEM_AVOIDANCE`
//! (the camera is what the avoider sees through; MAVLink has no camera unit): they join this
//! schedule, and the camera actor applies them from their `sim_fault` start and end.

use kestrel_proto::messages::{
    FAILURE_INJECTION_ENABLE, FailureInjection, FailureType, FailureUnit, InjectionOutcome,
};
use kestrel_proto::param_def::{ParamDef, WhileArmed};

use crate::error::InvalidParam;
use crate::faults::{CameraLens, FaultKind};
use crate::simulator::Simulator;

/// The live parameters' values, in their MAVLink units.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveFaultParams {
    /// `SYS_FAILURE_EN`: 1 allows MAV_CMD_INJECT_FAILURE.
    pub failure_injection: f64,
    pub gps_disable: f64,
    pub gps_jump_ned_m: [f64; 3],
    pub gps_noise_factor: f64,
    pub mag_anomaly_frd_gauss: [f64; 3],
    pub mag_stuck: f64,
    pub baro_drift_m_s: f64,
    pub baro_stuck: f64,
    pub gyro_bias_frd_rad_s: [f64; 3],
    pub accel_bias_frd_m_s2: [f64; 3],
    pub accel_clip: f64,
    pub imu_stop: f64,
    /// `SIM_ENGINE_FAIL`: the motor (1-based, mixer order) `engine_mul` acts on; 0 none.
    pub engine_fail: f64,
    /// `SIM_ENGINE_MUL`: that motor's thrust factor, 0..1 (0: lost).
    pub engine_mul: f64,
    pub battery_sag_v: f64,
    pub wind_speed_m_s: f64,
    /// Where the wind blows from (deg clockwise from north), as ArduPilot's `SIM_WIND_DIR`.
    pub wind_from_deg: f64,
    pub wind_gust_m_s: f64,
}

impl Default for LiveFaultParams {
    /// Nothing broken, injection off.
    fn default() -> LiveFaultParams {
        LiveFaultParams {
            failure_injection: 0.0,
            gps_disable: 0.0,
            gps_jump_ned_m: [0.0; 3],
            gps_noise_factor: 1.0,
            mag_anomaly_frd_gauss: [0.0; 3],
            mag_stuck: 0.0,
            baro_drift_m_s: 0.0,
            baro_stuck: 0.0,
            gyro_bias_frd_rad_s: [0.0; 3],
            accel_bias_frd_m_s2: [0.0; 3],
            accel_clip: 0.0,
            imu_stop: 0.0,
            engine_fail: 0.0,
            engine_mul: 1.0,
            battery_sag_v: 0.0,
            wind_speed_m_s: 0.0,
            wind_from_deg: 0.0,
            wind_gust_m_s: 0.0,
        }
    }
}

/// A 0/1 switch parameter.
macro_rules! switch_param {
    ($name:literal, $field:ident, $what:literal) => {
        ParamDef {
            name: $name,
            unit: "",
            min: 0.0,
            max: 1.0,
            description: $what,
            while_armed: WhileArmed::Tunable,
            get: |p| p.$field,
            set: |p, v| p.$field = v,
        }
    };
}

/// One axis of a vector parameter.
macro_rules! axis_param {
    ($name:literal, $field:ident, $i:literal, $unit:literal, $limit:literal, $what:literal) => {
        ParamDef {
            name: $name,
            unit: $unit,
            min: -$limit,
            max: $limit,
            description: $what,
            while_armed: WhileArmed::Tunable,
            get: |p| p.$field[$i],
            set: |p, v| p.$field[$i] = v,
        }
    };
}

/// The simulator's live fault parameters.
pub static LIVE_FAULT_PARAMS: [ParamDef<LiveFaultParams>; 26] = [
    switch_param!("SYS_FAILURE_EN", failure_injection, "Allow MAV_CMD_INJECT_FAILURE (PX4's name)"),
    switch_param!("SIM_GPS_DISABLE", gps_disable, "GPS loses every satellite (gps_off)"),
    axis_param!("SIM_GPS_JUMP_N", gps_jump_ned_m, 0, "m", 10000.0, "GPS position offset north (gps_jump)"),
    axis_param!("SIM_GPS_JUMP_E", gps_jump_ned_m, 1, "m", 10000.0, "GPS position offset east (gps_jump)"),
    axis_param!("SIM_GPS_JUMP_D", gps_jump_ned_m, 2, "m", 10000.0, "GPS position offset down (gps_jump)"),
    ParamDef {
        name: "SIM_GPS_NOISE",
        unit: "",
        min: 0.0,
        max: 100.0,
        description: "GPS noise factor, 1 none (gps_noise)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.gps_noise_factor,
        set: |p, v| p.gps_noise_factor = v,
    },
    axis_param!(
        "SIM_MAG_ANOM_X",
        mag_anomaly_frd_gauss,
        0,
        "gauss",
        10.0,
        "Field added forward (mag_anomaly)"
    ),
    axis_param!("SIM_MAG_ANOM_Y", mag_anomaly_frd_gauss, 1, "gauss", 10.0, "Field added right (mag_anomaly)"),
    axis_param!("SIM_MAG_ANOM_Z", mag_anomaly_frd_gauss, 2, "gauss", 10.0, "Field added down (mag_anomaly)"),
    switch_param!("SIM_MAG_STUCK", mag_stuck, "Magnetometer repeats its last reading (mag_stuck)"),
    ParamDef {
        name: "SIM_BARO_DRIFT",
        unit: "m/s",
        min: -100.0,
        max: 100.0,
        description: "Baro altitude error growth, + reads high (baro_drift)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.baro_drift_m_s,
        set: |p, v| p.baro_drift_m_s = v,
    },
    switch_param!("SIM_BARO_STUCK", baro_stuck, "Barometer repeats its last reading (baro_stuck)"),
    axis_param!("SIM_GYR_BIAS_X", gyro_bias_frd_rad_s, 0, "rad/s", 10.0, "Gyro bias step, roll (gyro_bias)"),
    axis_param!("SIM_GYR_BIAS_Y", gyro_bias_frd_rad_s, 1, "rad/s", 10.0, "Gyro bias step, pitch (gyro_bias)"),
    axis_param!("SIM_GYR_BIAS_Z", gyro_bias_frd_rad_s, 2, "rad/s", 10.0, "Gyro bias step, yaw (gyro_bias)"),
    axis_param!("SIM_ACC_BIAS_X", accel_bias_frd_m_s2, 0, "m/s^2", 50.0, "Accel bias step, fwd (accel_bias)"),
    axis_param!(
        "SIM_ACC_BIAS_Y",
        accel_bias_frd_m_s2,
        1,
        "m/s^2",
        50.0,
        "Accel bias step, right (accel_bias)"
    ),
    axis_param!(
        "SIM_ACC_BIAS_Z",
        accel_bias_frd_m_s2,
        2,
        "m/s^2",
        50.0,
        "Accel bias step, down (accel_bias)"
    ),
    switch_param!("SIM_ACC_CLIP", accel_clip, "Accelerometer clips at full scale (accel_clip)"),
    switch_param!("SIM_IMU_STOP", imu_stop, "IMU samples stop (imu_stop)"),
    ParamDef {
        name: "SIM_ENGINE_FAIL",
        unit: "",
        min: 0.0,
        max: 8.0,
        description: "Motor SIM_ENGINE_MUL acts on, 1-based; 0 none",
        while_armed: WhileArmed::Tunable,
        get: |p| p.engine_fail,
        set: |p, v| p.engine_fail = v,
    },
    ParamDef {
        name: "SIM_ENGINE_MUL",
        unit: "",
        min: 0.0,
        max: 1.0,
        description: "Thrust factor of SIM_ENGINE_FAIL's motor, 0 lost",
        while_armed: WhileArmed::Tunable,
        get: |p| p.engine_mul,
        set: |p, v| p.engine_mul = v,
    },
    ParamDef {
        name: "SIM_BATT_SAG",
        unit: "V",
        min: 0.0,
        max: 100.0,
        description: "Battery voltage lowered by (battery_sag)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.battery_sag_v,
        set: |p, v| p.battery_sag_v = v,
    },
    ParamDef {
        name: "SIM_WIND_SPD",
        unit: "m/s",
        min: 0.0,
        max: 50.0,
        description: "Wind speed replacing the world's; 0 with TURB 0: world's",
        while_armed: WhileArmed::Tunable,
        get: |p| p.wind_speed_m_s,
        set: |p, v| p.wind_speed_m_s = v,
    },
    ParamDef {
        name: "SIM_WIND_DIR",
        unit: "deg",
        min: 0.0,
        max: 360.0,
        description: "Direction the wind blows from, clockwise from north",
        while_armed: WhileArmed::Tunable,
        get: |p| p.wind_from_deg,
        set: |p, v| p.wind_from_deg = v,
    },
    ParamDef {
        name: "SIM_WIND_TURB",
        unit: "m/s",
        min: 0.0,
        max: 20.0,
        description: "Gust 1 sigma with SIM_WIND_SPD (wind)",
        while_armed: WhileArmed::Tunable,
        get: |p| p.wind_gust_m_s,
        set: |p, v| p.wind_gust_m_s = v,
    },
];

/// The parameters that take whole numbers only: the link serves them as integers.
pub const INTEGER_PARAMS: [&str; 7] = [
    "SYS_FAILURE_EN",
    "SIM_GPS_DISABLE",
    "SIM_MAG_STUCK",
    "SIM_BARO_STUCK",
    "SIM_ACC_CLIP",
    "SIM_IMU_STOP",
    "SIM_ENGINE_FAIL",
];

/// How many fault kinds the parameters set (one per group).
const GROUPS: usize = 14;

impl LiveFaultParams {
    /// Checks what a range cannot: switches are exactly 0 or 1, the motor a whole number of the
    /// vehicle's frame (`motor_count`).
    pub fn validate(&self, motor_count: usize) -> Result<(), InvalidParam> {
        let switches = [
            ("SYS_FAILURE_EN", self.failure_injection),
            ("SIM_GPS_DISABLE", self.gps_disable),
            ("SIM_MAG_STUCK", self.mag_stuck),
            ("SIM_BARO_STUCK", self.baro_stuck),
            ("SIM_ACC_CLIP", self.accel_clip),
            ("SIM_IMU_STOP", self.imu_stop),
        ];
        for (name, v) in switches {
            if v != 0.0 && v != 1.0 {
                return Err(InvalidParam::new(name, format!("is a switch: 0 or 1, got {v}")));
            }
        }
        let motor = self.engine_fail;
        if motor.fract() != 0.0 || motor < 0.0 || motor > motor_count as f64 {
            return Err(InvalidParam::new(
                "SIM_ENGINE_FAIL",
                format!("must be 0 (none) or a motor 1..={motor_count}, got {motor}"),
            ));
        }
        Ok(())
    }

    /// Whether MAV_CMD_INJECT_FAILURE is allowed.
    pub fn injection_allowed(&self) -> bool {
        self.failure_injection == 1.0
    }

    /// The fault each group asks for (`None`: its neutral value), in a fixed group order.
    fn kinds(&self) -> [Option<FaultKind>; GROUPS] {
        let on = |v: f64| v == 1.0;
        let nonzero = |v: &[f64; 3]| v.iter().any(|x| *x != 0.0);
        let engine = match (self.engine_fail as u8, self.engine_mul) {
            (0, _) => None,
            (_, 1.0) => None,
            (motor, 0.0) => Some(FaultKind::MotorLost { motor }),
            (motor, thrust) => Some(FaultKind::MotorWeak { motor, thrust }),
        };
        let wind = (self.wind_speed_m_s > 0.0 || self.wind_gust_m_s > 0.0).then(|| {
            let [north, east] = kestrel_proto::wind::from_direction(self.wind_speed_m_s, self.wind_from_deg);
            FaultKind::Wind { ned_m_s: [north, east, 0.0], gust_m_s: self.wind_gust_m_s }
        });
        [
            on(self.gps_disable).then_some(FaultKind::GpsOff),
            nonzero(&self.gps_jump_ned_m).then_some(FaultKind::GpsJump { ned_m: self.gps_jump_ned_m }),
            (self.gps_noise_factor != 1.0).then_some(FaultKind::GpsNoise { factor: self.gps_noise_factor }),
            nonzero(&self.mag_anomaly_frd_gauss)
                .then_some(FaultKind::MagAnomaly { gauss: self.mag_anomaly_frd_gauss }),
            on(self.mag_stuck).then_some(FaultKind::MagStuck),
            (self.baro_drift_m_s != 0.0).then_some(FaultKind::BaroDrift { m_s: self.baro_drift_m_s }),
            on(self.baro_stuck).then_some(FaultKind::BaroStuck),
            nonzero(&self.gyro_bias_frd_rad_s)
                .then_some(FaultKind::GyroBias { rad_s: self.gyro_bias_frd_rad_s }),
            nonzero(&self.accel_bias_frd_m_s2)
                .then_some(FaultKind::AccelBias { m_s2: self.accel_bias_frd_m_s2 }),
            on(self.accel_clip).then_some(FaultKind::AccelClip),
            on(self.imu_stop).then_some(FaultKind::ImuStop),
            engine,
            (self.battery_sag_v != 0.0).then_some(FaultKind::BatterySag { volts: self.battery_sag_v }),
            wind,
        ]
    }
}

/// The glare MAV_CMD_INJECT_FAILURE puts on the stereo camera: full white over the middle 60 %
/// of both images, over the avoider's centre region (the sun ahead, thesis §4.2.4).
pub const CAMERA_GLARE: FaultKind =
    FaultKind::CameraGlare { region: [0.2, 0.2, 0.8, 0.8], intensity: 1.0, lens: CameraLens::Both };

/// A failure injected by MAV_CMD_INJECT_FAILURE, until a `FAILURE_TYPE_OK` for its unit.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Injected {
    unit: FailureUnit,
    instance: u8,
    index: usize,
}

/// The faults the parameters and injections have put on the simulator's schedule.
#[derive(Clone, Debug, Default)]
pub struct LiveFaults {
    params: LiveFaultParams,
    /// Per group, the schedule index of its fault, while one is active.
    active: [Option<(FaultKind, usize)>; GROUPS],
    injected: Vec<Injected>,
}

impl LiveFaults {
    /// The parameters' current values.
    pub fn params(&self) -> &LiveFaultParams {
        &self.params
    }

    /// Takes parameter values already checked ([`LiveFaultParams::validate`]): every group
    /// whose fault changed ends the old one and starts the new one on `sim`.
    pub fn set_params(&mut self, params: LiveFaultParams, sim: &mut Simulator) -> Result<(), InvalidParam> {
        for (slot, wanted) in self.active.iter_mut().zip(params.kinds()) {
            if slot.as_ref().map(|(kind, _)| kind) == wanted.as_ref() {
                continue;
            }
            if let Some((_, index)) = slot.take() {
                sim.end_fault(index);
            }
            if let Some(kind) = wanted {
                *slot = Some((kind.clone(), sim.add_fault(kind)?));
            }
        }
        self.params = params;
        Ok(())
    }

    /// Carries out (or refuses) a MAV_CMD_INJECT_FAILURE on `sim`.
    pub fn inject(&mut self, request: &FailureInjection, sim: &mut Simulator) -> InjectionOutcome {
        if !self.params.injection_allowed() {
            return InjectionOutcome::Denied(format!(
                "{FAILURE_INJECTION_ENABLE} is 0; set it to 1 to allow failure injection"
            ));
        }
        let motors = sim.vehicle().frame.motor_count();
        if request.failure == FailureType::Ok {
            let (unit, instance) = (request.unit, request.instance);
            let mut ended = 0;
            self.injected.retain(|i| {
                let matches = i.unit == unit && (instance == 0 || i.instance == instance);
                if matches {
                    sim.end_fault(i.index);
                    ended += 1;
                }
                !matches
            });
            return InjectionOutcome::Accepted(format!("{unit:?} back to normal ({ended} failures ended)"));
        }
        let kind = match injected_kind(request.unit, request.failure, request.instance, motors) {
            Ok(kind) => kind,
            Err(outcome) => return outcome,
        };
        let what = format!("{} {kind}", kind.name());
        match sim.add_fault(kind) {
            Ok(index) => {
                self.injected.push(Injected { unit: request.unit, instance: request.instance, index });
                InjectionOutcome::Accepted(what.trim_end().to_owned())
            }
            Err(e) => InjectionOutcome::Denied(e.to_string()),
        }
    }
}

/// The fault a unit and type inject, as PX4's SITL reads them: `OFF` stops a sensor, `STUCK`
/// freezes it, `WRONG` makes it lie by the fault matrix's amount (GPS 50 m north, the
/// magnetometer +0.3 G forward, the barometer drifting 1 m/s). The simulator has one of each
/// sensor: instance 0 (all) or 1. A motor needs its number. The stereo camera
/// (`SYSTEM_AVOIDANCE`): `WRONG` is glare over the middle of both images ([`CAMERA_GLARE`], the
/// sun ahead), `STUCK` frozen frames, `OFF` a lens capped (instance 1 left, 2 right, 0 both:
/// black frames).
fn injected_kind(
    unit: FailureUnit,
    failure: FailureType,
    instance: u8,
    motors: usize,
) -> Result<FaultKind, InjectionOutcome> {
    use FailureType::{Off, Stuck, Wrong};
    use FailureUnit::{
        SensorAccel, SensorBaro, SensorGps, SensorGyro, SensorMag, SystemAvoidance, SystemMotor,
    };
    if unit == SystemAvoidance && instance > 2 {
        return Err(InjectionOutcome::Denied(format!(
            "the stereo camera's lenses are 1 (left) and 2 (right), or 0 (both); not {instance}"
        )));
    }
    if unit != SystemMotor && unit != SystemAvoidance && instance > 1 {
        return Err(InjectionOutcome::Denied(format!(
            "the simulator has one {unit:?}, not instance {instance}"
        )));
    }
    Ok(match (unit, failure) {
        (SensorGyro | SensorAccel, Off) => FaultKind::ImuStop,
        (SensorGps, Off) => FaultKind::GpsOff,
        (SensorGps, Wrong) => FaultKind::GpsJump { ned_m: [50.0, 0.0, 0.0] },
        (SensorMag, Stuck) => FaultKind::MagStuck,
        (SensorMag, Wrong) => FaultKind::MagAnomaly { gauss: [0.3, 0.0, 0.0] },
        (SensorBaro, Stuck) => FaultKind::BaroStuck,
        (SensorBaro, Wrong) => FaultKind::BaroDrift { m_s: 1.0 },
        (SystemAvoidance, Wrong) => CAMERA_GLARE,
        (SystemAvoidance, Stuck) => FaultKind::CameraFrozen,
        (SystemAvoidance, Off) => match instance {
            1 => FaultKind::CameraCapped { lens: CameraLens::Left },
            2 => FaultKind::CameraCapped { lens: CameraLens::Right },
            _ => FaultKind::CameraBlack,
        },
        (SystemMotor, Off) if (1..=motors).contains(&usize::from(instance)) => {
            FaultKind::MotorLost { motor: instance }
        }
        (SystemMotor, Off) => {
            return Err(InjectionOutcome::Denied(format!(
                "a motor failure names one motor, 1..={motors}; got instance {instance}"
            )));
        }
        _ => return Err(InjectionOutcome::Unsupported(format!("{unit:?} {failure:?} is not simulated"))),
    })
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::param_def::{ParamChange, apply};

    use super::*;
    use crate::simulator::SimOptions;
    use crate::vehicle::VehicleParams;
    use crate::world::World;

    fn sim() -> Simulator {
        Simulator::new(VehicleParams::default(), World::default(), SimOptions::default()).expect("defaults")
    }

    fn set(live: &mut LiveFaults, sim: &mut Simulator, name: &str, value: f64) -> Result<(), String> {
        let mut params = live.params().clone();
        let motors = sim.vehicle().frame.motor_count();
        match apply(&LIVE_FAULT_PARAMS, &mut params, name, value, |p| p.validate(motors)) {
            Ok(ParamChange::Applied) => live.set_params(params, sim).map_err(|e| e.to_string()),
            Ok(ParamChange::NotMine) => Err(format!("{name} is not a live fault parameter")),
            Err(e) => Err(e.to_string()),
        }
    }

    fn active_kinds(sim: &Simulator) -> Vec<String> {
        let t = Time(sim.time().0 + sim.tick_period().as_micros() as u64);
        sim.faults().active_at(t).map(|(_, f)| format!("{} {}", f.kind.name(), f.kind)).collect()
    }

    #[test]
    fn every_name_fits_mavlink_and_every_default_is_in_range_and_neutral() {
        let decl = kestrel_proto::param_def::declare(
            &LIVE_FAULT_PARAMS,
            &LiveFaultParams::default(),
            "sim",
            true,
            Time::ZERO,
        );
        decl.check().expect("a valid declaration");
        assert!(LiveFaultParams::default().kinds().iter().all(Option::is_none));
        LiveFaultParams::default().validate(4).expect("defaults valid");
    }

    #[test]
    fn a_parameter_starts_its_fault_at_the_next_tick_and_its_neutral_value_ends_it() {
        let (mut sim, mut live) = (sim(), LiveFaults::default());
        sim.advance_to(Time::from_micros(100_000));
        set(&mut live, &mut sim, "SIM_GPS_DISABLE", 1.0).unwrap();
        assert_eq!(active_kinds(&sim), ["gps_off "]);
        set(&mut live, &mut sim, "SIM_GPS_JUMP_N", 50.0).unwrap();
        assert_eq!(active_kinds(&sim), ["gps_off ", "gps_jump ned_m = [50, 0, 0]"]);
        set(&mut live, &mut sim, "SIM_GPS_JUMP_E", -3.0).unwrap();
        assert_eq!(active_kinds(&sim), ["gps_off ", "gps_jump ned_m = [50, -3, 0]"]);
        sim.advance_to(Time::from_micros(200_000));
        assert!(sim.fault_effects().gps.off, "in effect after a tick");
        set(&mut live, &mut sim, "SIM_GPS_DISABLE", 0.0).unwrap();
        assert_eq!(active_kinds(&sim), ["gps_jump ned_m = [50, -3, 0]"]);
        sim.advance_to(Time::from_micros(300_000));
        assert!(!sim.fault_effects().gps.off);
        assert_eq!(sim.fault_effects().gps.offset_ned_m, nalgebra::Vector3::new(50.0, -3.0, 0.0));
    }

    #[test]
    fn switches_take_exactly_0_or_1_and_the_motor_must_be_on_the_frame() {
        let (mut sim, mut live) = (sim(), LiveFaults::default());
        for (name, value) in [
            ("SIM_GPS_DISABLE", 0.5),
            ("SYS_FAILURE_EN", 2.0),
            ("SIM_IMU_STOP", f64::NAN),
            ("SIM_ENGINE_FAIL", 1.5),
            ("SIM_ENGINE_FAIL", 5.0),
            ("SIM_WIND_SPD", f64::INFINITY),
        ] {
            let refused = set(&mut live, &mut sim, name, value).expect_err(name);
            assert!(refused.contains(name), "{refused}");
        }
        assert_eq!(live.params(), &LiveFaultParams::default());
        assert!(active_kinds(&sim).is_empty());
    }

    #[test]
    fn engine_fail_and_mul_weaken_or_remove_one_motor() {
        let (mut sim, mut live) = (sim(), LiveFaults::default());
        set(&mut live, &mut sim, "SIM_ENGINE_FAIL", 2.0).unwrap();
        assert!(active_kinds(&sim).is_empty(), "a factor of 1 changes nothing");
        set(&mut live, &mut sim, "SIM_ENGINE_MUL", 0.6).unwrap();
        assert_eq!(active_kinds(&sim), ["motor_weak motor = 2, thrust = 0.6"]);
        set(&mut live, &mut sim, "SIM_ENGINE_MUL", 0.0).unwrap();
        assert_eq!(active_kinds(&sim), ["motor_lost motor = 2"]);
    }

    #[test]
    fn wind_dir_is_where_it_blows_from() {
        let (mut sim, mut live) = (sim(), LiveFaults::default());
        set(&mut live, &mut sim, "SIM_WIND_DIR", 90.0).unwrap();
        set(&mut live, &mut sim, "SIM_WIND_SPD", 10.0).unwrap();
        let t = Time(sim.time().0 + 1);
        let (_, fault) = sim.faults().active_at(t).next().expect("wind");
        let FaultKind::Wind { ned_m_s, gust_m_s } = fault.kind else { panic!("{:?}", fault.kind) };
        // From the east: the air moves west.
        assert!(ned_m_s[0].abs() < 1e-9 && (ned_m_s[1] + 10.0).abs() < 1e-9, "{ned_m_s:?}");
        assert_eq!(gust_m_s, 0.0);
    }

    fn request(unit: FailureUnit, failure: FailureType, instance: u8) -> FailureInjection {
        FailureInjection { time: Time::ZERO, id: 1, unit, failure, instance }
    }

    #[test]
    fn injection_is_denied_until_sys_failure_en_is_1() {
        let (mut sim, mut live) = (sim(), LiveFaults::default());
        let gps_off = request(FailureUnit::SensorGps, FailureType::Off, 0);
        let InjectionOutcome::Denied(why) = live.inject(&gps_off, &mut sim) else { panic!("not denied") };
        assert!(why.contains("SYS_FAILURE_EN"), "{why}");
        assert!(active_kinds(&sim).is_empty());
        set(&mut live, &mut sim, "SYS_FAILURE_EN", 1.0).unwrap();
        assert_eq!(live.inject(&gps_off, &mut sim), InjectionOutcome::Accepted("gps_off".into()));
        assert_eq!(active_kinds(&sim), ["gps_off "]);
        let ok = request(FailureUnit::SensorGps, FailureType::Ok, 0);
        assert!(matches!(live.inject(&ok, &mut sim), InjectionOutcome::Accepted(_)));
        assert!(active_kinds(&sim).is_empty());
    }

    #[test]
    fn each_unit_and_type_maps_to_its_fault_or_is_refused() {
        let (mut sim, mut live) = (sim(), LiveFaults::default());
        set(&mut live, &mut sim, "SYS_FAILURE_EN", 1.0).unwrap();
        use FailureType::*;
        use FailureUnit::*;
        for (unit, failure, instance, expect) in [
            (SensorGyro, Off, 0, Some("imu_stop")),
            (SensorAccel, Off, 1, Some("imu_stop")),
            (SensorGps, Wrong, 0, Some("gps_jump")),
            (SensorMag, Stuck, 0, Some("mag_stuck")),
            (SensorMag, Wrong, 0, Some("mag_anomaly")),
            (SensorBaro, Stuck, 0, Some("baro_stuck")),
            (SensorBaro, Wrong, 0, Some("baro_drift")),
            (SystemMotor, Off, 3, Some("motor_lost")),
            (SystemAvoidance, Wrong, 0, Some("camera_glare")),
            (SystemAvoidance, Off, 2, Some("camera_capped lens = \"right\"")),
            (SystemAvoidance, Off, 0, Some("camera_black")),
            (SystemAvoidance, Stuck, 0, Some("camera_frozen")),
        ] {
            let outcome = live.inject(&request(unit, failure, instance), &mut sim);
            let InjectionOutcome::Accepted(what) = outcome else {
                panic!("{unit:?} {failure:?}: {outcome:?}")
            };
            assert!(what.starts_with(expect.unwrap()), "{what}");
        }
        for (unit, failure, instance) in
            [(SystemMotor, Off, 0), (SystemMotor, Off, 5), (SensorGps, Off, 2), (SystemAvoidance, Off, 3)]
        {
            let outcome = live.inject(&request(unit, failure, instance), &mut sim);
            assert!(matches!(outcome, InjectionOutcome::Denied(_)), "{unit:?} {instance}: {outcome:?}");
        }
        for (unit, failure) in
            [(SensorGps, Garbage), (SensorAirspeed, Off), (SystemAvoidance, Slow), (SensorGyro, Slow)]
        {
            let outcome = live.inject(&request(unit, failure, 0), &mut sim);
            assert!(matches!(outcome, InjectionOutcome::Unsupported(_)), "{unit:?} {failure:?}: {outcome:?}");
        }
        let n = active_kinds(&sim).len();
        live.inject(&request(SensorMag, Ok, 0), &mut sim);
        assert_eq!(active_kinds(&sim).len(), n - 2, "both magnetometer failures ended");
    }
}
