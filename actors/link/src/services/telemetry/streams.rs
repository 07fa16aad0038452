//! When each telemetry message goes out: its default rate, the rate a ground station asked for
//! (MAV_CMD_SET_MESSAGE_INTERVAL, legacy REQUEST_DATA_STREAM), and the cadence that keeps it.
//! What goes into a message is `encode`'s business.
#![allow(
    deprecated,
    reason = "legacy REQUEST_DATA_STREAM is still spoken by ground stations and must be accepted"
)]

use std::time::Duration;

use kestrel_proto::Time;
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::{
    ATTITUDE_DATA, ATTITUDE_QUATERNION_DATA, BATTERY_STATUS_DATA, DEBUG_VECT_DATA, DISTANCE_SENSOR_DATA,
    EKF_STATUS_REPORT_DATA, EXTENDED_SYS_STATE_DATA, FENCE_STATUS_DATA, GLOBAL_POSITION_INT_DATA,
    GPS_RAW_INT_DATA, HIGHRES_IMU_DATA, HOME_POSITION_DATA, LOCAL_POSITION_NED_DATA, MISSION_CURRENT_DATA,
    MavDataStream, MavResult, NAV_CONTROLLER_OUTPUT_DATA, OBSTACLE_DISTANCE_DATA, ODOMETRY_DATA,
    POSITION_TARGET_GLOBAL_INT_DATA, POSITION_TARGET_LOCAL_NED_DATA, RAW_IMU_DATA, RC_CHANNELS_DATA,
    SCALED_IMU_DATA, SCALED_PRESSURE_DATA, SERVO_OUTPUT_RAW_DATA, SIMSTATE_DATA, SYS_STATUS_DATA,
    SYSTEM_TIME_DATA, VFR_HUD_DATA, WIND_DATA,
};

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
        // While the fence is on, in ArduCopter's EXTENDED_STATUS group beside SYS_STATUS.
        (FENCE_STATUS_DATA::ID, hz(1.0)),
        (OBSTACLE_DISTANCE_DATA::ID, hz(5.0)),
        (DEBUG_VECT_DATA::ID, hz(5.0)),
        // One per rangefinder with a fresh sample (down, up): the rangefinders sample at tens of
        // Hz, a ground station's readout needs no more than this.
        (DISTANCE_SENSOR_DATA::ID, hz(10.0)),
        // Only while the graph has a simulator's ground truth, as ArduPilot SITL sends it.
        (SIMSTATE_DATA::ID, hz(10.0)),
        // ArduCopter's RAW_SENSORS, RC_CHANNELS and EXTRA3 members at the 4 Hz MAVProxy and
        // QGroundControl ask it for (`tests/gcs_telemetry_frames.rs` measures both).
        (RAW_IMU_DATA::ID, hz(4.0)),
        (SCALED_PRESSURE_DATA::ID, hz(4.0)),
        (SERVO_OUTPUT_RAW_DATA::ID, hz(4.0)),
        // While sticks come (a receiver or MANUAL_CONTROL), as ArduCopter's RC_CHANNELS member.
        (RC_CHANNELS_DATA::ID, hz(4.0)),
        (SYSTEM_TIME_DATA::ID, hz(4.0)),
        // ArduCopter's EXTENDED_STATUS members: what the commander steers to (its setpoint).
        (NAV_CONTROLLER_OUTPUT_DATA::ID, hz(4.0)),
        (POSITION_TARGET_GLOBAL_INT_DATA::ID, hz(4.0)),
        // In GUIDED only, as ArduCopter sends it: what a companion computer's target became.
        (POSITION_TARGET_LOCAL_NED_DATA::ID, hz(4.0)),
        // Sent on request only (SET_MESSAGE_INTERVAL, REQUEST_MESSAGE), as ArduCopter sends
        // them; ODOMETRY, which ArduCopter refuses, as PX4 sends it to MAVSDK's `odometry`.
        (ATTITUDE_QUATERNION_DATA::ID, None),
        (SCALED_IMU_DATA::ID, None),
        (HIGHRES_IMU_DATA::ID, None),
        (ODOMETRY_DATA::ID, None),
    ]
    .into_iter()
    .map(|(id, default)| Stream { id, default, interval: default, next: Time::ZERO })
    .collect()
}

/// REQUEST_DATA_STREAM's groups, mapped onto our messages as ArduPilot groups them.
fn data_stream_ids(stream: MavDataStream) -> &'static [u32] {
    match stream {
        MavDataStream::MAV_DATA_STREAM_ALL => &[
            SYS_STATUS_DATA::ID,
            GPS_RAW_INT_DATA::ID,
            MISSION_CURRENT_DATA::ID,
            FENCE_STATUS_DATA::ID,
            GLOBAL_POSITION_INT_DATA::ID,
            LOCAL_POSITION_NED_DATA::ID,
            ATTITUDE_DATA::ID,
            VFR_HUD_DATA::ID,
            BATTERY_STATUS_DATA::ID,
            EXTENDED_SYS_STATE_DATA::ID,
            RAW_IMU_DATA::ID,
            SCALED_PRESSURE_DATA::ID,
            SERVO_OUTPUT_RAW_DATA::ID,
            SYSTEM_TIME_DATA::ID,
            RC_CHANNELS_DATA::ID,
            NAV_CONTROLLER_OUTPUT_DATA::ID,
            POSITION_TARGET_GLOBAL_INT_DATA::ID,
            POSITION_TARGET_LOCAL_NED_DATA::ID,
        ],
        MavDataStream::MAV_DATA_STREAM_RAW_SENSORS => &[RAW_IMU_DATA::ID, SCALED_PRESSURE_DATA::ID],
        MavDataStream::MAV_DATA_STREAM_RC_CHANNELS => &[SERVO_OUTPUT_RAW_DATA::ID, RC_CHANNELS_DATA::ID],
        MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS => &[
            SYS_STATUS_DATA::ID,
            GPS_RAW_INT_DATA::ID,
            MISSION_CURRENT_DATA::ID,
            FENCE_STATUS_DATA::ID,
            NAV_CONTROLLER_OUTPUT_DATA::ID,
            POSITION_TARGET_GLOBAL_INT_DATA::ID,
            POSITION_TARGET_LOCAL_NED_DATA::ID,
        ],
        MavDataStream::MAV_DATA_STREAM_POSITION => {
            &[GLOBAL_POSITION_INT_DATA::ID, LOCAL_POSITION_NED_DATA::ID]
        }
        MavDataStream::MAV_DATA_STREAM_EXTRA1 => &[ATTITUDE_DATA::ID, SIMSTATE_DATA::ID],
        MavDataStream::MAV_DATA_STREAM_EXTRA2 => &[VFR_HUD_DATA::ID],
        MavDataStream::MAV_DATA_STREAM_EXTRA3 => {
            &[BATTERY_STATUS_DATA::ID, EXTENDED_SYS_STATE_DATA::ID, WIND_DATA::ID, DISTANCE_SENSOR_DATA::ID]
        }
        _ => &[],
    }
}

/// Every streamed message's interval and next due time, in a fixed order (the order due
/// messages go out in).
#[derive(Debug)]
pub struct Streams {
    streams: Vec<Stream>,
}

impl Default for Streams {
    fn default() -> Self {
        Streams { streams: default_streams() }
    }
}

impl Streams {
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

    /// REQUEST_DATA_STREAM: every message of `stream`'s group at `rate_hz` (at most 50), or
    /// stopped.
    pub fn request_data_stream(&mut self, stream: MavDataStream, rate_hz: u16, start: bool, now: Time) {
        let ids = data_stream_ids(stream);
        let interval = (start && rate_hz > 0).then(|| hz(f64::from(rate_hz.min(50)))).flatten();
        for s in self.streams.iter_mut().filter(|s| ids.contains(&s.id)) {
            s.interval = interval;
            s.next = now;
        }
    }

    /// Calls `send` with the id of every message due at `now`, in stream order, and schedules
    /// each one's next time.
    pub fn take_due(&mut self, now: Time, mut send: impl FnMut(u32)) {
        for s in &mut self.streams {
            let Some(interval) = s.interval else { continue };
            if now < s.next {
                continue;
            }
            // Keep the cadence; after a stall, restart from now rather than bursting.
            let next = s.next + interval;
            s.next = if next <= now { now + interval } else { next };
            send(s.id);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sent_in_a_second(s: &mut Streams, id: u32, from_ms: u64) -> usize {
        let mut n = 0;
        for ms in (from_ms..from_ms + 1000).step_by(20) {
            s.take_due(Time::from_micros(ms * 1000), |due| n += usize::from(due == id));
        }
        n
    }

    #[test]
    fn a_stream_keeps_its_cadence_and_restarts_from_now_after_a_stall() {
        let mut s = Streams::default();
        assert_eq!(sent_in_a_second(&mut s, ATTITUDE_DATA::ID, 0), 10);
        // Nothing for 5 s, then one at once and the old cadence from there, not a burst.
        let mut n = 0;
        s.take_due(Time::from_micros(6_000_000), |id| n += usize::from(id == ATTITUDE_DATA::ID));
        assert_eq!(n, 1);
        assert_eq!(sent_in_a_second(&mut s, ATTITUDE_DATA::ID, 6020), 10);
    }

    #[test]
    fn intervals_are_set_stopped_restored_and_refused_beyond_50_hz() {
        let mut s = Streams::default();
        let id = f64::from(ATTITUDE_DATA::ID);
        assert_eq!(s.set_interval(id, 10_000.0, Time::ZERO), MavResult::MAV_RESULT_DENIED);
        assert_eq!(s.set_interval(id, f64::NAN, Time::ZERO), MavResult::MAV_RESULT_DENIED);
        assert_eq!(
            s.interval(ATTITUDE_DATA::ID),
            Some(Duration::from_millis(100)),
            "a refusal changes nothing"
        );
        assert_eq!(s.set_interval(id, 20_000.0, Time::ZERO), MavResult::MAV_RESULT_ACCEPTED);
        assert_eq!(sent_in_a_second(&mut s, ATTITUDE_DATA::ID, 0), 50);
        assert_eq!(s.set_interval(id, -1.0, Time::ZERO), MavResult::MAV_RESULT_ACCEPTED);
        assert_eq!(sent_in_a_second(&mut s, ATTITUDE_DATA::ID, 1000), 0);
        assert_eq!(s.set_interval(id, 0.0, Time::ZERO), MavResult::MAV_RESULT_ACCEPTED);
        assert_eq!(s.interval(ATTITUDE_DATA::ID), Some(Duration::from_millis(100)));
    }

    #[test]
    fn arducopters_frames_stream_at_4_hz_in_its_groups_and_the_rest_on_request() {
        let mut s = Streams::default();
        for id in
            [RAW_IMU_DATA::ID, SCALED_PRESSURE_DATA::ID, SERVO_OUTPUT_RAW_DATA::ID, SYSTEM_TIME_DATA::ID]
        {
            assert_eq!(s.interval(id), Some(Duration::from_millis(250)), "{id}");
        }
        for id in [ATTITUDE_QUATERNION_DATA::ID, SCALED_IMU_DATA::ID, HIGHRES_IMU_DATA::ID, ODOMETRY_DATA::ID]
        {
            assert_eq!(s.interval(id), None, "{id}: on request only");
            assert_eq!(s.set_interval(f64::from(id), 50_000.0, Time::ZERO), MavResult::MAV_RESULT_ACCEPTED);
            assert_eq!(s.interval(id), Some(Duration::from_millis(50)));
        }
        s.request_data_stream(MavDataStream::MAV_DATA_STREAM_RAW_SENSORS, 10, true, Time::ZERO);
        s.request_data_stream(MavDataStream::MAV_DATA_STREAM_RC_CHANNELS, 10, true, Time::ZERO);
        for id in [RAW_IMU_DATA::ID, SCALED_PRESSURE_DATA::ID, SERVO_OUTPUT_RAW_DATA::ID] {
            assert_eq!(s.interval(id), Some(Duration::from_millis(100)), "{id}");
        }
    }

    #[test]
    fn a_data_stream_request_sets_its_whole_group_and_a_zero_rate_stops_it() {
        let mut s = Streams::default();
        s.request_data_stream(MavDataStream::MAV_DATA_STREAM_POSITION, 100, true, Time::ZERO);
        for id in [GLOBAL_POSITION_INT_DATA::ID, LOCAL_POSITION_NED_DATA::ID] {
            assert_eq!(s.interval(id), Some(Duration::from_millis(20)), "capped at 50 Hz");
        }
        assert_eq!(s.interval(ATTITUDE_DATA::ID), Some(Duration::from_millis(100)), "other groups untouched");
        s.request_data_stream(MavDataStream::MAV_DATA_STREAM_POSITION, 0, true, Time::ZERO);
        assert_eq!(s.interval(GLOBAL_POSITION_INT_DATA::ID), None);
        s.request_data_stream(MavDataStream::MAV_DATA_STREAM_EXTRA2, 4, false, Time::ZERO);
        assert_eq!(s.interval(VFR_HUD_DATA::ID), None);
    }
}
