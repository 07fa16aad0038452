//! The faults of a run in time: which are active at a tick, each start and end reported once,
//! and what the active ones do to each model ([`FaultEffects`], each part defined beside the
//! model it changes).

use kestrel_proto::Time;
use kestrel_proto::messages::{SimFault, SimFaultPhase};
use nalgebra::Vector3;

use super::kind::{CameraLens, Fault, FaultKind};
use crate::battery::BatteryFaults;
use crate::motors::MotorFaults;
use crate::sensors::baro::BaroFaults;
use crate::sensors::gps::GpsFaults;
use crate::sensors::imu::ImuFaults;
use crate::sensors::mag::MagFaults;
use crate::wind::WindFault;

/// Where a scheduled fault is in its life, for [`FaultSchedule::poll`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Pending,
    Active,
    Ended,
}

/// The faults of a run, in the order they were added (the world file's order first).
#[derive(Clone, Debug, Default)]
pub struct FaultSchedule {
    faults: Vec<Fault>,
    phases: Vec<Phase>,
}

impl FaultSchedule {
    /// A schedule of `faults` (already validated), none started yet.
    pub fn new(faults: &[Fault]) -> FaultSchedule {
        FaultSchedule { faults: faults.to_vec(), phases: vec![Phase::Pending; faults.len()] }
    }

    /// Adds a fault (a live parameter or a MAVLink command); its index is the next one.
    pub fn push(&mut self, fault: Fault) {
        self.faults.push(fault);
        self.phases.push(Phase::Pending);
    }

    /// Ends fault `index` from the first tick after `time` on (never later than it was to end).
    /// One added and ended between two ticks takes no effect; its start and end are still
    /// reported, by the same poll.
    pub fn end_after(&mut self, index: usize, time: Time) {
        let Some(fault) = self.faults.get_mut(index) else { return };
        let end_s = (time.0 + 1) as f64 * 1e-6;
        let for_s = (end_s - fault.at_s).max(1e-6);
        fault.for_s = Some(fault.for_s.map_or(for_s, |old| old.min(for_s)));
    }

    /// Every fault, with its index.
    pub fn faults(&self) -> &[Fault] {
        &self.faults
    }

    /// The faults active at `time` (`start ≤ time < end`), with their indices, in order.
    pub fn active_at(&self, time: Time) -> impl Iterator<Item = (usize, &Fault)> {
        self.faults.iter().enumerate().filter(move |(_, f)| f.active_at(time))
    }

    /// Every start and end at or before `now` not reported yet, stamped `now` (the tick they
    /// take effect on), in index order, a start before its end. A fault whose whole window
    /// falls between two polls is reported started and ended by the same poll.
    pub fn poll(&mut self, now: Time) -> Vec<FaultEvent> {
        let mut events = Vec::new();
        for (index, (fault, phase)) in self.faults.iter().zip(self.phases.iter_mut()).enumerate() {
            if *phase == Phase::Pending && fault.start() <= now {
                *phase = Phase::Active;
                events.push(FaultEvent { time: now, index, phase: SimFaultPhase::Started });
            }
            if *phase == Phase::Active && fault.end().is_some_and(|end| end <= now) {
                *phase = Phase::Ended;
                events.push(FaultEvent { time: now, index, phase: SimFaultPhase::Ended });
            }
        }
        events
    }

    /// What the faults active at `time` do, summed over all of them.
    pub fn effects_at(&self, time: Time) -> FaultEffects {
        let mut effects = FaultEffects::default();
        let mut wind_start = None;
        for (_, fault) in self.active_at(time) {
            let since_s = time.0.saturating_sub(fault.start().0) as f64 * 1e-6;
            match &fault.kind {
                FaultKind::GpsOff => effects.gps.off = true,
                FaultKind::GpsJump { ned_m } => effects.gps.offset_ned_m += Vector3::from(*ned_m),
                FaultKind::GpsNoise { factor } => effects.gps.noise_factor *= factor,
                FaultKind::MagAnomaly { gauss } => effects.mag.added_frd_gauss += Vector3::from(*gauss),
                FaultKind::MagStuck => effects.mag.stuck = true,
                FaultKind::BaroDrift { m_s } => effects.baro.altitude_error_m += m_s * since_s,
                FaultKind::BaroStuck => effects.baro.stuck = true,
                FaultKind::GyroBias { rad_s } => effects.imu.gyro_bias_rad_s += Vector3::from(*rad_s),
                FaultKind::AccelBias { m_s2 } => effects.imu.accel_bias_m_s2 += Vector3::from(*m_s2),
                FaultKind::AccelClip => effects.imu.clip = true,
                FaultKind::ImuStop => effects.imu.stopped = true,
                FaultKind::MotorLost { motor } => effects.motors.thrust_scale[usize::from(*motor) - 1] = 0.0,
                FaultKind::MotorWeak { motor, thrust } => {
                    effects.motors.thrust_scale[usize::from(*motor) - 1] *= thrust
                }
                FaultKind::BatterySag { volts } => effects.battery.sag_v += volts,
                FaultKind::Wind { ned_m_s, gust_m_s } => {
                    // `active_at` yields in index order, so `>=` lets a later entry win a tie.
                    if wind_start.is_none_or(|start| fault.start() >= start) {
                        wind_start = Some(fault.start());
                        effects.wind = Some(WindFault { steady_ned_m_s: *ned_m_s, gust_std_m_s: *gust_m_s });
                    }
                }
                FaultKind::CameraStop => effects.camera.stop = true,
                FaultKind::CameraBlack => effects.camera.black = true,
                FaultKind::CameraFrozen => effects.camera.frozen = true,
                FaultKind::CameraGlare { region, intensity, lens } => {
                    // The latest entry active wins, as for the wind.
                    effects.camera.glare = Some(Glare { region: *region, intensity: *intensity, lens: *lens })
                }
                FaultKind::CameraCapped { lens } => {
                    effects.camera.capped_left |= lens.covers(true);
                    effects.camera.capped_right |= lens.covers(false);
                }
                FaultKind::ActorPanic { .. } | FaultKind::LinkLost => {}
            }
        }
        effects
    }

    /// The `sim_fault` message of `event`.
    pub fn message(&self, event: &FaultEvent) -> SimFault {
        let fault = &self.faults[event.index];
        SimFault {
            time: event.time,
            index: u32::try_from(event.index).unwrap_or(u32::MAX),
            phase: event.phase,
            kind: fault.kind.name().to_owned(),
            values: fault.kind.to_string(),
            at_s: fault.at_s,
            for_s: fault.for_s,
        }
    }
}

/// A fault starting or ending: entry `index` of the schedule, at `time`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultEvent {
    pub time: Time,
    pub index: usize,
    pub phase: SimFaultPhase,
}

/// What the active faults do to each model, in the model's own terms. Each part is defined, and
/// applied, next to the model it changes.
#[derive(Clone, Debug, PartialEq)]
pub struct FaultEffects {
    pub gps: GpsFaults,
    pub mag: MagFaults,
    pub baro: BaroFaults,
    pub imu: ImuFaults,
    pub motors: MotorFaults,
    pub battery: BatteryFaults,
    /// The wind that replaces the world's, if any.
    pub wind: Option<WindFault>,
    pub camera: CameraFaults,
}

impl Default for FaultEffects {
    /// No fault: every offset 0, every factor 1, every switch off.
    fn default() -> FaultEffects {
        FaultEffects {
            gps: GpsFaults::default(),
            mag: MagFaults::default(),
            baro: BaroFaults::default(),
            imu: ImuFaults::default(),
            motors: MotorFaults::default(),
            battery: BatteryFaults::default(),
            wind: None,
            camera: CameraFaults::default(),
        }
    }
}

/// The stereo camera's faults (applied in `camera_actor.rs`): when several are active, stopped
/// wins over black, black over frozen; a capped lens and glare act on a fresh frame (frozen
/// repeats the last healthy one), the cap after the glare.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraFaults {
    pub stop: bool,
    pub black: bool,
    pub frozen: bool,
    pub capped_left: bool,
    pub capped_right: bool,
    pub glare: Option<Glare>,
}

/// Veiling glare over part of the image (`camera_glare`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Glare {
    /// `[x0, y0, x1, y1]`, shares of the image width and height, top-left origin.
    pub region: [f64; 4],
    /// 0..1: each pixel becomes `p + intensity·(255 − p)`.
    pub intensity: f64,
    pub lens: CameraLens,
}

impl Glare {
    /// Applies the glare to one `width`×`height` grey image (`left` or right).
    pub fn apply(&self, pixels: &mut [u8], width: usize, height: usize, left: bool) {
        if !self.lens.covers(left) || width == 0 {
            return;
        }
        let [x0, y0, x1, y1] = self.region;
        let at = |share: f64, n: usize| ((share * n as f64).round() as usize).min(n);
        let (c0, c1, r0, r1) = (at(x0, width), at(x1, width), at(y0, height), at(y1, height));
        for row in pixels.chunks_exact_mut(width).take(r1).skip(r0) {
            for p in &mut row[c0..c1] {
                let v = f64::from(*p);
                *p = (v + self.intensity * (255.0 - v)).round().clamp(0.0, 255.0) as u8;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn at(s: f64) -> Time {
        Time::from_secs_f64(s)
    }

    fn fault(at_s: f64, for_s: Option<f64>, kind: FaultKind) -> Fault {
        Fault { at_s, for_s, kind }
    }

    #[test]
    fn a_fault_is_active_from_its_start_until_its_end_or_for_ever() {
        let schedule = FaultSchedule::new(&[
            fault(10.0, Some(5.0), FaultKind::GpsOff),
            fault(12.0, None, FaultKind::MagStuck),
        ]);
        let active = |s| schedule.active_at(at(s)).map(|(i, _)| i).collect::<Vec<_>>();
        assert_eq!(active(9.999_999), [] as [usize; 0]);
        assert_eq!(active(10.0), [0]);
        assert_eq!(active(12.0), [0, 1]);
        assert_eq!(active(14.999_999), [0, 1]);
        assert_eq!(active(15.0), [1], "the end is exclusive");
        assert_eq!(active(1e6), [1], "no for_s: to the end of the run");
    }

    #[test]
    fn overlapping_faults_add_multiply_or_replace() {
        let schedule = FaultSchedule::new(&[
            fault(0.0, None, FaultKind::GpsJump { ned_m: [1.0, 2.0, 3.0] }),
            fault(5.0, Some(10.0), FaultKind::GpsJump { ned_m: [10.0, 0.0, 0.0] }),
            fault(0.0, None, FaultKind::GpsNoise { factor: 2.0 }),
            fault(5.0, None, FaultKind::GpsNoise { factor: 3.0 }),
            fault(0.0, None, FaultKind::MotorWeak { motor: 2, thrust: 0.5 }),
            fault(5.0, None, FaultKind::MotorWeak { motor: 2, thrust: 0.5 }),
            fault(0.0, None, FaultKind::Wind { ned_m_s: [1.0, 0.0, 0.0], gust_m_s: 0.0 }),
            fault(5.0, Some(1.0), FaultKind::Wind { ned_m_s: [9.0, 0.0, 0.0], gust_m_s: 2.0 }),
            fault(2.0, Some(8.0), FaultKind::BaroDrift { m_s: 1.0 }),
            fault(4.0, Some(6.0), FaultKind::BaroDrift { m_s: -0.5 }),
        ]);
        let before = schedule.effects_at(at(1.0));
        assert_eq!(before.gps.offset_ned_m, Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(before.gps.noise_factor, 2.0);
        assert_eq!(before.motors.thrust_scale[..3], [1.0, 0.5, 1.0]);
        assert_eq!(before.wind.as_ref().map(|w| w.steady_ned_m_s), Some([1.0, 0.0, 0.0]));
        let during = schedule.effects_at(at(5.5));
        assert_eq!(during.gps.offset_ned_m, Vector3::new(11.0, 2.0, 3.0));
        assert_eq!(during.gps.noise_factor, 6.0);
        assert_eq!(during.motors.thrust_scale[1], 0.25);
        assert_eq!(during.wind, Some(WindFault { steady_ned_m_s: [9.0, 0.0, 0.0], gust_std_m_s: 2.0 }));
        // 3.5 s at +1 m/s and 1.5 s at −0.5 m/s.
        assert!(
            (during.baro.altitude_error_m - (3.5 - 0.75)).abs() < 1e-9,
            "{}",
            during.baro.altitude_error_m
        );
        let after = schedule.effects_at(at(6.0));
        assert_eq!(
            after.wind.as_ref().map(|w| w.steady_ned_m_s),
            Some([1.0, 0.0, 0.0]),
            "back to the earlier"
        );
        assert_eq!(schedule.effects_at(at(10.0)).baro.altitude_error_m, 0.0, "drift gone at its end");
        assert_eq!(FaultSchedule::default().effects_at(at(3.0)), FaultEffects::default());
    }

    #[test]
    fn each_start_and_end_is_reported_once() {
        let mut schedule = FaultSchedule::new(&[
            fault(1.0, Some(2.0), FaultKind::ImuStop),
            fault(0.0, None, FaultKind::CameraBlack),
            fault(1.5, Some(0.0001), FaultKind::BaroStuck),
        ]);
        let started = |i, s| FaultEvent { time: at(s), index: i, phase: SimFaultPhase::Started };
        let ended = |i, s| FaultEvent { time: at(s), index: i, phase: SimFaultPhase::Ended };
        assert_eq!(schedule.poll(at(0.0)), [started(1, 0.0)]);
        assert_eq!(schedule.poll(at(0.5)), []);
        assert_eq!(schedule.poll(at(1.0)), [started(0, 1.0)]);
        assert_eq!(schedule.poll(at(2.0)), [started(2, 2.0), ended(2, 2.0)], "a short one between polls");
        assert_eq!(schedule.poll(at(1e4)), [ended(0, 1e4)]);
        assert_eq!(schedule.poll(at(2e4)), []);
        let message = schedule.message(&ended(0, 1e4));
        assert_eq!(
            (message.kind.as_str(), message.values.as_str(), message.for_s),
            ("imu_stop", "", Some(2.0))
        );
    }

    #[test]
    fn glare_whitens_its_region_on_its_lens_and_a_cap_blacks_out_one_side() {
        let glare = Glare { region: [0.5, 0.0, 1.0, 0.5], intensity: 1.0, lens: CameraLens::Right };
        let mut right = vec![100u8; 4 * 4];
        glare.apply(&mut right, 4, 4, false);
        let white: Vec<usize> = (0..16).filter(|&i| right[i] == 255).collect();
        assert_eq!(white, [2, 3, 6, 7], "columns 2..4 of rows 0..2");
        assert!(right.iter().all(|&p| p == 255 || p == 100));
        let mut left = vec![100u8; 16];
        glare.apply(&mut left, 4, 4, true);
        assert!(left.iter().all(|&p| p == 100), "the left lens is not under this glare");
        let half = Glare { intensity: 0.5, lens: CameraLens::Both, ..glare };
        let mut both = vec![100u8; 16];
        half.apply(&mut both, 4, 4, true);
        assert_eq!(both[3], 178, "100 + 0.5·155 rounded");
        let schedule = FaultSchedule::new(&[
            fault(1.0, None, FaultKind::CameraCapped { lens: CameraLens::Right }),
            fault(
                2.0,
                None,
                FaultKind::CameraGlare { region: [0.0; 4], intensity: 0.0, lens: CameraLens::Both },
            ),
        ]);
        let camera = schedule.effects_at(at(1.5)).camera;
        assert_eq!((camera.capped_left, camera.capped_right, camera.glare), (false, true, None));
        assert!(schedule.effects_at(at(2.5)).camera.glare.is_some());
    }

    fn any_kind() -> impl Strategy<Value = FaultKind> {
        prop_oneof![
            Just(FaultKind::GpsOff),
            (-100.0..100.0f64).prop_map(|n| FaultKind::GpsJump { ned_m: [n, 0.0, 0.0] }),
            (0.0..10.0f64).prop_map(|factor| FaultKind::GpsNoise { factor }),
            (1u8..=4, 0.0..=1.0f64).prop_map(|(motor, thrust)| FaultKind::MotorWeak { motor, thrust }),
            Just(FaultKind::ImuStop),
        ]
    }

    fn any_fault() -> impl Strategy<Value = Fault> {
        (0u32..40_000, prop::option::of(1u32..20_000), any_kind()).prop_map(|(at_ms, for_ms, kind)| Fault {
            at_s: f64::from(at_ms) * 1e-3,
            for_s: for_ms.map(|ms| f64::from(ms) * 1e-3),
            kind,
        })
    }

    proptest! {
        /// Polled at increasing times, every fault is reported started once its start has come
        /// and ended once its end has, never twice and never ended before started; and between
        /// polls it is active exactly when started and not ended.
        #[test]
        fn polling_agrees_with_the_windows(
            faults in prop::collection::vec(any_fault(), 0..8),
            mut polls in prop::collection::vec(0u64..70_000_000, 1..40),
        ) {
            polls.sort_unstable();
            let mut schedule = FaultSchedule::new(&faults);
            let mut started = vec![0u32; faults.len()];
            let mut ended = vec![0u32; faults.len()];
            let mut last = Time::ZERO;
            for &t in &polls {
                let now = Time(t);
                let events = schedule.poll(now);
                for e in &events {
                    prop_assert_eq!(e.time, now);
                    match e.phase {
                        SimFaultPhase::Started => {
                            prop_assert!(faults[e.index].start() <= now);
                            started[e.index] += 1;
                        }
                        SimFaultPhase::Ended => {
                            prop_assert!(faults[e.index].end().is_some_and(|end| end <= now));
                            prop_assert_eq!(started[e.index], 1);
                            ended[e.index] += 1;
                        }
                    }
                }
                for (i, f) in faults.iter().enumerate() {
                    prop_assert!(started[i] <= 1 && ended[i] <= 1);
                    prop_assert_eq!(started[i] == 1, f.start() <= now);
                    prop_assert_eq!(ended[i] == 1, f.end().is_some_and(|end| end <= now));
                    let active = schedule.active_at(now).any(|(j, _)| j == i);
                    prop_assert_eq!(active, started[i] == 1 && ended[i] == 0);
                    prop_assert_eq!(active, f.start() <= now && f.end().is_none_or(|end| now < end));
                }
                last = now;
            }
            prop_assert!(schedule.poll(last).is_empty(), "nothing twice");
        }

        /// The effects depend only on the faults active at the time: none active is no effect,
        /// and a motor's scale is the product of its active `motor_weak` thrusts.
        #[test]
        fn effects_are_those_of_the_active_faults(
            faults in prop::collection::vec(any_fault(), 0..8),
            t in 0u64..70_000_000,
        ) {
            let schedule = FaultSchedule::new(&faults);
            let now = Time(t);
            let effects = schedule.effects_at(now);
            let active: Vec<&Fault> = faults.iter().filter(|f| f.active_at(now)).collect();
            if active.is_empty() {
                prop_assert_eq!(&effects, &FaultEffects::default());
            }
            for motor in 1..=4u8 {
                let expected: f64 = active
                    .iter()
                    .filter_map(|f| match f.kind {
                        FaultKind::MotorWeak { motor: m, thrust } if m == motor => Some(thrust),
                        _ => None,
                    })
                    .product();
                prop_assert!((effects.motors.thrust_scale[usize::from(motor) - 1] - expected).abs() < 1e-12);
            }
            prop_assert_eq!(effects.imu.stopped, active.iter().any(|f| f.kind == FaultKind::ImuStop));
            prop_assert_eq!(effects.gps.off, active.iter().any(|f| f.kind == FaultKind::GpsOff));
        }
    }
}
