//! The desired horizontal speed the rule base's `V_in` is made of, read from the commander's
//! setpoint.

use kestrel_proto::messages::{Setpoint, SetpointTarget};

use crate::avoidance::error::SetpointError;

/// The horizontal speed `setpoint` asks for (m/s): the trajectory's `desired_speed_m_s` where
/// the commander gives it (a leg flown with the avoider), otherwise the norm of its north and
/// east velocity. An axis without a velocity (held in position) contributes nothing; a setpoint that
/// is not a trajectory (motors off, the pilot flying rates or attitude) or is disarmed asks for
/// none. The camera looks forward and missions fly nose first, so this speed is taken as
/// forward speed.
pub fn desired_speed_m_s(setpoint: &Setpoint) -> Result<f64, SetpointError> {
    let SetpointTarget::Trajectory(trajectory) = &setpoint.target else {
        return Ok(0.0);
    };
    for (axis, velocity) in ["north", "east", "down"].into_iter().zip(trajectory.velocity_ned_m_s) {
        if let Some(value) = velocity
            && !value.is_finite()
        {
            return Err(SetpointError::NotFinite { axis, value });
        }
    }
    if !setpoint.armed {
        return Ok(0.0);
    }
    if let Some(desired) = trajectory.desired_speed_m_s {
        return if desired.is_finite() && desired >= 0.0 {
            Ok(desired)
        } else {
            Err(SetpointError::BadDesiredSpeed { value: desired })
        };
    }
    let [north, east, _] = trajectory.velocity_ned_m_s.map(|v| v.unwrap_or(0.0));
    Ok(north.hypot(east))
}
