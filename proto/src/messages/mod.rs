//! The messages of the graph, one file per sensor or subsystem.

mod actuators;
mod avoidance_command;
mod baro;
mod battery;
mod calibration;
mod control_loop;
mod depth_grid;
mod esc_pulses;
mod esc_telemetry;
mod estimator_status;
mod failure_injection;
mod fence_plan;
mod follow_target;
mod gps;
mod ground_truth;
mod guided_target;
mod imu;
mod mag;
mod manual_control;
mod mission;
mod nav_state;
mod obstacle_map;
mod param_decl;
mod param_set;
mod proximity;
mod rally;
mod rangefinder;
mod sensor_health;
mod setpoint;
mod sim_fault;
mod stereo_frame;
mod supervisor;
mod vehicle_command;
mod vehicle_status;

pub use actuators::{ActuatorOutputs, MAX_MOTORS};
pub use avoidance_command::{
    AVOIDER_RULES, AvoidanceCommand, AvoidanceHealth, ClearRange, ClearRangeReason, FuzzyVelocity,
};
pub use baro::BaroSample;
pub use battery::BatteryStatus;
pub use calibration::{
    ACCELCAL_FAILED, ACCELCAL_SUCCESS, CalibrationCommand, CalibrationEvent, CalibrationMotion,
    CalibrationRequest, CalibrationStatus, CalibrationStep, CalibrationUpdate, MagCalState, MagReport,
    Motion, Severity,
};
pub use control_loop::ControlLoopStats;
pub use depth_grid::{DepthGrid, GridRegion, OBSTACLE_SECTORS, ObstacleSectors, SECTOR_UNKNOWN};
pub use esc_pulses::EscPulses;
pub use esc_telemetry::EscTelemetry;
pub use estimator_status::{AidingCounters, EstimatorHealth, EstimatorStatus, Innovation};
pub use failure_injection::{
    FAILURE_INJECTION_ENABLE, FailureInjection, FailureInjectionResult, FailureType, FailureUnit,
    InjectionOutcome,
};
pub use fence_plan::{FenceKind, FencePlan, FenceZone};
pub use follow_target::{FollowSource, FollowTarget};
pub use gps::{GpsFix, GpsFixType};
pub use ground_truth::GroundTruth;
pub use guided_target::{AttitudeTarget, PositionTarget};
pub use imu::ImuSample;
pub use mag::MagSample;
pub use manual_control::{ManualControl, StickSource};
pub use mission::{AltitudeFrame, CameraAction, MAX_MISSION_ITEMS, Mission, MissionItem, MissionPoint};
pub use nav_state::{NavState, NavValidity};
pub use obstacle_map::{Obstacle, ObstacleMap};
pub use param_decl::{ParamDecl, ParamInfo};
pub use param_set::ParamSet;
pub use proximity::Proximity;
pub use rally::{MAX_RALLY_POINTS, RallyPoints};
pub use rangefinder::{RangefinderOrientation, RangefinderSample};
pub use sensor_health::SensorHealth;
pub use setpoint::{Setpoint, SetpointTarget, TrajectorySetpoint};
pub use sim_fault::{SimFault, SimFaultPhase};
pub use stereo_frame::{FrameSizeError, StereoFrame};
pub use supervisor::{SupervisorEvent, SupervisorEventKind};
pub use vehicle_command::{
    Command, CommandResult, MOTOR_TEST_MAX_S, MotorTestThrottle, OrbitYaw, VehicleCommand,
};
pub use vehicle_status::{
    FENCE_ALT_MAX, FENCE_ALT_MIN, FENCE_CIRCLE, FENCE_POLYGON, Failsafe, FailsafeAction, FailsafeCause,
    FenceStatus, FlightMode, Home, LandedState, MissionProgress, SpeedCapStatus, VehicleStatus,
    VerticalLimitKind, VerticalLimitStatus,
};
