//! EKF_STATUS_REPORT: what the estimate is good for, and how its observations pass their gates.

use kestrel_proto::messages::{EstimatorStatus, Innovation, NavState};
use mavlink::dialects::ardupilotmega::{EKF_STATUS_REPORT_DATA, EkfStatusFlags};

/// EKF_STATUS_REPORT as ArduPilot fills it: flags for what the estimate is good for, from the
/// NavState's validity, and "variances" that are the square roots of the innovation test ratios
/// (below 1 the observations pass their gates; ground stations turn the bars amber at 0.5 and
/// red at 0.8), the largest of each group, 0 until the estimator reports any.
pub fn ekf_status(nav: &NavState, estimator: Option<&EstimatorStatus>) -> EKF_STATUS_REPORT_DATA {
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

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::NavValidity;

    use super::*;
    use crate::services::telemetry::encode::nav_facing_east;

    #[test]
    fn ekf_status_report_flags_what_the_estimate_is_good_for_and_roots_the_test_ratios() {
        let mut good = nav_facing_east();
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
