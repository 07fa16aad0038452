//! STATUSTEXT for what the estimator found that a pilot must know: the barometer found faulty
//! (height from GPS), GPS height refused (the barometer kept), and a GPS position reset refused
//! for moving the position further than `EKF2_GPS_RST_M` (the position is then invalid and the
//! commander's estimator failsafe acts). Said once, when each begins.

use kestrel_proto::messages::EstimatorHealth;

/// The texts for what began between two healths (`old = None`: the first one, nothing began).
pub fn estimator_changes(old: Option<&EstimatorHealth>, new: &EstimatorHealth) -> Vec<String> {
    let Some(old) = old else { return Vec::new() };
    let mut out = Vec::new();
    if !old.baro_faulty && new.baro_faulty {
        out.push("EKF: baro faulty, height from GPS".to_owned());
    }
    if !old.gps_height_faulty && new.gps_height_faulty {
        out.push("EKF: GPS height refused, baro kept".to_owned());
    }
    if let (None, Some(m)) = (old.gps_reset_refused_m, new.gps_reset_refused_m) {
        out.push(format!("EKF: GPS jump of {m} m refused, position invalid"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_finding_is_said_once_when_it_begins() {
        let calm = EstimatorHealth::default();
        let refused = EstimatorHealth { gps_reset_refused_m: Some(2000), ..calm };
        assert!(estimator_changes(None, &refused).is_empty());
        assert_eq!(
            estimator_changes(Some(&calm), &refused),
            ["EKF: GPS jump of 2000 m refused, position invalid"]
        );
        let still = EstimatorHealth { gps_reset_refused_m: Some(1995), ..calm };
        assert!(estimator_changes(Some(&refused), &still).is_empty(), "the distance moving is no news");
        let height = EstimatorHealth { gps_height_faulty: true, ..calm };
        assert_eq!(estimator_changes(Some(&calm), &height), ["EKF: GPS height refused, baro kept"]);
        let baro = EstimatorHealth { baro_faulty: true, ..calm };
        assert_eq!(estimator_changes(Some(&calm), &baro), ["EKF: baro faulty, height from GPS"]);
        assert!(estimator_changes(Some(&baro), &calm).is_empty());
    }
}
