//! MAV_CMD_DO_MOTOR_TEST's run, as ArduCopter's `motor_test_output` sequences it: motor `first`
//! of the frame's test order spins at its throttle for the test's time, then, when more motors
//! follow, every output rests at its command-0 pulse for half that time before the next one
//! spins; after the last the outputs are released to the disarmed pulse.
//!
//! The commander decides whether a test may start (disarmed, landed: `Commander::on_command`);
//! this core only runs one it took. It stops early, outputs released at once, on anything
//! else a ground station commands, a calibration, arming, or when no ground-station heartbeat
//! has been heard for [`GCS_LOSS_TIMEOUT`] — stricter than ArduCopter, which turns its GCS
//! failsafe off for the test and waits out the timeout (up to `MOTOR_TEST_MAX_S`).
//!
//! The pulses go out on the direct-pulse path (`EscPulses`), which every consumer checks
//! exactly, obeys only disarmed and drops after `DIRECT_PULSE_TIMEOUT` (`kestrel_proto::esc`):
//! the simulator and the Navio2 PWM driver alike. Pure: time comes in, pulses go out. Held by
//! the tests below and tests/gcs_reboot_motor_test.rs (the simulator's motors, as the ground
//! station sees them).

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::esc::{EscRanges, OutputRange, SAFE_PULSE_MAX_US, SAFE_PULSE_MIN_US, esc_range_names};
use kestrel_proto::frame_layout::FrameLayout;
use kestrel_proto::messages::{MAX_MOTORS, MotorTestThrottle, ParamDecl};

/// A test stops when no ground-station heartbeat came for this long: ArduCopter's
/// `FS_GCS_TIMEOUT` default (5 s).
pub const GCS_LOSS_TIMEOUT: Duration = Duration::from_secs(5);

/// The outputs the motor driver (or the simulator) declares: how many, and each one's range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestOutputs {
    pub layout: FrameLayout,
    pub ranges: EscRanges,
}

impl TestOutputs {
    /// From the output owner's declaration: its `SERVOn_MIN`/`SERVOn_MAX` for outputs 1..=n
    /// give the ranges and the motor count, whose one layout gives the test order. `None` for
    /// a declaration without them (another owner's) or with a count no layout has.
    pub fn from_decl(decl: &ParamDecl) -> Option<TestOutputs> {
        let value = |name: &str| decl.params.iter().find(|p| p.name == name).map(|p| p.value);
        let mut ranges = EscRanges::default();
        let mut count = 0;
        for (output, range) in ranges.outputs.iter_mut().enumerate() {
            let (min, max) = esc_range_names(output);
            let (Some(min_us), Some(max_us)) = (value(min), value(max)) else { break };
            *range = OutputRange { min_us, max_us };
            count += 1;
        }
        let layout = FrameLayout::with_motor_count(count)?;
        ranges.validate().ok()?;
        Some(TestOutputs { layout, ranges })
    }
}

/// Why a test does not start.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MotorTestRefusal {
    #[error("Motor Test: no motor outputs declared")]
    NoOutputs,
    #[error("Motor Test: motors {first}..={last} asked, the frame has {motors}")]
    NoSuchMotor { first: u8, last: u16, motors: usize },
    #[error("Motor Test: pulse {pulse_us} us outside {SAFE_PULSE_MIN_US}..={SAFE_PULSE_MAX_US} us")]
    Pulse { pulse_us: f64 },
    #[error("Motor Test: time {duration_s} s is not a positive number")]
    Duration { duration_s: f64 },
}

/// The test under way.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Running {
    /// Test-order number (1-based) of the motor spinning, or next after a rest.
    seq: u8,
    /// Motors left, this one included.
    left: u8,
    throttle: MotorTestThrottle,
    spin: Duration,
    /// When this motor's spin began.
    since: Time,
}

/// One vehicle's motor test: the outputs declared, the test under way, the last heartbeat.
#[derive(Clone, Debug, Default)]
pub struct MotorTest {
    outputs: Option<TestOutputs>,
    running: Option<Running>,
    heard: Option<Time>,
}

impl MotorTest {
    /// The output owner's declaration; others are ignored.
    pub fn on_decl(&mut self, decl: &ParamDecl) {
        if let Some(outputs) = TestOutputs::from_decl(decl) {
            self.outputs = Some(outputs);
        }
    }

    /// A ground station's heartbeat at `now`.
    pub fn on_heartbeat(&mut self, now: Time) {
        self.heard = Some(now);
    }

    pub fn running(&self) -> bool {
        self.running.is_some()
    }

    /// Starts (or restarts, as ArduCopter takes a new command during a test) the test the
    /// commander took.
    pub fn start(
        &mut self,
        first: u8,
        count: u8,
        throttle: MotorTestThrottle,
        duration_s: f64,
        now: Time,
    ) -> Result<(), MotorTestRefusal> {
        self.running = None;
        let outputs = self.outputs.ok_or(MotorTestRefusal::NoOutputs)?;
        let motors = outputs.layout.motor_count();
        let last = u16::from(first) + u16::from(count.max(1)) - 1;
        if first == 0 || usize::from(last) > motors {
            return Err(MotorTestRefusal::NoSuchMotor { first, last, motors });
        }
        if let MotorTestThrottle::PulseUs(pulse_us) = throttle
            && !(SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US).contains(&pulse_us)
        {
            return Err(MotorTestRefusal::Pulse { pulse_us });
        }
        if let MotorTestThrottle::Share(share) = throttle
            && !(0.0..=1.0).contains(&share)
        {
            return Err(MotorTestRefusal::Pulse { pulse_us: share });
        }
        let spin = Duration::try_from_secs_f64(duration_s)
            .ok()
            .filter(|d| !d.is_zero())
            .ok_or(MotorTestRefusal::Duration { duration_s })?;
        self.running = Some(Running { seq: first, left: count.max(1), throttle, spin, since: now });
        // The command came from a ground station: it counts as heard.
        self.heard = Some(self.heard.map_or(now, |h| h.max(now)));
        Ok(())
    }

    /// Stops a test under way; `true` if one was.
    pub fn stop(&mut self) -> bool {
        self.running.take().is_some()
    }

    /// Moves the test on to `now`: `Some(why)` when it ended here (its last motor done, or the
    /// ground station lost).
    pub fn update(&mut self, now: Time) -> Option<&'static str> {
        let run = self.running.as_mut()?;
        if self.heard.is_none_or(|h| now.saturating_since(h) > GCS_LOSS_TIMEOUT) {
            self.running = None;
            return Some("ground station lost");
        }
        // Each motor: `spin` at its throttle, then half of it at rest when another follows.
        loop {
            let elapsed = now.saturating_since(run.since);
            if elapsed < run.spin {
                return None;
            }
            if run.left <= 1 {
                self.running = None;
                return Some("done");
            }
            let cycle = run.spin + run.spin / 2;
            if elapsed < cycle {
                return None;
            }
            run.seq += 1;
            run.left -= 1;
            run.since = run.since + cycle;
        }
    }

    /// The pulse for every output now (µs): the motor under test at its throttle, the rest at
    /// their command-0 pulse; `None` when no test runs. Call [`MotorTest::update`] first.
    pub fn pulses_us(&self, now: Time) -> Option<[f64; MAX_MOTORS]> {
        let run = self.running.as_ref()?;
        let outputs = self.outputs.as_ref()?;
        let mut pulses = [0.0; MAX_MOTORS];
        for (output, p) in pulses.iter_mut().enumerate() {
            *p = outputs.ranges.pulse_us(output, 0.0);
        }
        if now.saturating_since(run.since) < run.spin {
            let output = outputs.layout.test_order()[usize::from(run.seq - 1)];
            pulses[output] = match run.throttle {
                MotorTestThrottle::Share(share) => outputs.ranges.pulse_us(output, share),
                MotorTestThrottle::PulseUs(pulse_us) => pulse_us,
            };
        }
        Some(pulses)
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::ParamInfo;
    use proptest::prelude::*;

    use super::*;

    fn decl(ranges: &[(f64, f64)]) -> ParamDecl {
        let mut params = Vec::new();
        for (i, &(min, max)) in ranges.iter().enumerate() {
            let (a, b) = esc_range_names(i);
            for (name, value) in [(a, min), (b, max)] {
                params.push(ParamInfo {
                    name: name.into(),
                    value,
                    min: SAFE_PULSE_MIN_US,
                    max: SAFE_PULSE_MAX_US,
                    unit: "us".into(),
                    description: String::new(),
                    integer: false,
                    disarmed_only: true,
                });
            }
        }
        ParamDecl { time: Time::ZERO, owner: "sim".into(), start: true, params }
    }

    fn quad() -> MotorTest {
        let mut t = MotorTest::default();
        t.on_decl(&decl(&[(1000.0, 2000.0), (1100.0, 1900.0), (1000.0, 2000.0), (1000.0, 2000.0)]));
        t
    }

    fn at(s: f64) -> Time {
        Time::from_micros((s * 1e6).round() as u64)
    }

    /// The output spinning (above its command-0 pulse) at `s`, and its pulse.
    fn spinning(t: &mut MotorTest, s: f64) -> Option<(usize, f64)> {
        t.update(at(s));
        let pulses = t.pulses_us(at(s))?;
        let idle = [1000.0, 1100.0, 1000.0, 1000.0];
        let busy: Vec<_> = (0..4).filter(|&i| pulses[i] != idle[i]).map(|i| (i, pulses[i])).collect();
        assert!(busy.len() <= 1, "one motor at a time: {pulses:?}");
        busy.first().copied()
    }

    #[test]
    fn a_sequence_spins_each_motor_in_test_order_with_rests_between_then_releases() {
        let mut t = quad();
        t.on_heartbeat(at(0.0));
        t.start(1, 4, MotorTestThrottle::Share(0.5), 1.0, at(0.0)).expect("starts");
        // Quad-X test order 1, 4, 2, 3 (outputs 0, 3, 1, 2); motor 2's range is 1100..1900.
        let expect =
            [(0.1, Some((0, 1500.0))), (1.2, None), (1.6, Some((3, 1500.0))), (3.1, Some((1, 1500.0)))];
        for (s, want) in expect {
            t.on_heartbeat(at(s));
            assert_eq!(spinning(&mut t, s), want, "at {s} s");
        }
        t.on_heartbeat(at(4.6));
        assert_eq!(spinning(&mut t, 4.6), Some((2, 1500.0)));
        assert!(t.running());
        t.on_heartbeat(at(5.5));
        assert_eq!(t.update(at(5.6)), Some("done"), "four motors: 4 + 3 rests of 0.5 s = 5.5 s");
        assert_eq!(t.pulses_us(at(5.6)), None, "released");
    }

    #[test]
    fn pwm_throttle_is_the_pulse_itself_and_what_cannot_be_run_is_refused() {
        let mut t = quad();
        t.start(2, 1, MotorTestThrottle::PulseUs(1234.0), 2.0, at(0.0)).expect("starts");
        assert_eq!(spinning(&mut t, 1.0), Some((3, 1234.0)), "test motor 2 is output 4 (rear right)");
        assert_eq!(t.update(at(2.0)), Some("done"));
        assert!(matches!(
            t.start(4, 2, MotorTestThrottle::Share(0.1), 1.0, at(0.0)),
            Err(MotorTestRefusal::NoSuchMotor { .. })
        ));
        assert!(matches!(
            t.start(1, 1, MotorTestThrottle::PulseUs(2300.0), 1.0, at(0.0)),
            Err(MotorTestRefusal::Pulse { .. })
        ));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(
                matches!(
                    t.start(1, 1, MotorTestThrottle::Share(0.1), bad, at(0.0)),
                    Err(MotorTestRefusal::Duration { .. })
                ),
                "{bad}"
            );
        }
        assert!(!t.running(), "a refusal leaves nothing running");
        let mut bare = MotorTest::default();
        assert_eq!(
            bare.start(1, 1, MotorTestThrottle::Share(0.1), 1.0, at(0.0)),
            Err(MotorTestRefusal::NoOutputs)
        );
    }

    #[test]
    fn a_lost_ground_station_or_a_stop_ends_the_test_at_once() {
        let mut t = quad();
        t.start(1, 1, MotorTestThrottle::Share(0.2), 60.0, at(10.0)).expect("starts");
        assert_eq!(t.update(at(15.0)), None, "5 s after the command: still heard");
        assert_eq!(t.update(at(15.1)), Some("ground station lost"));
        assert_eq!(t.pulses_us(at(15.1)), None);
        t.start(1, 1, MotorTestThrottle::Share(0.2), 60.0, at(20.0)).expect("starts");
        assert!(t.stop());
        assert!(!t.stop(), "nothing left to stop");
    }

    proptest! {
        /// Whatever the request, the pulses are finite and inside the safe range, at most one
        /// output above its command-0 pulse, and the test ends by itself within
        /// count × 1.5 × time.
        #[test]
        fn pulses_stay_safe_and_the_test_ends_by_itself(
            first in 1u8..=4, count in 1u8..=4, share in 0.0..=1.0f64, duration_s in 0.01..5.0f64,
            steps in 1usize..400,
        ) {
            let mut t = quad();
            prop_assume!(t.start(first, count, MotorTestThrottle::Share(share), duration_s, at(0.0)).is_ok());
            let end = f64::from(count) * 1.5 * duration_s;
            for i in 0..=steps {
                let s = end * i as f64 / steps as f64;
                t.on_heartbeat(at(s));
                t.update(at(s));
                if let Some(p) = t.pulses_us(at(s)) {
                    prop_assert!(p[..4].iter().all(|&x| x.is_finite() && (SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US).contains(&x)));
                    let idle = [1000.0, 1100.0, 1000.0, 1000.0];
                    prop_assert!((0..4).filter(|&i| p[i] > idle[i]).count() <= 1);
                }
            }
            t.on_heartbeat(at(end + 0.001));
            t.update(at(end + 0.001));
            prop_assert!(!t.running());
        }
    }
}
