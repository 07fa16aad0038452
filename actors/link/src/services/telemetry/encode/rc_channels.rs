//! RC_CHANNELS: the pilot's sticks as the newest ManualControl on the graph carries them (the RC
//! receiver's, or a ground station's MANUAL_CONTROL), in ArduCopter's channel order and PWM
//! (µs): 1 roll, 2 pitch (stick forward is the low end, as ArduCopter's RC2), 3 throttle, 4 yaw,
//! 1000..2000 with 1500 centred; unused channels UINT16_MAX as MAVLink says. Nothing when no
//! sticks came within [`STICKS_STALE_S`]: a value remembered from a lost radio is not a reading.

use kestrel_proto::Time;
use kestrel_proto::messages::{ManualControl, StickSource};
use mavlink::dialects::ardupilotmega::RC_CHANNELS_DATA;

/// Sticks older than this are not reported (s): the commander's own stick timeout is shorter.
pub const STICKS_STALE_S: f64 = 1.0;

/// A stick position -1..1 as PWM around 1500 µs.
fn centred(v: f64) -> u16 {
    (1500.0 + 500.0 * v.clamp(-1.0, 1.0)).round() as u16
}

/// RC_CHANNELS of `sticks` at `now`, stamped `boot_ms`; `None` when stale.
pub fn rc_channels(sticks: &ManualControl, now: Time, boot_ms: u32) -> Option<RC_CHANNELS_DATA> {
    if now.saturating_since(sticks.time).as_secs_f64() > STICKS_STALE_S {
        return None;
    }
    let throttle = (1000.0 + 1000.0 * sticks.throttle.clamp(0.0, 1.0)).round() as u16;
    Some(RC_CHANNELS_DATA {
        time_boot_ms: boot_ms,
        chan1_raw: centred(sticks.roll),
        chan2_raw: centred(-sticks.pitch),
        chan3_raw: throttle,
        chan4_raw: centred(sticks.yaw),
        chan5_raw: u16::MAX,
        chan6_raw: u16::MAX,
        chan7_raw: u16::MAX,
        chan8_raw: u16::MAX,
        chan9_raw: u16::MAX,
        chan10_raw: u16::MAX,
        chan11_raw: u16::MAX,
        chan12_raw: u16::MAX,
        chan13_raw: u16::MAX,
        chan14_raw: u16::MAX,
        chan15_raw: u16::MAX,
        chan16_raw: u16::MAX,
        chan17_raw: u16::MAX,
        chan18_raw: u16::MAX,
        chancount: 4,
        // A receiver's signal strength is not known here; MAVLink's "unknown".
        rssi: match sticks.source {
            StickSource::Radio | StickSource::Mavlink { .. } => u8::MAX,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sticks_become_arducopter_pwm_and_stale_ones_nothing() {
        let s = ManualControl {
            time: Time::from_secs_f64(1.0),
            roll: 0.5,
            pitch: 1.0,
            yaw: -1.0,
            throttle: 0.25,
            source: StickSource::Radio,
        };
        let m = rc_channels(&s, Time::from_secs_f64(1.5), 1500).expect("fresh");
        assert_eq!((m.chan1_raw, m.chan2_raw, m.chan3_raw, m.chan4_raw), (1750, 1000, 1250, 1000));
        assert_eq!((m.chan5_raw, m.chancount, m.rssi, m.time_boot_ms), (u16::MAX, 4, u8::MAX, 1500));
        assert!(rc_channels(&s, Time::from_secs_f64(2.1), 0).is_none(), "older than a second");
    }
}
