//! Parameters a ground station may change in flight (MAVLink `PARAM_SET`, through the link's
//! `param_set` topic), mapped onto [`CommanderParams`] fields. Names follow ArduPilot's where one
//! exists, with the unit spelled out, so QGroundControl and MAVProxy users recognise them. The
//! link checks each value against the range in its parameter table; the commander checks it
//! again against its own field validation, and a change that would make the parameters invalid
//! is refused and the old value kept.

use super::params::CommanderParams;
use crate::error::InvalidParam;

/// A named field of [`CommanderParams`] that can change live.
struct LiveParam {
    name: &'static str,
    field: fn(&mut CommanderParams) -> &mut f64,
}

/// Every live parameter, by MAVLink name.
const LIVE_PARAMS: [LiveParam; 8] = [
    LiveParam { name: "RTL_ALT_M", field: |p| &mut p.rtl_altitude_m },
    LiveParam { name: "RTL_SPEED_M_S", field: |p| &mut p.rtl_speed_m_s },
    LiveParam { name: "TKOFF_ALT_M", field: |p| &mut p.takeoff_altitude_m },
    LiveParam { name: "WPNAV_SPEED_M_S", field: |p| &mut p.guided_speed_m_s },
    LiveParam { name: "FS_GCS_TIMEOUT_S", field: |p| &mut p.failsafe.link_timeout_s },
    LiveParam { name: "BATT_LOW_FRAC", field: |p| &mut p.failsafe.battery_low },
    LiveParam { name: "FENCE_RADIUS_M", field: |p| &mut p.geofence.max_radius_m },
    LiveParam { name: "FENCE_ALT_MAX_M", field: |p| &mut p.geofence.max_altitude_m },
];

/// What a `PARAM_SET` did.
#[derive(Debug, PartialEq)]
pub enum ParamChange {
    /// The field now holds the value.
    Applied,
    /// Not a commander parameter (another actor may own it).
    NotMine,
}

/// Sets the live parameter `name` to `value` in `params`, keeping the old value when the result
/// would not validate.
pub fn apply(params: &mut CommanderParams, name: &str, value: f64) -> Result<ParamChange, InvalidParam> {
    let Some(live) = LIVE_PARAMS.iter().find(|p| p.name == name) else {
        return Ok(ParamChange::NotMine);
    };
    let mut changed = params.clone();
    *(live.field)(&mut changed) = value;
    changed.validate()?;
    *params = changed;
    Ok(ParamChange::Applied)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_live_change_applies_and_an_invalid_one_keeps_the_old_value() {
        let mut params = CommanderParams::default();
        assert_eq!(apply(&mut params, "RTL_ALT_M", 25.0), Ok(ParamChange::Applied));
        assert_eq!(params.rtl_altitude_m, 25.0);
        assert_eq!(apply(&mut params, "SYSID_THISMAV", 3.0), Ok(ParamChange::NotMine));
        let before = params.clone();
        assert!(apply(&mut params, "RTL_ALT_M", f64::NAN).is_err());
        assert!(apply(&mut params, "BATT_LOW_FRAC", 7.0).is_err(), "a share above 1 is refused");
        assert_eq!(params, before);
    }
}
