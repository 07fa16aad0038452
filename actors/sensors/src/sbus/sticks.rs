//! Channels → [`ManualControl`]: which channel drives which stick, each channel's calibrated
//! range, and reversal. The default is the Futaba/FrSky "AETR" order with the usual SBUS
//! range 172..992..1811 (988..1500..2012 µs).

use kestrel_proto::Time;
use kestrel_proto::messages::{ManualControl, StickSource};

use crate::sbus::frame::SbusFrame;

/// One channel's calibrated travel, in the receiver's raw units (SBUS counts, or pulse widths
/// in µs for RCIO and PWM receivers).
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

    /// This channel's value; a channel number past the end reads as the centre (callers that
    /// know their channel count check the map with [`StickMap::highest_channel`]).
    fn raw(&self, channels: &[u16]) -> f64 {
        let index = self.channel.max(1) - 1;
        f64::from(channels.get(index).copied().unwrap_or(self.center))
    }

    /// A centred stick, −1..1.
    fn centred(&self, channels: &[u16]) -> f64 {
        let (raw, center) = (self.raw(channels), f64::from(self.center));
        let span = if raw >= center { f64::from(self.max) - center } else { center - f64::from(self.min) };
        let value = if span > 0.0 { ((raw - center) / span).clamp(-1.0, 1.0) } else { 0.0 };
        if self.reversed { -value } else { value }
    }

    /// A stick from bottom, 0..1.
    fn upward(&self, channels: &[u16]) -> f64 {
        let span = f64::from(self.max) - f64::from(self.min);
        let value = if span > 0.0 {
            ((self.raw(channels) - f64::from(self.min)) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
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
    /// AETR on channels 1..4 measured as pulse widths: 1000..1500..2000 µs, as PWM/PPM
    /// receivers and Navio2's RCIO report them.
    pub fn pulse_width_us() -> StickMap {
        let on = |channel| ChannelRange { channel, min: 1000, center: 1500, max: 2000, reversed: false };
        StickMap { roll: on(1), pitch: on(2), throttle: on(3), yaw: on(4) }
    }

    /// The highest channel number the map reads (1-based).
    pub fn highest_channel(&self) -> usize {
        [self.roll.channel, self.pitch.channel, self.throttle.channel, self.yaw.channel]
            .into_iter()
            .max()
            .unwrap_or(1)
    }

    /// The sticks for raw channel values (channel 1 first) read at `time`.
    pub fn sticks(&self, channels: &[u16], time: Time) -> ManualControl {
        ManualControl {
            time,
            roll: self.roll.centred(channels),
            pitch: self.pitch.centred(channels),
            yaw: self.yaw.centred(channels),
            throttle: self.throttle.upward(channels),
            source: StickSource::Radio,
        }
    }

    /// The sticks of `frame`, received at `time`; `None` while the receiver is in failsafe
    /// (its channels are then its failsafe presets, not the pilot's hands — link-loss handling
    /// is the commander's, on the missing input).
    pub fn manual_control(&self, frame: &SbusFrame, time: Time) -> Option<ManualControl> {
        (!frame.failsafe).then(|| self.sticks(&frame.channels, time))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sbus::frame::CHANNELS;

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
            ManualControl {
                time: Time::from_micros(7),
                roll: 0.0,
                pitch: 0.0,
                yaw: 0.0,
                throttle: 0.0,
                source: StickSource::Radio
            }
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
    fn pulse_widths_and_missing_channels() {
        let map = StickMap::pulse_width_us();
        let mc = map.sticks(&[1750, 1500, 1000, 1250], Time::ZERO);
        assert_eq!((mc.roll, mc.pitch, mc.yaw, mc.throttle), (0.5, 0.0, -0.5, 0.0));
        assert_eq!(map.highest_channel(), 4);
        assert_eq!(map.sticks(&[2000], Time::ZERO).pitch, 0.0, "absent channel reads centred");
    }

    #[test]
    fn failsafe_gives_no_sticks() {
        let mut f = frame([992; 4]);
        f.failsafe = true;
        assert_eq!(StickMap::default().manual_control(&f, Time::ZERO), None);
    }
}
