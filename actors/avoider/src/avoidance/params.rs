//! The avoider's parameters (`[actors.NAME.params]` of an `avoider` actor), with defaults that
//! follow the thesis where it gives a number and say so where it does not.

use std::path::PathBuf;

use serde::Deserialize;

use crate::avoidance::error::ParamsError;

/// Parameters of the avoider core and its actor shell.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AvoiderParams {
    /// Rule base file (fuzzylite FLL or our TOML), relative to the config file's directory;
    /// `None` uses the built-in `config/avoider/thesis.fll`. It must keep the thesis's
    /// interface: inputs `D_lu … D_rd` and `V_in`, outputs `Vx`, `Vy`, `Vz`, 18 rules.
    /// Used by the actor only.
    pub rules: Option<PathBuf>,
    /// Maximum horizontal speed of the vehicle (m/s): `V_in` is the desired speed over it, and
    /// a fuzzy output of ±1 is a correction of this many m/s. Thesis §3.3.2: 5 m/s.
    pub max_speed_m_s: f64,
    /// Time constant of the first-order low-pass on the correction (s); 0 turns it off. The
    /// thesis added a low-pass against spikes from noisy regions but gives no value (§3.3.9);
    /// 0.3 s spans about five frames at the stereo engine's 15 Hz.
    pub filter_time_constant_s: f64,
    /// Near-pixel share from which a region is blocked, 0..1: where the rule base's Gaussian
    /// Low and High terms cross (0.5).
    pub blocked_share: f64,
    /// Near-pixel share below which the centre counts as clear again and a climb ends, 0..1;
    /// below `blocked_share` so that the climb does not chatter at the threshold.
    pub climb_exit_share: f64,
    /// Climb rate while every region is blocked (m/s, up). Thesis §6 asks for a constant
    /// climb without a number; 1.5 m/s is half of PX4's default maximum climb rate.
    pub climb_speed_m_s: f64,
    /// Height climbed on once the centre has cleared (m): the centre band clears while the
    /// obstacle's top is still level with the airframe's underside.
    pub climb_margin_m: f64,
    /// Share of invalid (no disparity) pixels above which a region is unknown, 0..1.
    pub unknown_invalid_share: f64,
    /// Share of the desired speed the vehicle keeps while the view ahead is unknown, 0..1.
    /// 0 stops: no data ahead is no way ahead, as PX4's collision prevention treats a sector
    /// without data by default (`CP_GO_NO_DATA = 0`). "Unknown ahead" needs the centre *and*
    /// the region below it to be mostly invalid (see [`View::unknown_ahead`]), so open sky
    /// above the horizon does not stop the vehicle.
    ///
    /// [`View::unknown_ahead`]: crate::avoidance::View::unknown_ahead
    pub unknown_speed_share: f64,
    /// The distance ahead the view vouches for while the centre region is mostly invalid but
    /// the view ahead is not yet unknown (m): in level flight the centre is mostly sky, and a
    /// textureless wall looks the same until it hides the ground below the path. The plain
    /// wall of `config/worlds/wall-plain.toml` is first called unknown about 4.4 m out, so the
    /// commander's speed cap keeps the vehicle able to stop within less.
    pub unknown_range_m: f64,
    /// Height above the estimator's origin (the take-off ground; m) up to which the stereo pair
    /// matches the ground below the flight path. Above it that ground is too far for a
    /// disparity, so an invalid region below the centre says nothing about a textureless wall
    /// and the view ahead is not called unknown: the range vouched for is `unknown_range_m`
    /// ([`ClearRangeReason::GroundOutOfReach`]), as for a mostly invalid centre. The default
    /// is what a 320 × 240 rig with a 110° view and a 12 cm baseline matches, measured
    /// hovering over open ground in the simulator: the region below the centre was 36–58 %
    /// invalid from 10 to 12.5 m and 74–85 % (unknown) from 14.5 m; from 28 m every region was
    /// invalid, and a vehicle that climbed over a 25 m tree stopped above it for good. The VGA
    /// rig of `config/base/perception.toml` matches up to about 26 m and says so there. The
    /// height is above the ground: the downward rangefinder's, else above home, else above the
    /// estimator's origin ([`super::ground_height`]); without terrain data the ground is taken
    /// as flat at home's height.
    ///
    /// [`ClearRangeReason::GroundOutOfReach`]: kestrel_proto::messages::ClearRangeReason::GroundOutOfReach
    pub ground_match_height_m: f64,
    /// The vehicle stops this far short of the nearest depth in the centre region (m). Beyond
    /// the thesis, which only slows through the rule base: like PX4's collision prevention
    /// (`CP_DIST`), the forward speed is capped so that the vehicle can still brake in time.
    pub stop_distance_m: f64,
    /// Half the width of the corridor the vehicle flies (m): a sector's return that can lie
    /// within it of the forward axis bounds the clear range, and with it the commander's
    /// speed cap, as the centre's nearest depth does ([`ClearRangeReason::ObstacleInPath`],
    /// thin objects that fill too little of the centre region to reach its percentile). The
    /// avoider's own cap (`stop_distance_m`) and its blocked centre read the regions only.
    /// The 450 mm quad's collision radius (0.35 m) plus 0.4 m for the drift of a sidestep and
    /// the sector's bearing.
    ///
    /// [`ClearRangeReason::ObstacleInPath`]: kestrel_proto::messages::ClearRangeReason::ObstacleInPath
    pub path_half_width_m: f64,
    /// Deceleration the forward-speed cap assumes (m/s²); below the commander's 2.5 m/s² limit
    /// on changes of the velocity demand, so the cap is always reachable.
    pub brake_decel_m_s2: f64,
    /// Delay the cap allows for between a frame and the vehicle starting to brake (s): grid
    /// latency plus the position loop's response.
    pub reaction_time_s: f64,
    /// Lateral speed of a sidestep (m/s): with the path blocked and no way over or under given
    /// by the rule base (table 3.1 has no row for an obstacle only straight ahead, and none for
    /// a whole blocked centre column), the vehicle slides sideways until the path clears. 0
    /// turns the sidestep off (the thesis's behaviour: stop in front of the obstacle). The
    /// camera does not see sideways; the obstacle memory limits the slide towards what it saw
    /// (the speeds tried: decision 0038).
    pub sidestep_speed_m_s: f64,
    /// A sidestep that has slid this far (m, horizontally, from where it began; known only
    /// with the estimator's poses) with the path still blocked climbs instead, as when boxed
    /// in: the camera does not see sideways, and farther on lies what nearer trunks hid while
    /// it was in view: an unlimited slide of 4.4 m reached a trunk that had stood behind
    /// others. The climb it takes instead is safe to come down from only because the commander
    /// keeps a leg's descent inside the camera's centre band (`DESCENT_SLOPE`; decisions 0039
    /// and 0040).
    pub sidestep_max_m: f64,
    /// A depth nearer than this in the centre region (m) blocks the path even when its near
    /// share is small (a thin trunk), so the vehicle sidesteps rather than waits in front of it.
    pub sidestep_distance_m: f64,
    /// Obstacle points are remembered this long (s) after they were last seen or last within
    /// `sidestep_distance_m` of the vehicle; 0 turns the memory off. What the vehicle stays
    /// beside is kept however long it stays (a long hover must not forget the trunk beside
    /// it); what it left behind goes after this long (with 10 s a trunk abeam was forgotten
    /// during a hover a little farther off and hit on the next sidestep; decision 0038); what
    /// the camera sees again replaces it sooner, and
    /// `memory_range_m` drops what is left behind.
    pub memory_time_s: f64,
    /// Sector ranges up to this are remembered, and points farther from the vehicle are
    /// forgotten (m). A trunk 3 m beside the path leaves the 110° view about 6 m away, so 6 m
    /// missed one that a sidestep then ran into; beyond 10 m the camera sees
    /// again before the vehicle gets there.
    pub memory_range_m: f64,
    /// Remembered points count only while the vehicle is within this height of where it saw
    /// them from (m): the sectors are measured at the vehicle's level, about ±0.35 m per metre
    /// of range for the 110° VGA camera's centre band.
    pub memory_height_m: f64,
    /// The vehicle can always stop this far short of a remembered point (m): its own radius
    /// plus a margin. Smaller than `stop_distance_m`, which is measured ahead with the whole
    /// centre region, so that the vehicle still fits between trees 3 m apart.
    pub memory_stop_distance_m: f64,
    /// Depth grids older than this are ignored and the view counts as unknown (s): a few frames
    /// at 15 Hz plus the stereo engine's latency.
    pub max_grid_age_s: f64,
    /// Period of the actor's staleness check (s). Used by the actor only.
    pub check_period_s: f64,
}

impl Default for AvoiderParams {
    fn default() -> AvoiderParams {
        AvoiderParams {
            rules: None,
            max_speed_m_s: 5.0,
            filter_time_constant_s: 0.3,
            blocked_share: 0.5,
            climb_exit_share: 0.3,
            climb_speed_m_s: 1.5,
            climb_margin_m: 1.0,
            unknown_invalid_share: 0.7,
            unknown_speed_share: 0.0,
            unknown_range_m: 4.0,
            ground_match_height_m: 12.0,
            stop_distance_m: 2.0,
            path_half_width_m: 0.75,
            brake_decel_m_s2: 2.0,
            reaction_time_s: 0.3,
            sidestep_speed_m_s: 1.0,
            sidestep_distance_m: 4.0,
            sidestep_max_m: 3.5,
            memory_time_s: 30.0,
            memory_range_m: 10.0,
            memory_height_m: 1.5,
            memory_stop_distance_m: 1.0,
            max_grid_age_s: 0.5,
            check_period_s: 0.1,
        }
    }
}

impl AvoiderParams {
    /// Checks every value, naming the first bad one.
    pub fn validate(&self) -> Result<(), ParamsError> {
        let positive = [
            ("max_speed_m_s", self.max_speed_m_s),
            ("climb_speed_m_s", self.climb_speed_m_s),
            ("brake_decel_m_s2", self.brake_decel_m_s2),
            ("max_grid_age_s", self.max_grid_age_s),
            ("check_period_s", self.check_period_s),
            ("memory_range_m", self.memory_range_m),
            ("sidestep_max_m", self.sidestep_max_m),
            ("memory_height_m", self.memory_height_m),
            ("ground_match_height_m", self.ground_match_height_m),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ParamsError { field, value, expected: "a finite value > 0" });
            }
        }
        let non_negative = [
            ("filter_time_constant_s", self.filter_time_constant_s),
            ("stop_distance_m", self.stop_distance_m),
            ("path_half_width_m", self.path_half_width_m),
            ("unknown_range_m", self.unknown_range_m),
            ("reaction_time_s", self.reaction_time_s),
            ("sidestep_distance_m", self.sidestep_distance_m),
            ("sidestep_speed_m_s", self.sidestep_speed_m_s),
            ("memory_time_s", self.memory_time_s),
            ("climb_margin_m", self.climb_margin_m),
            ("memory_stop_distance_m", self.memory_stop_distance_m),
        ];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParamsError { field, value, expected: "a finite value ≥ 0" });
            }
        }
        let shares = [
            ("blocked_share", self.blocked_share),
            ("climb_exit_share", self.climb_exit_share),
            ("unknown_invalid_share", self.unknown_invalid_share),
            ("unknown_speed_share", self.unknown_speed_share),
        ];
        for (field, value) in shares {
            if !(0.0..=1.0).contains(&value) {
                return Err(ParamsError { field, value, expected: "a share in 0..1" });
            }
        }
        if self.climb_exit_share > self.blocked_share {
            return Err(ParamsError {
                field: "climb_exit_share",
                value: self.climb_exit_share,
                expected: "at most blocked_share",
            });
        }
        Ok(())
    }
}
