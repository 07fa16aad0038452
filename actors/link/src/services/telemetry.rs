//! Telemetry streams: which messages go out how often (defaults, MAV_CMD_SET_MESSAGE_INTERVAL,
//! legacy REQUEST_DATA_STREAM, MAV_CMD_REQUEST_MESSAGE), and each message built from the graph's
//! latest state. Quaternion → Euler happens here for display only.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use kestrel_proto::attitude::{euler_rad, unit_quaternion};
use kestrel_proto::units::GRAVITY_M_S2;
use nalgebra::Vector3;
use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame, deg_e7};
use kestrel_proto::messages::{
    AvoidanceCommand, BatteryStatus, DepthGrid, EstimatorStatus, FailsafeCause, GpsFix, GpsFixType,
    GroundTruth, Innovation, LandedState, NavState, OBSTACLE_SECTORS, RangefinderOrientation,
    RangefinderSample, VehicleStatus,
};
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::{
    ATTITUDE_DATA, BATTERY_STATUS_DATA, DEBUG_VECT_DATA, DISTANCE_SENSOR_DATA, EKF_STATUS_REPORT_DATA,
    EXTENDED_SYS_STATE_DATA, EkfStatusFlags, GLOBAL_POSITION_INT_DATA, GPS_RAW_INT_DATA,
    GpsFixType as MavFix, HOME_POSITION_DATA, LOCAL_POSITION_NED_DATA, MISSION_CURRENT_DATA,
    MavBatteryFunction, MavBatteryType, MavDataStream, MavDistanceSensor, MavFrame, MavLandedState,
    MavMessage, MavResult, MavSensorOrientation, MavSysStatusSensor, MavVtolState, MissionState,
    OBSTACLE_DISTANCE_DATA, SIMSTATE_DATA, SYS_STATUS_DATA, VFR_HUD_DATA, WIND_DATA,
};

/// The graph's latest state, as telemetry needs it.
#[derive(Debug, Default)]
pub struct Snapshot {
    pub nav: Option<NavState>,
    pub gps: Option<GpsFix>,
    pub battery: Option<BatteryStatus>,
    pub status: Option<VehicleStatus>,
    pub depth: Option<DepthGrid>,
    pub avoidance: Option<AvoidanceCommand>,
    /// The estimator's innovations and health (for EKF_STATUS_REPORT's test ratios).
    pub estimator: Option<EstimatorStatus>,
    /// Whether a flight mission is stored (for MISSION_CURRENT).
    pub mission_items: u16,
    /// The simulator's ground truth (for SIMSTATE); never on hardware.
    pub truth: Option<GroundTruth>,
    /// Each rangefinder's newest usable sample (for DISTANCE_SENSOR), indexed by its
    /// [`distance_sensor_id`]: down, then up.
    pub rangefinders: [Option<RangefinderSample>; 2],
}

#[derive(Clone, Copy, Debug)]
struct Stream {
    id: u32,
    default: Option<Duration>,
    interval: Option<Duration>,
    next: Time,
}

fn hz(rate: f64) -> Option<Duration> {
    Some(Duration::from_secs_f64(1.0 / rate))
}

/// Name of the DEBUG_VECT carrying the obstacle avoider's correction.
pub const AVOIDANCE_VECT_NAME: &str = "AVOID";

/// Default rates (Hz): PX4's and ArduPilot's SITL rates, rounded.
fn default_streams() -> Vec<Stream> {
    [
        (SYS_STATUS_DATA::ID, hz(1.0)),
        (ATTITUDE_DATA::ID, hz(10.0)),
        (LOCAL_POSITION_NED_DATA::ID, hz(5.0)),
        (GLOBAL_POSITION_INT_DATA::ID, hz(5.0)),
        (GPS_RAW_INT_DATA::ID, hz(2.0)),
        (VFR_HUD_DATA::ID, hz(4.0)),
        (BATTERY_STATUS_DATA::ID, hz(1.0)),
        (HOME_POSITION_DATA::ID, hz(0.5)),
        (EXTENDED_SYS_STATE_DATA::ID, hz(1.0)),
        (EKF_STATUS_REPORT_DATA::ID, hz(1.0)),
        // Once the estimator has learnt the wind (a drag model is configured).
        (WIND_DATA::ID, hz(1.0)),
        (MISSION_CURRENT_DATA::ID, hz(1.0)),
        (OBSTACLE_DISTANCE_DATA::ID, hz(5.0)),
        (DEBUG_VECT_DATA::ID, hz(5.0)),
        // One per rangefinder with a fresh sample (down, up): the rangefinders sample at tens of
        // Hz, a ground station's readout needs no more than this.
        (DISTANCE_SENSOR_DATA::ID, hz(10.0)),
        // Only while the graph has a simulator's ground truth, as ArduPilot SITL sends it.
        (SIMSTATE_DATA::ID, hz(10.0)),
    ]
    .into_iter()
    .map(|(id, default)| Stream { id, default, interval: default, next: Time::ZERO })
    .collect()
}

/// ArduPilot SITL's SIMSTATE from the simulator's truth: the true attitude (rad), what an ideal
/// accelerometer would read (m/s², body FRD, gravity included) and the true rates (rad/s,
/// body), and the true position. `None` for a truth without a valid attitude.
fn simstate(truth: &GroundTruth) -> Option<SIMSTATE_DATA> {
    let attitude = unit_quaternion(truth.attitude).ok()?;
    let [roll, pitch, yaw] = euler_rad(truth.attitude);
    let gravity_ned = Vector3::new(0.0, 0.0, GRAVITY_M_S2);
    let specific_force = attitude.inverse() * (Vector3::from(truth.acceleration_ned_m_s2) - gravity_ned);
    let [p, q, r] = truth.angular_velocity_rad_s;
    Some(SIMSTATE_DATA {
        roll: roll as f32,
        pitch: pitch as f32,
        yaw: yaw as f32,
        xacc: specific_force.x as f32,
        yacc: specific_force.y as f32,
        zacc: specific_force.z as f32,
        xgyro: p as f32,
        ygyro: q as f32,
        zgyro: r as f32,
        lat: deg_e7(truth.lat_deg),
        lng: deg_e7(truth.lon_deg),
    })
}

/// ArduPilot's WIND from the estimator's wind (m/s, north and east: the air's velocity over the
/// ground): the direction it blows *from* (degrees clockwise from north, 0..360) and its speed;
/// no vertical wind is estimated.
fn wind(wind_ne_m_s: [f64; 2]) -> WIND_DATA {
    let (from_deg, speed_m_s) = kestrel_proto::wind::direction(wind_ne_m_s);
    WIND_DATA { direction: from_deg as f32, speed: speed_m_s as f32, speed_z: 0.0 }
}

/// A rangefinder's sample older than this is not reported (a sensor gone quiet is no longer
/// in view): ArduPilot's backends mark a rangefinder `NoData` after 200 ms without a reading
/// (`AP_RangeFinder_Benewake_TFMiniPlus::update`), and `GCS_MAVLINK::send_distance_sensor` sends
/// nothing for a sensor without data.
pub const RANGEFINDER_STALE: Duration = Duration::from_millis(200);

/// What a reading beyond the sensor's range reports, above its maximum (cm): ArduPilot's
/// Benewake drivers (`AP_RangeFinder_Benewake::get_reading`,
/// `AP_RangeFinder_Benewake_TFMiniPlus::process_raw_measure`) turn a TFmini's "no return" into
/// `max(model maximum, RNGFND_MAX_CM + BENEWAKE_OUT_OF_RANGE_ADD_CM)`, 100 cm beyond the
/// maximum, and `GCS_MAVLINK::send_distance_sensor` sends that distance as `current_distance`;
/// a ground station (and ArduPilot's own MAVLink rangefinder backend) reads a distance above
/// `max_distance` as out of range high.
pub const OUT_OF_RANGE_ADD_CM: u16 = 100;

/// DISTANCE_SENSOR's `id` of the rangefinder looking `orientation`: 0 for the downward one, as
/// ArduPilot numbers its first rangefinder (the one its altitude comes from), 1 for the upward.
pub fn distance_sensor_id(orientation: RangefinderOrientation) -> u8 {
    match orientation {
        RangefinderOrientation::Down => 0,
        RangefinderOrientation::Up => 1,
    }
}

/// DISTANCE_SENSOR for `sample` (checked by [`RangefinderSample::invalid`]): distances in cm,
/// stamped with its measurement time (ArduPilot stamps the sending time, a TODO in its code),
/// a laser (a TFmini is a time-of-flight lidar) whose `covariance` is unknown (255: the sample
/// does not carry its noise).
fn distance_sensor(sample: &RangefinderSample) -> DISTANCE_SENSOR_DATA {
    let cm = |m: f64| (m * 100.0).round().clamp(0.0, f64::from(u16::MAX)) as u16;
    let max_distance = cm(sample.max_range_m);
    DISTANCE_SENSOR_DATA {
        time_boot_ms: (sample.time.as_micros() / 1000) as u32,
        min_distance: cm(sample.min_range_m),
        max_distance,
        current_distance: sample.distance_m.map_or(max_distance.saturating_add(OUT_OF_RANGE_ADD_CM), cm),
        mavtype: MavDistanceSensor::MAV_DISTANCE_SENSOR_LASER,
        id: distance_sensor_id(sample.orientation),
        orientation: match sample.orientation {
            RangefinderOrientation::Up => MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_90,
            RangefinderOrientation::Down => MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_270,
        },
        covariance: u8::MAX,
        ..Default::default()
    }
}

/// The telemetry scheduler and message builder.
#[derive(Debug)]
pub struct Telemetry {
    streams: Vec<Stream>,
    pub snapshot: Snapshot,
    /// Whether a refused sample of each rangefinder (by [`distance_sensor_id`]) was logged: a
    /// broken sensor at 100 Hz must not flood the log.
    rangefinder_refusal_logged: [bool; 2],
}

impl Default for Telemetry {
    fn default() -> Self {
        Telemetry {
            streams: default_streams(),
            snapshot: Snapshot::default(),
            rangefinder_refusal_logged: [false; 2],
        }
    }
}

impl Telemetry {
    /// Default streams, no state yet.
    pub fn new() -> Telemetry {
        Telemetry::default()
    }

    /// The interval of message `id` (`None`: not streamed).
    pub fn interval(&self, id: u32) -> Option<Duration> {
        self.streams.iter().find(|s| s.id == id).and_then(|s| s.interval)
    }

    /// MAV_CMD_SET_MESSAGE_INTERVAL: `interval_us` -1 stops, 0 restores the default, > 0 sets.
    pub fn set_interval(&mut self, id: f64, interval_us: f64, now: Time) -> MavResult {
        let Some(s) = self.streams.iter_mut().find(|s| f64::from(s.id) == id) else {
            return MavResult::MAV_RESULT_UNSUPPORTED;
        };
        s.interval = match interval_us {
            -1.0 => None,
            0.0 => s.default,
            // Faster than 50 Hz is more than the scheduler's tick can honour.
            x if x.is_finite() && x >= 20_000.0 => Some(Duration::from_micros(x as u64)),
            _ => return MavResult::MAV_RESULT_DENIED,
        };
        s.next = now;
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// REQUEST_DATA_STREAM, mapped onto our messages as ArduPilot groups them.
    pub fn request_data_stream(&mut self, stream: MavDataStream, rate_hz: u16, start: bool, now: Time) {
        let ids: &[u32] = match stream {
            MavDataStream::MAV_DATA_STREAM_ALL => &[
                SYS_STATUS_DATA::ID,
                GPS_RAW_INT_DATA::ID,
                MISSION_CURRENT_DATA::ID,
                GLOBAL_POSITION_INT_DATA::ID,
                LOCAL_POSITION_NED_DATA::ID,
                ATTITUDE_DATA::ID,
                VFR_HUD_DATA::ID,
                BATTERY_STATUS_DATA::ID,
                EXTENDED_SYS_STATE_DATA::ID,
            ],
            MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS => {
                &[SYS_STATUS_DATA::ID, GPS_RAW_INT_DATA::ID, MISSION_CURRENT_DATA::ID]
            }
            MavDataStream::MAV_DATA_STREAM_POSITION => {
                &[GLOBAL_POSITION_INT_DATA::ID, LOCAL_POSITION_NED_DATA::ID]
            }
            MavDataStream::MAV_DATA_STREAM_EXTRA1 => &[ATTITUDE_DATA::ID, SIMSTATE_DATA::ID],
            MavDataStream::MAV_DATA_STREAM_EXTRA2 => &[VFR_HUD_DATA::ID],
            MavDataStream::MAV_DATA_STREAM_EXTRA3 => &[
                BATTERY_STATUS_DATA::ID,
                EXTENDED_SYS_STATE_DATA::ID,
                WIND_DATA::ID,
                DISTANCE_SENSOR_DATA::ID,
            ],
            _ => &[],
        };
        let interval = (start && rate_hz > 0).then(|| hz(f64::from(rate_hz.min(50)))).flatten();
        for s in self.streams.iter_mut().filter(|s| ids.contains(&s.id)) {
            s.interval = interval;
            s.next = now;
        }
    }

    /// Every stream message due at `now`.
    pub fn due(&mut self, now: Time) -> Vec<MavMessage> {
        let mut due = Vec::new();
        for i in 0..self.streams.len() {
            let s = self.streams[i];
            let Some(interval) = s.interval else { continue };
            if now < s.next {
                continue;
            }
            // Keep the cadence; after a stall, restart from now rather than bursting.
            let next = s.next + interval;
            self.streams[i].next = if next <= now { now + interval } else { next };
            if s.id == DISTANCE_SENSOR_DATA::ID {
                due.extend(self.distance_sensors(now));
            } else {
                due.extend(self.build(s.id, now));
            }
        }
        due
    }

    /// A rangefinder's newest sample, kept for DISTANCE_SENSOR; one that cannot be used is
    /// dropped, and logged the first time for each sensor.
    pub fn on_rangefinder(&mut self, sample: RangefinderSample) {
        let id = usize::from(distance_sensor_id(sample.orientation));
        match sample.invalid() {
            None => self.snapshot.rangefinders[id] = Some(sample),
            Some(why) => {
                if !std::mem::replace(&mut self.rangefinder_refusal_logged[id], true) {
                    tracing::warn!(
                        orientation = ?sample.orientation,
                        "rangefinder sample refused, not sent to the ground station: {why} (further refusals are not logged)"
                    );
                }
            }
        }
    }

    /// DISTANCE_SENSOR for every rangefinder whose newest sample is fresh at `now`, down first.
    fn distance_sensors(&self, now: Time) -> impl Iterator<Item = MavMessage> + '_ {
        self.snapshot
            .rangefinders
            .iter()
            .flatten()
            .filter(move |s| now.saturating_since(s.time) <= RANGEFINDER_STALE)
            .map(|s| MavMessage::DISTANCE_SENSOR(distance_sensor(s)))
    }

    /// Message `id` from the latest state (`None`: not ours, or nothing known yet).
    pub fn build(&self, id: u32, now: Time) -> Option<MavMessage> {
        let snap = &self.snapshot;
        let boot_ms = (now.as_micros() / 1000) as u32;
        Some(match id {
            SYS_STATUS_DATA::ID => MavMessage::SYS_STATUS(self.sys_status()),
            EKF_STATUS_REPORT_DATA::ID => {
                MavMessage::EKF_STATUS_REPORT(ekf_status(snap.nav.as_ref()?, snap.estimator.as_ref()))
            }
            ATTITUDE_DATA::ID => {
                let nav = snap.nav.as_ref()?;
                let [roll, pitch, yaw] = euler_rad(nav.attitude);
                let [p, q, r] = nav.angular_velocity_rad_s;
                MavMessage::ATTITUDE(ATTITUDE_DATA {
                    time_boot_ms: boot_ms,
                    roll: roll as f32,
                    pitch: pitch as f32,
                    yaw: yaw as f32,
                    rollspeed: p as f32,
                    pitchspeed: q as f32,
                    yawspeed: r as f32,
                })
            }
            SIMSTATE_DATA::ID => MavMessage::SIMSTATE(simstate(snap.truth.as_ref()?)?),
            // Asked for once (MAV_CMD_REQUEST_MESSAGE): the first fresh one, down before up.
            DISTANCE_SENSOR_DATA::ID => self.distance_sensors(now).next()?,
            WIND_DATA::ID => MavMessage::WIND(wind(snap.estimator.as_ref()?.wind_ne_m_s?)),
            LOCAL_POSITION_NED_DATA::ID => {
                let nav = snap.nav.as_ref()?;
                let [x, y, z] = nav.position_ned_m.map(|v| v as f32);
                let [vx, vy, vz] = nav.velocity_ned_m_s.map(|v| v as f32);
                MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                    time_boot_ms: boot_ms,
                    x,
                    y,
                    z,
                    vx,
                    vy,
                    vz,
                })
            }
            GLOBAL_POSITION_INT_DATA::ID => {
                let nav = snap.nav.as_ref()?;
                let home = nav.origin?;
                let p = LocalFrame::new(home).to_geodetic(nav.position_ned_m);
                let v = nav.velocity_ned_m_s;
                MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: boot_ms,
                    lat: deg_e7(p.lat_deg),
                    lon: deg_e7(p.lon_deg),
                    alt: (p.alt_m * 1000.0).round() as i32,
                    relative_alt: (-nav.position_ned_m[2] * 1000.0).round() as i32,
                    vx: (v[0] * 100.0).round() as i16,
                    vy: (v[1] * 100.0).round() as i16,
                    vz: (v[2] * 100.0).round() as i16,
                    hdg: heading_cdeg(nav.attitude),
                })
            }
            GPS_RAW_INT_DATA::ID => MavMessage::GPS_RAW_INT(gps_raw(snap.gps.as_ref()?)),
            VFR_HUD_DATA::ID => {
                let nav = snap.nav.as_ref()?;
                let v = nav.velocity_ned_m_s;
                let alt = nav.origin.map_or(-nav.position_ned_m[2], |o| o.alt_m - nav.position_ned_m[2]);
                MavMessage::VFR_HUD(VFR_HUD_DATA {
                    airspeed: v[0].hypot(v[1]) as f32,
                    groundspeed: v[0].hypot(v[1]) as f32,
                    alt: alt as f32,
                    climb: -v[2] as f32,
                    heading: (heading_cdeg(nav.attitude) / 100) as i16,
                    throttle: 0,
                })
            }
            BATTERY_STATUS_DATA::ID => {
                let b = snap.battery.as_ref()?;
                let mut voltages = [u16::MAX; 10];
                voltages[0] = (b.voltage_v * 1000.0).clamp(0.0, 65_534.0) as u16;
                MavMessage::BATTERY_STATUS(BATTERY_STATUS_DATA {
                    current_consumed: b.consumed_mah.round() as i32,
                    energy_consumed: -1,
                    temperature: i16::MAX,
                    voltages,
                    current_battery: (b.current_a * 100.0).round() as i16,
                    battery_function: MavBatteryFunction::MAV_BATTERY_FUNCTION_ALL,
                    mavtype: MavBatteryType::MAV_BATTERY_TYPE_LIPO,
                    battery_remaining: (b.remaining * 100.0).round().clamp(0.0, 100.0) as i8,
                    ..Default::default()
                })
            }
            HOME_POSITION_DATA::ID => {
                // The commander's home (set at arming or by DO_SET_HOME); before it has one,
                // the estimator's origin, where the vehicle started.
                let origin = snap.nav.as_ref()?.origin?;
                let [n, e, d] =
                    snap.status.as_ref().and_then(|s| s.home).map_or([0.0; 3], |h| h.position_ned_m);
                let home = LocalFrame::new(origin).to_geodetic([n, e, 0.0]);
                MavMessage::HOME_POSITION(HOME_POSITION_DATA {
                    latitude: deg_e7(home.lat_deg),
                    longitude: deg_e7(home.lon_deg),
                    // One altitude convention with the mission's: down is height below the origin.
                    altitude: ((origin.alt_m - d) * 1000.0).round() as i32,
                    x: n as f32,
                    y: e as f32,
                    z: d as f32,
                    q: [1.0, 0.0, 0.0, 0.0],
                    time_usec: now.as_micros(),
                    ..Default::default()
                })
            }
            EXTENDED_SYS_STATE_DATA::ID => {
                let s = snap.status.as_ref()?;
                MavMessage::EXTENDED_SYS_STATE(EXTENDED_SYS_STATE_DATA {
                    vtol_state: MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                    landed_state: match s.landed {
                        LandedState::OnGround => MavLandedState::MAV_LANDED_STATE_ON_GROUND,
                        LandedState::InAir => MavLandedState::MAV_LANDED_STATE_IN_AIR,
                        LandedState::Landing => MavLandedState::MAV_LANDED_STATE_LANDING,
                    },
                })
            }
            MISSION_CURRENT_DATA::ID => {
                let progress = snap.status.as_ref().map(|s| s.mission).unwrap_or_default();
                let state = match (snap.mission_items, progress) {
                    (0, _) => MissionState::MISSION_STATE_NO_MISSION,
                    (_, p) if p.completed => MissionState::MISSION_STATE_COMPLETE,
                    (_, p)
                        if p.reached > 0
                            || snap
                                .status
                                .as_ref()
                                .is_some_and(|s| s.mode == kestrel_proto::messages::FlightMode::Auto) =>
                    {
                        MissionState::MISSION_STATE_ACTIVE
                    }
                    _ => MissionState::MISSION_STATE_NOT_STARTED,
                };
                // Item 0 is home: the commander's item i is our item i + 1. As the message
                // defines it (and ArduPilot sends it), `total` excludes home so that the last
                // item has `seq == total`, and is UINT16_MAX when no mission is stored; a
                // finished mission stays on its last item rather than one past it.
                let total = snap.mission_items.checked_sub(1).unwrap_or(u16::MAX);
                let seq = match snap.mission_items {
                    0 => 0,
                    _ => u16::try_from(progress.current + 1).unwrap_or(u16::MAX).min(total),
                };
                MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
                    seq,
                    total,
                    mission_state: state,
                    ..Default::default()
                })
            }
            OBSTACLE_DISTANCE_DATA::ID => {
                let d = snap.depth.as_ref()?;
                let mut distances = [u16::MAX; OBSTACLE_SECTORS];
                for (out, v) in distances.iter_mut().zip(&d.sectors.distances_cm) {
                    *out = *v;
                }
                MavMessage::OBSTACLE_DISTANCE(OBSTACLE_DISTANCE_DATA {
                    time_usec: d.time.as_micros(),
                    distances,
                    min_distance: d.sectors.min_distance_cm,
                    max_distance: d.sectors.max_distance_cm,
                    sensor_type: MavDistanceSensor::MAV_DISTANCE_SENSOR_UNKNOWN,
                    increment: 0,
                    increment_f: d.sectors.increment_deg,
                    angle_offset: d.sectors.angle_offset_deg,
                    frame: MavFrame::MAV_FRAME_BODY_FRD,
                })
            }
            DEBUG_VECT_DATA::ID => {
                // The avoider's correction as ground stations graph it (QGroundControl's
                // MAVLink inspector, MAVProxy's `graph DEBUG_VECT.x`): x forward, y right,
                // z down (m/s, body FRD), stamped with its depth grid's capture time.
                let a = snap.avoidance.as_ref()?;
                let [x, y, z] = a.velocity_frd_m_s.map(|v| v as f32);
                let mut name = [0u8; 10];
                name[..AVOIDANCE_VECT_NAME.len()].copy_from_slice(AVOIDANCE_VECT_NAME.as_bytes());
                MavMessage::DEBUG_VECT(DEBUG_VECT_DATA {
                    time_usec: a.time.as_micros(),
                    x,
                    y,
                    z,
                    name: name.into(),
                })
            }
            _ => return None,
        })
    }

    /// SYS_STATUS: what is present and healthy, as ArduPilot reports it — the IMU, compass and
    /// AHRS healthy once the attitude estimate is, the barometer and GPS once their parts of
    /// the position are, the battery once reported, the depth camera once a grid came, and the
    /// pre-arm bit while the commander's pre-arm checks pass (MAVSDK's `is_armable`), and the
    /// motor outputs unhealthy once a motor was declared failed.
    fn sys_status(&self) -> SYS_STATUS_DATA {
        type S = MavSysStatusSensor;
        let snap = &self.snapshot;
        let mut present = S::MAV_SYS_STATUS_SENSOR_3D_GYRO
            | S::MAV_SYS_STATUS_SENSOR_3D_ACCEL
            | S::MAV_SYS_STATUS_SENSOR_3D_MAG
            | S::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
            | S::MAV_SYS_STATUS_SENSOR_GPS
            | S::MAV_SYS_STATUS_AHRS
            | S::MAV_SYS_STATUS_PREARM_CHECK;
        let mut health = S::empty();
        if let Some(v) = snap.nav.as_ref().map(|n| n.valid) {
            if v.attitude {
                health |= S::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | S::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | S::MAV_SYS_STATUS_SENSOR_3D_MAG
                    | S::MAV_SYS_STATUS_AHRS;
            }
            if v.vertical_position {
                health |= S::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE;
            }
            if v.horizontal_position {
                health |= S::MAV_SYS_STATUS_SENSOR_GPS;
            }
        }
        if snap.battery.is_some() {
            present |= S::MAV_SYS_STATUS_SENSOR_BATTERY;
            health |= S::MAV_SYS_STATUS_SENSOR_BATTERY;
        }
        if snap.depth.is_some() {
            present |= S::MAV_SYS_STATUS_SENSOR_PROXIMITY;
            health |= S::MAV_SYS_STATUS_SENSOR_PROXIMITY;
        }
        if snap.status.as_ref().is_some_and(|s| s.armable || s.armed) {
            health |= S::MAV_SYS_STATUS_PREARM_CHECK;
        }
        // The geofence: enabled as switched, healthy unless breached (MAVProxy says "fence
        // breach" when the bit is present and enabled but not healthy).
        present |= S::MAV_SYS_STATUS_GEOFENCE | S::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
        if snap.status.as_ref().is_none_or(|s| s.failed_motor.is_none()) {
            health |= S::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
        }
        let mut enabled = present;
        if let Some(s) = &snap.status {
            if !s.geofence_enabled {
                enabled.remove(S::MAV_SYS_STATUS_GEOFENCE);
            }
            if s.failsafe.is_none_or(|f| f.cause != FailsafeCause::GeofenceBreach) {
                health |= S::MAV_SYS_STATUS_GEOFENCE;
            }
        }
        let (voltage, current, remaining) = snap.battery.as_ref().map_or((u16::MAX, -1, -1), |b| {
            (
                (b.voltage_v * 1000.0).clamp(0.0, 65_534.0) as u16,
                (b.current_a * 100.0).round() as i16,
                (b.remaining * 100.0).round().clamp(0.0, 100.0) as i8,
            )
        });
        SYS_STATUS_DATA {
            onboard_control_sensors_present: present,
            onboard_control_sensors_enabled: enabled,
            onboard_control_sensors_health: health,
            voltage_battery: voltage,
            current_battery: current,
            battery_remaining: remaining,
            ..Default::default()
        }
    }
}

/// EKF_STATUS_REPORT as ArduPilot fills it: flags for what the estimate is good for, from the
/// NavState's validity, and "variances" that are the square roots of the innovation test ratios
/// (below 1 the observations pass their gates; ground stations turn the bars amber at 0.5 and
/// red at 0.8), the largest of each group, 0 until the estimator reports any.
fn ekf_status(nav: &NavState, estimator: Option<&EstimatorStatus>) -> EKF_STATUS_REPORT_DATA {
    type F = EkfStatusFlags;
    let v = nav.valid;
    let mut flags = F::empty();
    for (good, flag) in [
        (v.attitude, F::EKF_ATTITUDE),
        (v.horizontal_velocity, F::EKF_VELOCITY_HORIZ),
        (v.vertical_velocity, F::EKF_VELOCITY_VERT),
        (v.horizontal_position, F::EKF_POS_HORIZ_REL | F::EKF_PRED_POS_HORIZ_REL),
        (v.horizontal_position && nav.origin.is_some(), F::EKF_POS_HORIZ_ABS | F::EKF_PRED_POS_HORIZ_ABS),
        (v.vertical_position, F::EKF_POS_VERT_ABS),
    ] {
        if good {
            flags |= flag;
        }
    }
    if v.attitude && !v.horizontal_position {
        flags |= F::EKF_CONST_POS_MODE;
    }
    if !v.attitude {
        flags |= F::EKF_UNINITIALIZED;
    }
    let root = |ratios: &[Innovation]| ratios.iter().map(|i| i.test_ratio).fold(0.0, f64::max).sqrt() as f32;
    let (velocity, horizontal, vertical, compass) = estimator.map_or((0.0, 0.0, 0.0, 0.0), |e| {
        (root(&e.gps_velocity_ned), root(&e.gps_position_ne), root(&[e.baro_height]), root(&e.mag_field))
    });
    EKF_STATUS_REPORT_DATA {
        velocity_variance: velocity,
        pos_horiz_variance: horizontal,
        pos_vert_variance: vertical,
        compass_variance: compass,
        terrain_alt_variance: 0.0,
        flags,
        airspeed_variance: 0.0,
    }
}

fn heading_cdeg(q: [f64; 4]) -> u16 {
    let yaw_deg = euler_rad(q)[2].to_degrees().rem_euclid(360.0);
    ((yaw_deg * 100.0).round() as u16) % 36_000
}

fn gps_raw(g: &GpsFix) -> GPS_RAW_INT_DATA {
    let v = g.vel_ned_m_s;
    let speed = v[0].hypot(v[1]);
    GPS_RAW_INT_DATA {
        time_usec: g.time.as_micros(),
        lat: deg_e7(g.lat_deg),
        lon: deg_e7(g.lon_deg),
        alt: (g.alt_msl_m * 1000.0).round() as i32,
        eph: (g.h_acc_m * 100.0).clamp(0.0, 65_534.0) as u16,
        epv: (g.v_acc_m * 100.0).clamp(0.0, 65_534.0) as u16,
        vel: (speed * 100.0).clamp(0.0, 65_534.0) as u16,
        cog: ((v[1].atan2(v[0]).to_degrees().rem_euclid(360.0) * 100.0) as u16) % 36_000,
        fix_type: match g.fix_type {
            GpsFixType::NoFix => MavFix::GPS_FIX_TYPE_NO_FIX,
            GpsFixType::Fix2d => MavFix::GPS_FIX_TYPE_2D_FIX,
            GpsFixType::Fix3d => MavFix::GPS_FIX_TYPE_3D_FIX,
            GpsFixType::Dgps => MavFix::GPS_FIX_TYPE_DGPS,
            GpsFixType::RtkFloat => MavFix::GPS_FIX_TYPE_RTK_FLOAT,
            GpsFixType::RtkFixed => MavFix::GPS_FIX_TYPE_RTK_FIXED,
        },
        satellites_visible: g.satellites,
        h_acc: (g.h_acc_m * 1000.0) as u32,
        v_acc: (g.v_acc_m * 1000.0) as u32,
        vel_acc: (g.s_acc_m_s * 1000.0) as u32,
        ..Default::default()
    }
}

impl Telemetry {
    /// MISSION_CURRENT now, when the commander already shows item `index` current: the spec
    /// wants one after every set-current request, changed or not (a change sends its own when
    /// the status shows it).
    pub fn mission_current_if_shown(&self, index: u32) -> Option<MavMessage> {
        let shown = self.snapshot.status.as_ref().is_some_and(|s| s.mission.current == index);
        shown.then(|| self.build(MISSION_CURRENT_DATA::ID, Time::ZERO)).flatten()
    }
}

/// Where home is, if the estimator has anchored its frame.
pub fn home(snapshot: &Snapshot) -> Option<Geodetic> {
    snapshot.nav.as_ref().and_then(|n| n.origin)
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::NavValidity;

    use super::*;

    fn nav() -> NavState {
        let half = (std::f64::consts::FRAC_PI_2 / 2.0, 0.0);
        NavState {
            time: Time::ZERO,
            attitude: [half.0.cos(), 0.0, 0.0, half.0.sin()],
            angular_velocity_rad_s: [0.0; 3],
            velocity_ned_m_s: [1.0, 0.0, -0.5],
            position_ned_m: [10.0, 0.0, -30.0],
            gyro_bias_rad_s: [0.0; 3],
            accel_bias_m_s2: [0.0; 3],
            covariance_diagonal: [0.0; 16],
            origin: Some(Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 }),
            valid: NavValidity { attitude: true, ..Default::default() },
        }
    }

    #[test]
    fn the_avoiders_correction_goes_out_as_debug_vect_at_5_hz() {
        let mut t = Telemetry::new();
        let count = |t: &mut Telemetry, from_ms: u64| {
            (from_ms..from_ms + 1000)
                .step_by(20)
                .flat_map(|ms| t.due(Time::from_micros(ms * 1000)))
                .filter_map(|m| match m {
                    MavMessage::DEBUG_VECT(d) => Some(d),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        assert!(count(&mut t, 0).is_empty(), "nothing before the avoider speaks");
        t.snapshot.avoidance = Some(AvoidanceCommand {
            time: Time::from_micros(123),
            velocity_frd_m_s: [-1.5, 0.5, -0.25],
            ..AvoidanceCommand::default()
        });
        let sent = count(&mut t, 1000);
        assert_eq!(sent.len(), 5);
        let d = &sent[0];
        assert_eq!((d.x, d.y, d.z, d.time_usec), (-1.5, 0.5, -0.25, 123));
        assert_eq!(&d.name.to_str().expect("ascii").trim_end_matches('\0'), &AVOIDANCE_VECT_NAME);
    }

    #[test]
    fn rangefinder_samples_become_distance_sensor_in_centimetres_at_10_hz() {
        let sample = |orientation, time_us, distance_m| RangefinderSample {
            time: Time::from_micros(time_us),
            orientation,
            distance_m,
            min_range_m: 0.1,
            max_range_m: 12.0,
        };
        let mut t = Telemetry::new();
        t.on_rangefinder(sample(RangefinderOrientation::Down, 995_000, Some(3.456)));
        // Open sky above: nothing within the 12 m.
        t.on_rangefinder(sample(RangefinderOrientation::Up, 998_000, None));
        let Some(MavMessage::DISTANCE_SENSOR(down)) =
            t.build(DISTANCE_SENSOR_DATA::ID, Time::from_micros(1_000_000))
        else {
            panic!("the downward one first")
        };
        assert_eq!(
            down,
            DISTANCE_SENSOR_DATA {
                time_boot_ms: 995,
                min_distance: 10,
                max_distance: 1200,
                current_distance: 346,
                mavtype: MavDistanceSensor::MAV_DISTANCE_SENSOR_LASER,
                id: 0,
                orientation: MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_270,
                covariance: 255,
                horizontal_fov: 0.0,
                vertical_fov: 0.0,
                quaternion: [0.0; 4],
                signal_quality: 0,
            }
        );
        let sent = |t: &mut Telemetry, from_ms: u64, to_ms: u64| {
            (from_ms..to_ms)
                .step_by(20)
                .flat_map(|ms| t.due(Time::from_micros(ms * 1000)))
                .filter_map(|m| match m {
                    MavMessage::DISTANCE_SENSOR(d) => Some(d),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        // 10 Hz for each, while the samples are younger than 200 ms.
        let fresh = sent(&mut t, 1000, 1200);
        assert_eq!(fresh.len(), 4, "{fresh:?}");
        let up = fresh.iter().find(|d| d.id == 1).expect("the upward one");
        // Out of range high reads 100 cm beyond the maximum, as ArduPilot's TFmini drivers.
        assert_eq!((up.current_distance, up.max_distance, up.time_boot_ms), (1300, 1200, 998));
        assert_eq!(up.orientation, MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_90);
        for o in [RangefinderOrientation::Up, RangefinderOrientation::Down] {
            let mavlink = fresh.iter().find(|d| d.id == distance_sensor_id(o)).expect("both");
            assert_eq!(mavlink.orientation as u8, o.mavlink_rotation(), "{o:?}");
        }
        assert!(sent(&mut t, 1200, 2000).is_empty(), "a sensor quiet for 200 ms is not reported");

        // A sample its own ranges refuse is dropped; the last good one stays.
        t.on_rangefinder(sample(RangefinderOrientation::Down, 2_000_000, Some(3.0)));
        t.on_rangefinder(sample(RangefinderOrientation::Down, 2_010_000, Some(f64::NAN)));
        t.on_rangefinder(sample(RangefinderOrientation::Down, 2_020_000, Some(12.5)));
        let after = sent(&mut t, 2000, 2100);
        assert!(
            after.iter().all(|d| d.id == 0 && d.current_distance == 300 && d.time_boot_ms == 2000),
            "{after:?}"
        );
        assert!(!after.is_empty());
        t.request_data_stream(MavDataStream::MAV_DATA_STREAM_EXTRA3, 2, true, Time::ZERO);
        assert_eq!(
            t.interval(DISTANCE_SENSOR_DATA::ID),
            Some(Duration::from_millis(500)),
            "in EXTRA3, as ArduPilot"
        );
    }

    #[test]
    fn default_rates_and_interval_changes() {
        let mut t = Telemetry::new();
        t.snapshot.nav = Some(nav());
        let count = |t: &mut Telemetry| {
            let mut n = 0;
            for ms in (0..1000).step_by(20) {
                n += t
                    .due(Time::from_micros(ms * 1000))
                    .iter()
                    .filter(|m| matches!(m, MavMessage::ATTITUDE(_)))
                    .count();
            }
            n
        };
        assert_eq!(count(&mut t), 10);
        let mut t = Telemetry::new();
        t.snapshot.nav = Some(nav());
        assert_eq!(
            t.set_interval(f64::from(ATTITUDE_DATA::ID), 50_000.0, Time::ZERO),
            MavResult::MAV_RESULT_ACCEPTED
        );
        assert_eq!(count(&mut t), 20);
        assert_eq!(
            t.set_interval(f64::from(ATTITUDE_DATA::ID), -1.0, Time::ZERO),
            MavResult::MAV_RESULT_ACCEPTED
        );
        assert_eq!(t.interval(ATTITUDE_DATA::ID), None);
        assert_eq!(
            t.set_interval(f64::from(ATTITUDE_DATA::ID), 0.0, Time::ZERO),
            MavResult::MAV_RESULT_ACCEPTED
        );
        assert_eq!(t.interval(ATTITUDE_DATA::ID), Some(Duration::from_millis(100)));
        assert_eq!(t.set_interval(9999.0, 1.0, Time::ZERO), MavResult::MAV_RESULT_UNSUPPORTED);
        t.request_data_stream(MavDataStream::MAV_DATA_STREAM_EXTRA1, 2, true, Time::ZERO);
        assert_eq!(t.interval(ATTITUDE_DATA::ID), Some(Duration::from_millis(500)));
    }

    #[test]
    fn messages_carry_the_state_in_mavlink_units() {
        let mut t = Telemetry::new();
        t.snapshot.nav = Some(nav());
        let Some(MavMessage::GLOBAL_POSITION_INT(g)) = t.build(GLOBAL_POSITION_INT_DATA::ID, Time::ZERO)
        else {
            panic!()
        };
        assert_eq!(g.relative_alt, 30_000);
        assert_eq!(g.alt, 50_000);
        assert_eq!(g.hdg, 9_000, "facing east");
        assert!((f64::from(g.lat) * 1e-7 - 6.79710 - 10.0 / 110_600.0).abs() < 1e-5, "{}", g.lat);
        let Some(MavMessage::ATTITUDE(a)) = t.build(ATTITUDE_DATA::ID, Time::ZERO) else { panic!() };
        assert!((f64::from(a.yaw) - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
        assert!(t.build(GPS_RAW_INT_DATA::ID, Time::ZERO).is_none(), "no fix yet, nothing to send");
    }

    #[test]
    fn wind_says_where_the_learnt_wind_blows_from_once_there_is_one() {
        let mut t = Telemetry::new();
        t.snapshot.estimator = Some(EstimatorStatus::default());
        assert!(t.build(WIND_DATA::ID, Time::ZERO).is_none(), "no wind learnt, no WIND");
        for (ne, from_deg) in
            [([0.0, 1.0], 270.0), ([-2.0, 0.0], 0.0), ([1.0, 1.0], 225.0), ([0.0, -3.0], 90.0)]
        {
            t.snapshot.estimator =
                Some(EstimatorStatus { wind_ne_m_s: Some(ne), ..EstimatorStatus::default() });
            let Some(MavMessage::WIND(w)) = t.build(WIND_DATA::ID, Time::ZERO) else { panic!() };
            assert!((f64::from(w.direction) - from_deg).abs() < 1e-4, "{ne:?}: {w:?}");
            assert!((f64::from(w.speed) - ne[0].hypot(ne[1])).abs() < 1e-6, "{ne:?}: {w:?}");
        }
        assert_eq!(t.interval(WIND_DATA::ID), Some(Duration::from_secs(1)));
    }

    #[test]
    fn simstate_carries_the_simulators_truth_and_only_when_there_is_one() {
        let mut t = Telemetry::new();
        assert!(t.build(SIMSTATE_DATA::ID, Time::ZERO).is_none(), "no truth on hardware, no SIMSTATE");
        let half = std::f64::consts::FRAC_PI_4;
        t.snapshot.truth = Some(GroundTruth {
            // Facing east, climbing at 1 m/s² (up is −down), turning right at 0.1 rad/s.
            attitude: [half.cos(), 0.0, 0.0, half.sin()],
            acceleration_ned_m_s2: [0.0, 0.0, -1.0],
            angular_velocity_rad_s: [0.0, 0.0, 0.1],
            lat_deg: 6.7971,
            lon_deg: 79.9017,
            ..GroundTruth::default()
        });
        let Some(MavMessage::SIMSTATE(s)) = t.build(SIMSTATE_DATA::ID, Time::ZERO) else { panic!() };
        assert!((f64::from(s.yaw) - std::f64::consts::FRAC_PI_2).abs() < 1e-6, "{s:?}");
        assert!(s.roll.abs() < 1e-6 && s.pitch.abs() < 1e-6, "{s:?}");
        // An accelerometer at rest reads −g on its down axis; climbing adds to it.
        assert!((f64::from(s.zacc) + GRAVITY_M_S2 + 1.0).abs() < 1e-5, "{s:?}");
        assert!(s.xacc.abs() < 1e-5 && s.yacc.abs() < 1e-5, "{s:?}");
        assert_eq!((s.zgyro, s.lat, s.lng), (0.1, 67_971_000, 799_017_000));
        assert_eq!(t.interval(SIMSTATE_DATA::ID), Some(Duration::from_millis(100)));
        t.request_data_stream(MavDataStream::MAV_DATA_STREAM_EXTRA1, 4, true, Time::ZERO);
        assert_eq!(
            t.interval(SIMSTATE_DATA::ID),
            Some(Duration::from_millis(250)),
            "in EXTRA1, as ArduPilot"
        );
    }

    #[test]
    fn home_position_follows_the_commanders_home() {
        use kestrel_proto::messages::{FlightMode, Home, LandedState};
        use kestrel_proto::testing::vehicle_status;
        let mut t = Telemetry::new();
        t.snapshot.nav = Some(nav());
        let home = |t: &Telemetry| match t.build(HOME_POSITION_DATA::ID, Time::ZERO) {
            Some(MavMessage::HOME_POSITION(h)) => h,
            other => panic!("{other:?}"),
        };
        let origin = home(&t);
        assert_eq!((origin.latitude, origin.longitude, origin.altitude), (67_971_000, 799_017_000, 20_000));
        t.snapshot.status = Some(VehicleStatus {
            home: Some(Home { position_ned_m: [110.6, 0.0, -5.0], revision: 2 }),
            ..vehicle_status(Time::ZERO, true, FlightMode::PosHold, LandedState::InAir)
        });
        let moved = home(&t);
        assert!((moved.latitude - 67_981_000).abs() < 20, "{}", moved.latitude);
        assert_eq!((moved.longitude, moved.altitude), (799_017_000, 25_000));
        assert_eq!((moved.x, moved.y, moved.z), (110.6, 0.0, -5.0));
    }

    #[test]
    fn sys_status_shows_the_motor_outputs_unhealthy_once_a_motor_failed() {
        use kestrel_proto::messages::{FlightMode, LandedState};
        use kestrel_proto::testing::vehicle_status;
        type S = MavSysStatusSensor;
        let mut t = Telemetry::new();
        let status = |failed_motor| VehicleStatus {
            failed_motor,
            ..vehicle_status(Time::ZERO, true, FlightMode::Auto, LandedState::InAir)
        };
        let motors = S::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
        t.snapshot.status = Some(status(None));
        let healthy = t.sys_status();
        assert!(healthy.onboard_control_sensors_present.contains(motors));
        assert!(healthy.onboard_control_sensors_health.contains(motors));
        t.snapshot.status = Some(status(Some(2)));
        assert!(!t.sys_status().onboard_control_sensors_health.contains(motors));
    }

    #[test]
    fn mission_current_counts_items_after_home_and_never_points_past_the_last() {
        use kestrel_proto::messages::{FlightMode, LandedState, MissionProgress};
        use kestrel_proto::testing::vehicle_status;
        let mut t = Telemetry::new();
        let current = |t: &Telemetry| match t.build(MISSION_CURRENT_DATA::ID, Time::ZERO) {
            Some(MavMessage::MISSION_CURRENT(m)) => (m.seq, m.total, m.mission_state),
            other => panic!("{other:?}"),
        };
        assert_eq!(current(&t), (0, u16::MAX, MissionState::MISSION_STATE_NO_MISSION));
        t.snapshot.mission_items = 7; // home, take-off, four waypoints, RTL
        let status = |current, reached| VehicleStatus {
            mission: MissionProgress {
                current,
                reached,
                last_reached: reached.checked_sub(1),
                total: 6,
                completed: reached >= 6,
            },
            ..vehicle_status(Time::ZERO, true, FlightMode::Auto, LandedState::InAir)
        };
        t.snapshot.status = Some(status(0, 0));
        assert_eq!(current(&t), (1, 6, MissionState::MISSION_STATE_ACTIVE));
        t.snapshot.status = Some(status(6, 6));
        assert_eq!(current(&t), (6, 6, MissionState::MISSION_STATE_COMPLETE), "finished: on the last item");
    }

    #[test]
    fn ekf_status_report_flags_what_the_estimate_is_good_for_and_roots_the_test_ratios() {
        let mut good = nav();
        good.valid = NavValidity::ALL;
        let report = ekf_status(&good, None);
        assert!(report.flags.contains(
            EkfStatusFlags::EKF_ATTITUDE
                | EkfStatusFlags::EKF_VELOCITY_HORIZ
                | EkfStatusFlags::EKF_POS_HORIZ_ABS
                | EkfStatusFlags::EKF_PRED_POS_HORIZ_ABS
                | EkfStatusFlags::EKF_POS_VERT_ABS
        ));
        assert!(
            !report.flags.intersects(EkfStatusFlags::EKF_CONST_POS_MODE | EkfStatusFlags::EKF_UNINITIALIZED)
        );
        let ratio = |r| Innovation { innovation: 0.0, variance: 1.0, test_ratio: r };
        let status = EstimatorStatus {
            gps_position_ne: [ratio(0.25), ratio(0.04)],
            gps_velocity_ned: [ratio(0.0), ratio(0.81), ratio(0.0)],
            baro_height: ratio(1.44),
            mag_field: [ratio(0.09); 3],
            ..EstimatorStatus::default()
        };
        let report = ekf_status(&good, Some(&status));
        let near = |a: f32, b: f32| (a - b).abs() < 1e-6;
        assert!(near(report.pos_horiz_variance, 0.5) && near(report.velocity_variance, 0.9), "{report:?}");
        assert!(near(report.pos_vert_variance, 1.2) && near(report.compass_variance, 0.3), "{report:?}");
        let mut lost = good.clone();
        lost.valid.horizontal_position = false;
        let report = ekf_status(&lost, None);
        assert!(report.flags.contains(EkfStatusFlags::EKF_CONST_POS_MODE));
        assert!(
            !report.flags.intersects(EkfStatusFlags::EKF_POS_HORIZ_ABS | EkfStatusFlags::EKF_POS_HORIZ_REL)
        );
    }
}
