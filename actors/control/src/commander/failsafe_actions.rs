//! Each failsafe's action as a live parameter, numbered as the flight stack whose users know it
//! numbers it: ArduCopter's `FS_GCS_ENABLE`, `FS_THR_ENABLE`, `BATT_FS_LOW_ACT`,
//! `BATT_FS_CRT_ACT`, `FS_EKF_ACTION` and `FENCE_ACTION` (we report ArduCopter's dialect, so
//! QGroundControl and MAVProxy show these names), and PX4's `COM_ACT_FAIL_ACT` for a failed motor,
//! which ArduCopter has no parameter for.
//!
//! A parameter takes exactly the codes whose meaning Kestrel flies; any other value is refused
//! naming what it means and what may be chosen, and the old action stays. Refused on purpose:
//! SmartRTL and DO_LAND_START returns (Kestrel keeps no breadcrumb path and no landing
//! sequence), ArduCopter's "continue mission" (gone since 4.0, `FS_OPTIONS` replaced it) and
//! Terminate: a failsafe ends in a controlled state and never stops the motors in the air.
//!
//! Codes and Kestrel's actions differ in two places, said here once:
//! * ArduCopter's "brake or land" is [`FailsafeAction::Hold`]: the vehicle stops and holds its
//!   position, and without a position it holds its altitude (ALT_HOLD), as `FS_EKF_ACTION` 2 does;
//! * "RTL or land" and "RTL" are one action: RTL falls back to LAND wherever it cannot fly.

use kestrel_proto::messages::FailsafeAction;

/// One parameter's codes.
pub(crate) struct ActionCodes {
    pub name: &'static str,
    /// The codes taken, each with its action and what the ground station's user reads.
    pub taken: &'static [(u8, FailsafeAction, &'static str)],
    /// The codes the stack this numbering comes from knows and Kestrel refuses, with why.
    pub refused: &'static [(u8, &'static str)],
}

impl ActionCodes {
    /// The action for `value`, if it is exactly one of the codes taken.
    pub fn action(&self, value: f64) -> Option<FailsafeAction> {
        self.taken.iter().find(|(code, _, _)| f64::from(*code) == value).map(|&(_, action, _)| action)
    }

    /// The code of `action`, if this parameter can express it.
    pub fn code(&self, action: FailsafeAction) -> Option<u8> {
        self.taken.iter().find(|(_, a, _)| *a == action).map(|&(code, _, _)| code)
    }

    /// Smallest and largest code taken: the range `live_params` must declare.
    #[cfg(test)]
    pub fn bounds(&self) -> (f64, f64) {
        let codes = self.taken.iter().map(|(code, _, _)| f64::from(*code));
        (codes.clone().fold(f64::INFINITY, f64::min), codes.fold(f64::NEG_INFINITY, f64::max))
    }

    /// Why `value` is not taken, naming what it means where it has a meaning elsewhere.
    pub fn why_not(&self, value: f64) -> String {
        let choices: Vec<String> =
            self.taken.iter().map(|(code, _, what)| format!("{code} ({what})")).collect();
        let meaning = self
            .refused
            .iter()
            .find(|(code, _)| f64::from(*code) == value)
            .map_or(String::new(), |(_, why)| format!(" ({why})"));
        format!("{value}{meaning} is not an action Kestrel flies; choose {}", choices.join(", "))
    }

    /// The same as a refusal of `action` set in a configuration file.
    pub fn why_not_action(&self, action: FailsafeAction) -> String {
        let choices: Vec<&str> = self.taken.iter().map(|(_, _, what)| *what).collect();
        format!("{action:?} has no {} code; choose {}", self.name, choices.join(", "))
    }
}

const SMART_RTL: &str = "SmartRTL: Kestrel keeps no breadcrumb path";
const LAND_START: &str = "DO_LAND_START: Kestrel has no landing sequence";
const TERMINATE: &str = "Terminate: a failsafe never stops the motors in the air";
const CONTINUE: &str = "continue mission: removed in ArduCopter 4.0";

/// `FS_GCS_ENABLE`: losing the ground station's heartbeats.
pub(crate) const GCS: ActionCodes = ActionCodes {
    name: "FS_GCS_ENABLE",
    taken: &[
        (0, FailsafeAction::Warn, "report only"),
        (1, FailsafeAction::ReturnToLaunch, "RTL"),
        (5, FailsafeAction::Land, "land"),
        (7, FailsafeAction::Hold, "brake and hold"),
    ],
    refused: &[(2, CONTINUE), (3, SMART_RTL), (4, SMART_RTL), (6, LAND_START)],
};

/// `FS_THR_ENABLE`: losing the sticks (RC or MAVLink MANUAL_CONTROL) while flown from them.
pub(crate) const STICKS: ActionCodes = ActionCodes {
    name: "FS_THR_ENABLE",
    taken: &[
        (0, FailsafeAction::Warn, "report only"),
        (1, FailsafeAction::ReturnToLaunch, "RTL"),
        (3, FailsafeAction::Land, "land"),
        (7, FailsafeAction::Hold, "brake and hold"),
    ],
    refused: &[(2, CONTINUE), (4, SMART_RTL), (5, SMART_RTL), (6, LAND_START)],
};

/// `BATT_FS_LOW_ACT` and `BATT_FS_CRT_ACT` (one numbering): a battery under its threshold.
pub(crate) const BATTERY_CODES: &[(u8, FailsafeAction, &str)] = &[
    (0, FailsafeAction::Warn, "report only"),
    (1, FailsafeAction::Land, "land"),
    (2, FailsafeAction::ReturnToLaunch, "RTL"),
    (7, FailsafeAction::Hold, "brake and hold"),
];
const BATTERY_REFUSED: &[(u8, &str)] = &[(3, SMART_RTL), (4, SMART_RTL), (5, TERMINATE), (6, LAND_START)];

/// `BATT_FS_LOW_ACT`.
pub(crate) const BATTERY_LOW: ActionCodes =
    ActionCodes { name: "BATT_FS_LOW_ACT", taken: BATTERY_CODES, refused: BATTERY_REFUSED };

/// `BATT_FS_CRT_ACT`.
pub(crate) const BATTERY_CRITICAL: ActionCodes =
    ActionCodes { name: "BATT_FS_CRT_ACT", taken: BATTERY_CODES, refused: BATTERY_REFUSED };

/// `FS_EKF_ACTION`: an estimate the estimator cannot vouch for. ArduCopter's 3 ("land even in
/// STABILIZE") is refused: a lost attitude lands in every mode here, a lost position only in
/// the modes that need one, which is its 1.
pub(crate) const ESTIMATOR: ActionCodes = ActionCodes {
    name: "FS_EKF_ACTION",
    taken: &[(1, FailsafeAction::Land, "land"), (2, FailsafeAction::Hold, "hold altitude")],
    refused: &[(3, "land even in STABILIZE: 1 already lands in every mode that needs the estimate")],
};

/// `FENCE_ACTION`: outside the geofence.
pub(crate) const FENCE: ActionCodes = ActionCodes {
    name: "FENCE_ACTION",
    taken: &[
        (0, FailsafeAction::Warn, "report only"),
        (1, FailsafeAction::ReturnToLaunch, "RTL or land"),
        (2, FailsafeAction::Land, "land"),
        (4, FailsafeAction::Hold, "brake and hold"),
    ],
    refused: &[(3, SMART_RTL), (5, SMART_RTL)],
};

/// `COM_ACT_FAIL_ACT` (PX4): a failed motor the others cannot fly around (a quad).
pub(crate) const MOTOR: ActionCodes = ActionCodes {
    name: "COM_ACT_FAIL_ACT",
    taken: &[
        (0, FailsafeAction::Warn, "warning only"),
        (1, FailsafeAction::Hold, "hold"),
        (2, FailsafeAction::Land, "land"),
        (3, FailsafeAction::ReturnToLaunch, "return"),
    ],
    refused: &[(4, TERMINATE)],
};

/// Every action parameter.
pub(crate) const ALL: [&ActionCodes; 7] =
    [&GCS, &STICKS, &BATTERY_LOW, &BATTERY_CRITICAL, &ESTIMATOR, &FENCE, &MOTOR];

/// The action parameter called `name`, if there is one.
pub(crate) fn named(name: &str) -> Option<&'static ActionCodes> {
    ALL.into_iter().find(|codes| codes.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_taken_round_trips_and_no_table_disarms() {
        for codes in ALL {
            for &(code, action, _) in codes.taken {
                assert_eq!(codes.action(f64::from(code)), Some(action), "{}", codes.name);
                assert_eq!(codes.code(action), Some(code), "{}: one code per action", codes.name);
                assert!(
                    !codes.refused.iter().any(|(r, _)| *r == code),
                    "{}: {code} taken and refused",
                    codes.name
                );
            }
            assert_eq!(codes.code(FailsafeAction::Disarm), None, "{} can disarm", codes.name);
            let (lo, hi) = codes.bounds();
            assert!(lo <= hi && codes.action(lo).is_some() && codes.action(hi).is_some(), "{}", codes.name);
        }
    }

    #[test]
    fn values_between_or_outside_the_codes_are_refused_naming_what_they_mean() {
        for bad in [0.5, 1.000_001, -1.0, 8.0, f64::NAN, f64::INFINITY] {
            assert_eq!(GCS.action(bad), None, "{bad}");
        }
        let why = BATTERY_CRITICAL.why_not(5.0);
        assert!(why.contains("Terminate") && why.contains("1 (land)"), "{why}");
        assert!(GCS.why_not(3.0).contains("SmartRTL"), "{}", GCS.why_not(3.0));
        assert!(GCS.why_not(9.0).starts_with("9 is not"), "{}", GCS.why_not(9.0));
        assert!(ESTIMATOR.why_not_action(FailsafeAction::ReturnToLaunch).contains("FS_EKF_ACTION"));
        assert_eq!(named("FENCE_ACTION").map(|c| c.name), Some("FENCE_ACTION"));
        assert!(named("RTL_ALT_M").is_none());
    }
}
