//! What the estimator noticed, as events for the flight report: the start of each run of
//! rejections per aiding source, GPS lost, dead reckoning, the barometer or GPS height found
//! faulty, a GPS position reset refused for its length, an IMU
//! gap, a numerical fault. Taken from `estimator_status` (its counters and health flags), so a
//! fault the estimator handles without any failsafe still shows when it was detected.

use kestrel_proto::messages::EstimatorStatus;
use serde::{Deserialize, Serialize};

/// One thing the estimator noticed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EstimatorEvent {
    /// IMU time of the status that showed it (s).
    pub t_s: f64,
    /// `gps_rejected`, `baro_rejected`, `mag_rejected` (a run of rejections began), `gps_lost`,
    /// `dead_reckoning`, `baro_faulty`, `gps_height_faulty` (GPS height refused, the barometer
    /// kept), `gps_reset_refused` (a GPS position reset longer than `EKF2_GPS_RST_M`), `imu_gap`,
    /// `imu_switched`, `warm_start`, `realigned`, `numerical_fault`.
    pub event: String,
}

/// Turns consecutive statuses into events.
#[derive(Clone, Debug, Default)]
pub struct EstimatorEvents {
    previous: Option<EstimatorStatus>,
    /// Per source (GPS, baro, mag): inside a run of rejections, which ends only when the source
    /// fuses again or is reset to. A status without new rejections does not end it: statuses
    /// come at 10 Hz and GPS samples at 5 Hz, so every other status of a rejection carries none
    /// (`a_run_of_rejections_ends_when_the_source_fuses_again`).
    rejecting: [bool; 3],
    pub log: Vec<EstimatorEvent>,
}

impl EstimatorEvents {
    /// Takes the next status; events start at the first status after alignment.
    pub fn on_status(&mut self, s: &EstimatorStatus) {
        if !s.health.tilt_aligned {
            return;
        }
        let Some(p) = self.previous.replace(s.clone()) else { return };
        let t_s = s.time.as_secs_f64();
        let mut push = |event: &str| self.log.push(EstimatorEvent { t_s, event: event.to_owned() });
        let sources = [
            (&s.gps, &p.gps, "gps_rejected"),
            (&s.baro, &p.baro, "baro_rejected"),
            (&s.mag, &p.mag, "mag_rejected"),
        ];
        for (i, (now, before, name)) in sources.into_iter().enumerate() {
            let rejected = now.rejected > before.rejected;
            let recovered = now.fused > before.fused || now.resets > before.resets;
            if rejected && !self.rejecting[i] {
                push(name);
                self.rejecting[i] = true;
            } else if recovered && !rejected {
                self.rejecting[i] = false;
            }
        }
        let (h, ph) = (&s.health, &p.health);
        let edges = [
            (ph.gps_fusing && !h.gps_fusing, "gps_lost"),
            (!ph.dead_reckoning && h.dead_reckoning, "dead_reckoning"),
            (!ph.baro_faulty && h.baro_faulty, "baro_faulty"),
            (!ph.gps_height_faulty && h.gps_height_faulty, "gps_height_faulty"),
            (ph.gps_reset_refused_m.is_none() && h.gps_reset_refused_m.is_some(), "gps_reset_refused"),
            (h.imu_gaps > ph.imu_gaps, "imu_gap"),
            (h.imu_switches > ph.imu_switches, "imu_switched"),
            (h.warm_starts > ph.warm_starts, "warm_start"),
            (h.realignments > ph.realignments, "realigned"),
            (h.numerical_faults > ph.numerical_faults, "numerical_fault"),
        ];
        for (rose, name) in edges {
            if rose {
                push(name);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kestrel_proto::Time;

    fn status(t: f64, gps_rejected: u64, gps_fusing: bool, baro_faulty: bool) -> EstimatorStatus {
        let mut s = EstimatorStatus { time: Time::from_secs_f64(t), ..EstimatorStatus::default() };
        s.health.tilt_aligned = true;
        s.health.gps_fusing = gps_fusing;
        s.health.baro_faulty = baro_faulty;
        s.gps.rejected = gps_rejected;
        s
    }

    fn events(e: &EstimatorEvents) -> Vec<(f64, &str)> {
        e.log.iter().map(|v| (v.t_s, v.event.as_str())).collect()
    }

    #[test]
    fn a_run_of_rejections_is_one_event_and_edges_are_events() {
        let mut e = EstimatorEvents::default();
        for (t, rejected, fused, fusing, faulty) in [
            (1.0, 0, 10, true, false),
            (1.5, 1, 10, true, false),
            (2.0, 3, 10, true, false),
            (2.5, 3, 11, true, false),
            (3.0, 4, 11, false, true),
            (3.5, 4, 11, false, true),
        ] {
            let mut s = status(t, rejected, fusing, faulty);
            s.gps.fused = fused;
            e.on_status(&s);
        }
        assert_eq!(
            events(&e),
            [(1.5, "gps_rejected"), (3.0, "gps_rejected"), (3.0, "gps_lost"), (3.0, "baro_faulty")]
        );
    }

    #[test]
    fn a_run_of_rejections_ends_when_the_source_fuses_again() {
        // GPS at half the status rate: a long rejection shows new rejections in every
        // other status only, and stays one run until a sample is fused or the state is reset.
        let mut e = EstimatorEvents::default();
        let mut rejected = 0;
        for k in 0..40u32 {
            rejected += u64::from(k % 2);
            e.on_status(&status(1.0 + 0.25 * f64::from(k), rejected, true, false));
        }
        let mut fused = status(11.0, rejected, true, false);
        fused.gps.fused = 1;
        e.on_status(&fused);
        e.on_status(&status(11.25, rejected + 1, true, false));
        let mut reset = status(11.5, rejected + 1, true, false);
        reset.gps.fused = 1;
        reset.gps.resets = 1;
        e.on_status(&reset);
        let mut after_reset = reset.clone();
        after_reset.time = Time::from_secs_f64(11.75);
        after_reset.gps.rejected += 1;
        e.on_status(&after_reset);
        assert_eq!(events(&e), [(1.25, "gps_rejected"), (11.25, "gps_rejected"), (11.75, "gps_rejected")]);
    }

    #[test]
    fn a_refused_gps_reset_and_a_refused_gps_height_are_one_event_each() {
        let mut e = EstimatorEvents::default();
        for (t, refused, height) in
            [(1.0, None, false), (2.0, Some(2000), true), (3.0, Some(1990), true), (4.0, None, false)]
        {
            let mut s = status(t, 0, true, false);
            s.health.gps_reset_refused_m = refused;
            s.health.gps_height_faulty = height;
            e.on_status(&s);
        }
        let got: Vec<(f64, &str)> = e.log.iter().map(|v| (v.t_s, v.event.as_str())).collect();
        assert_eq!(got, [(2.0, "gps_height_faulty"), (2.0, "gps_reset_refused")]);
    }
}
