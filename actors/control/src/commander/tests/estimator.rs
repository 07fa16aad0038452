//! The estimator's state going stale: the backup attitude flown, and the landing it brings.

use kestrel_proto::Time;
use kestrel_proto::messages::{FailsafeCause, FlightMode, LandedState, SetpointTarget};

use super::fixtures::{hovering, nav};

/// The controller's backup attitude (a state without horizontal position) while the estimator's
/// is stale: announced once, the staleness still lands, the landing descends without a
/// horizontal target, and the land detector ends it on the backup's vertical channel.
#[test]
fn the_backup_attitude_is_flown_while_the_estimator_is_stale_and_lands_the_vehicle() {
    let mut c = hovering();
    let refusals = c.status(Time(2000)).refusals;
    // While the estimator is fresh the backup's states are ignored.
    c.on_backup_nav(&nav(Time(2500), -4.0, false));
    assert!(!c.on_backup_attitude());
    let mut t = 2000;
    let mut down = -5.0;
    let mut landing_target = None;
    while c.armed() && t < 30_000_000 {
        t += 2500;
        if t > 100_000 {
            // The estimator is gone: the backup sinks at 1 m/s to the ground at 0, then stands.
            down = f64::min(down + 0.0025, 0.0);
            let mut backup = nav(Time(t), down, false);
            backup.velocity_ned_m_s[2] = if down < 0.0 { 1.0 } else { 0.0 };
            c.on_backup_nav(&backup);
        }
        let sp = c.update(Time(t));
        if c.mode() == FlightMode::Land && c.armed() {
            landing_target = Some(sp.target);
        }
    }
    assert!(c.on_backup_attitude());
    let status = c.status(Time(t));
    assert_eq!(status.refusals, refusals + 1, "announced once: {:?}", status.last_refusal);
    assert_eq!(c.failsafe_log().first().map(|r| r.cause), Some(FailsafeCause::NavStateStale));
    assert!(!c.armed() && c.landed() == LandedState::OnGround, "landed on the backup's vertical channel");
    let Some(SetpointTarget::Trajectory(sp)) = landing_target else { panic!("{landing_target:?}") };
    assert_eq!(sp.position_ned_m[..2], [None, None], "no horizontal target without a position: {sp:?}");
    assert!(sp.velocity_ned_m_s[2].is_some_and(|v| v > 0.0), "descending: {sp:?}");
}
