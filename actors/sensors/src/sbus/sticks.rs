//! Channels → [`ManualControl`]: which channel drives which stick, each channel's calibrated
//! range, and reversal. The default is the Futaba/FrSky "AETR" order with the usual SBUS
//! range 172..992..1811 (988..1500..2012 µs).

use kestrel_proto::Time;
use kestrel_proto::messages::ManualControl;

use crate::sbus::frame::{CHANNELS, SbusFrame};

/// One channel's calibrated travel (raw SBUS counts).
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChannelRange {
    /// Channel number, 1-based as radios print it.
    pub channel: usize,
    pub min: u16,
    pub center: u16,
    pub max: u16,
    /// Reverses the stick direction.
    pub reversed: bool,
}

impl Default for ChannelRange {
    fn default() -> ChannelRange {
        ChannelRange { channel: 1, min: 172, center: 992, max: 1811, reversed: false }
    }
}

impl ChannelRange {
    fn on(channel: usize) -> ChannelRange {
        ChannelRange { channel, ..ChannelRange::default() }
    }

    fn raw(&self, frame: &SbusFrame) -> f64 {
        f64::from(frame.channels[self.channel.clamp(1, CHANNELS) - 1])
    }

    /// A centred stick, −1..1.
    fn centred(&self, frame: &SbusFrame) -> f64 {
        let (raw, center) = (self.raw(frame), f64::from(self.center));
        let span = if raw >= center { f64::from(self.max) - center } else { center - f64::from(self.min) };
        let value = if span > 0.0 { ((raw - center) / span).clamp(-1.0, 1.0) } else { 0.0 };
        if self.reversed { -value } else { value }
    }

    /// A stick from bottom, 0..1.
    fn upward(&self, frame: &SbusFrame) -> f64 {
        let span = f64::from(self.max) - f64::from(self.min);
        let value =
            if span > 0.0 { ((self.raw(frame) - f64::from(self.min)) / span).clamp(0.0, 1.0) } else { 0.0 };
        if self.reversed { 1.0 - value } else { value }
    }
}

/// Which channel is which stick.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct StickMap {
    pub roll: ChannelRange,
    pub pitch: ChannelRange,
    pub throttle: ChannelRange,
    pub yaw: ChannelRange,
}

impl Default for StickMap {
    /// AETR: aileron 1, elevator 2, throttle 3, rudder 4.
    fn default() -> StickMap {
        StickMap {
            roll: ChannelRange::on(1),
            pitch: ChannelRange::on(2),
            throttle: ChannelRange::on(3),
            yaw: ChannelRange::on(4),
        }
    }
}

impl StickMap {
    /// The sticks of `frame`, received at `time`; `None` while the receiver is in failsafe
    /// (its channels are then its failsafe presets, not the pilot's hands — link-loss handling
    /// is the commander's, on the missing input).
    pub fn manual_control(&self, frame: &SbusFrame, time: Time) -> Option<ManualControl> {
        (!frame.failsafe).then(|| ManualControl {
            time,
            roll: self.roll.centred(frame),
            pitch: self.pitch.centred(frame),
            yaw: self.yaw.centred(frame),
            throttle: self.throttle.upward(frame),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(aetr: [u16; 4]) -> SbusFrame {
        let mut channels = [992; CHANNELS];
        channels[..4].copy_from_slice(&aetr);
        SbusFrame { channels, digital: [false; 2], frame_lost: false, failsafe: false }
    }

    #[test]
    fn centred_sticks_and_low_throttle() {
        let mc = StickMap::default()
            .manual_control(&frame([992, 992, 172, 992]), Time::from_micros(7))
            .expect("ok");
        assert_eq!(
            mc,
            ManualControl { time: Time::from_micros(7), roll: 0.0, pitch: 0.0, yaw: 0.0, throttle: 0.0 }
        );
    }

    #[test]
    fn full_deflections_clamp_and_reverse() {
        let mut map = StickMap::default();
        map.pitch.reversed = true;
        let mc = map.manual_control(&frame([1811, 2047, 1811, 0]), Time::ZERO).expect("ok");
        assert_eq!((mc.roll, mc.pitch, mc.yaw, mc.throttle), (1.0, -1.0, -1.0, 1.0));
        let half = map.manual_control(&frame([992 + 819 / 2, 992, 992, 992]), Time::ZERO).expect("ok");
        assert!((half.roll - 409.0 / 819.0).abs() < 1e-12);
        assert!((half.throttle - 820.0 / 1639.0).abs() < 1e-12);
    }

    #[test]
    fn failsafe_gives_no_sticks() {
        let mut f = frame([992; 4]);
        f.failsafe = true;
        assert_eq!(StickMap::default().manual_control(&f, Time::ZERO), None);
    }
}
