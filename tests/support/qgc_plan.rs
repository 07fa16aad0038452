//! QGroundControl `.plan` files for flight tests: mission items around the simulator's home
//! (config/sim.toml), written as QGroundControl writes them.

#![allow(dead_code, reason = "each flight test binary uses only the commands it flies")]

use std::path::{Path, PathBuf};

/// The simulator's home (degrees): the University of Moratuwa.
pub const HOME_DEG: (f64, f64) = (6.7971, 79.9017);
/// Degrees of latitude per metre north, near enough for test legs of tens of metres.
pub const DEG_PER_M_NORTH: f64 = 1.0 / 111_000.0;

/// Degrees of longitude per metre east at home's latitude, as near as [`DEG_PER_M_NORTH`].
pub fn deg_per_m_east() -> f64 {
    DEG_PER_M_NORTH / HOME_DEG.0.to_radians().cos()
}

/// MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_RETURN_TO_LAUNCH, MAV_CMD_NAV_LAND, MAV_CMD_NAV_TAKEOFF.
pub const WAYPOINT: u32 = 16;
pub const RETURN_TO_LAUNCH: u32 = 20;
pub const LAND: u32 = 21;
pub const TAKEOFF: u32 = 22;

/// One mission item: its command, hold time (s, param 1) and place (altitude above home, m).
pub struct Item {
    pub command: u32,
    pub hold_s: f64,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub alt_m: f64,
}

impl Item {
    /// `command` at `metres_north` of home, `alt_m` above it.
    pub fn north(command: u32, metres_north: f64, alt_m: f64) -> Item {
        Item {
            command,
            hold_s: 0.0,
            lat_deg: HOME_DEG.0 + metres_north * DEG_PER_M_NORTH,
            lon_deg: HOME_DEG.1,
            alt_m,
        }
    }

    /// `command` `metres` from home along the bearing `heading_deg` (clockwise from north),
    /// `alt_m` above it.
    pub fn along(command: u32, heading_deg: f64, metres: f64, alt_m: f64) -> Item {
        let (sin, cos) = heading_deg.to_radians().sin_cos();
        Item {
            command,
            hold_s: 0.0,
            lat_deg: HOME_DEG.0 + metres * cos * DEG_PER_M_NORTH,
            lon_deg: HOME_DEG.1 + metres * sin * deg_per_m_east(),
            alt_m,
        }
    }
}

/// A straight leg of `metres` along the bearing `heading_deg` at `alt_m`, written into `dir`:
/// take off, one waypoint, land there, at `write`'s 5 m/s cruise (the avoider's
/// `max_speed_m_s`).
pub fn leg(dir: &Path, heading_deg: f64, metres: f64, alt_m: f64) -> PathBuf {
    write(
        dir,
        &format!("leg-{heading_deg}deg-{metres}m-5ms.plan"),
        &[
            Item::along(TAKEOFF, heading_deg, 0.0, alt_m),
            Item::along(WAYPOINT, heading_deg, metres, alt_m),
            Item::along(LAND, heading_deg, metres, 0.0),
        ],
    )
}

/// Writes `items` as `dir/name` and returns its path.
pub fn write(dir: &Path, name: &str, items: &[Item]) -> PathBuf {
    let items: Vec<serde_json::Value> = items
        .iter()
        .zip(1u32..)
        .map(|(i, id)| {
            serde_json::json!({
                "type": "SimpleItem", "autoContinue": true, "command": i.command, "doJumpId": id,
                "frame": 3, "params": [i.hold_s, 0, 0, null, i.lat_deg, i.lon_deg, i.alt_m],
                "AMSLAltAboveTerrain": null, "Altitude": i.alt_m, "AltitudeMode": 1
            })
        })
        .collect();
    let plan = serde_json::json!({
        "fileType": "Plan", "groundStation": "QGroundControl", "version": 1,
        "geoFence": { "circles": [], "polygons": [], "version": 2 },
        "rallyPoints": { "points": [], "version": 2 },
        "mission": {
            "cruiseSpeed": 5, "hoverSpeed": 5, "firmwareType": 12, "vehicleType": 2, "version": 2,
            "globalPlanAltitudeMode": 1, "plannedHomePosition": [HOME_DEG.0, HOME_DEG.1, 20],
            "items": items
        }
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string_pretty(&plan).expect("a plan is JSON"))
        .expect("write the plan");
    path
}
