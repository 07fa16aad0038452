//! The world file: where home is, its magnetic field, the wind, the obstacles and the faults
//! injected during the run.

use std::path::Path;

use kestrel_proto::geo::Geodetic;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::config_file;
use crate::error::{ConfigError, InvalidParam, finite, positive};
use crate::faults::{self, Fault, FaultKind};
use crate::forest::Forest;
use crate::obstacles::{Obstacle, ObstacleGeometry};
use crate::wind::WindParams;

/// The world the vehicle flies in, as `config/worlds/*.toml` describes it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct World {
    /// `[home]`: origin of the NED frame and ground altitude.
    pub home: Home,
    /// `[magnetic_field]`: the Earth's field at home.
    pub magnetic_field: MagneticField,
    /// `[wind]`: steady wind and gusts.
    pub wind: WindParams,
    /// `[[obstacles]]`: boxes, cylinders and walls; none by default.
    pub obstacles: Vec<Obstacle>,
    /// `[forest]`: random trees from a seed, added to `obstacles` when the file is loaded.
    pub forest: Option<Forest>,
    /// `[[faults]]`: what breaks during the run, and when (`faults.rs`); none by default.
    pub faults: Vec<Fault>,
}

/// The origin of the local NED frame; the ground is flat at its altitude.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Home {
    /// WGS-84 latitude (degrees, north positive).
    pub lat_deg: f64,
    /// WGS-84 longitude (degrees, east positive).
    pub lon_deg: f64,
    /// Ground altitude above mean sea level (m).
    pub alt_msl_m: f64,
}

impl Default for Home {
    /// The University of Moratuwa, Sri Lanka, where the thesis flew.
    fn default() -> Home {
        Home { lat_deg: 6.79710, lon_deg: 79.90170, alt_msl_m: 20.0 }
    }
}

impl Home {
    pub fn geodetic(&self) -> Geodetic {
        Geodetic { lat_deg: self.lat_deg, lon_deg: self.lon_deg, alt_m: self.alt_msl_m }
    }
}

/// The Earth's field at home, as a magnetic model gives it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MagneticField {
    /// Total intensity (gauss; 1 G = 100 µT).
    pub total_intensity_gauss: f64,
    /// Angle from true north to magnetic north, east positive (degrees).
    pub declination_deg: f64,
    /// Angle of the field below the horizontal, down positive (degrees).
    pub inclination_deg: f64,
}

impl Default for MagneticField {
    /// Approximate World Magnetic Model (WMM2025) values for Moratuwa: the site lies just
    /// south of the magnetic dip equator, so the field is almost horizontal and points slightly
    /// up. Check a current model before relying on the last digit.
    fn default() -> MagneticField {
        MagneticField { total_intensity_gauss: 0.410, declination_deg: -2.0, inclination_deg: -3.5 }
    }
}

impl MagneticField {
    /// The field vector in NED (gauss).
    pub fn ned_gauss(&self) -> Vector3<f64> {
        let (dec, inc) = (self.declination_deg.to_radians(), self.inclination_deg.to_radians());
        let horizontal = self.total_intensity_gauss * inc.cos();
        Vector3::new(horizontal * dec.cos(), horizontal * dec.sin(), self.total_intensity_gauss * inc.sin())
    }
}

impl World {
    /// Loads and checks a world file; a `[forest]` is planted into `obstacles` here, so the
    /// simulator and the camera see the same trees.
    pub fn load(path: &Path) -> Result<World, ConfigError> {
        let text = config_file::read(path)?;
        faults::check_entries(&text).map_err(|(line, source)| ConfigError::InvalidAt {
            path: path.to_path_buf(),
            line,
            source,
        })?;
        let mut world: World = config_file::parse(path, &text, World::validate)?;
        if let Some(forest) = &world.forest {
            let trees = forest
                .plant()
                .map_err(|e| ConfigError::Invalid { path: path.to_path_buf(), source: e.within("forest") })?;
            world.obstacles.extend(trees);
        }
        Ok(world)
    }

    /// Checks every field; the error names the offending one.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        let h = &self.home;
        finite("home", &[h.lat_deg, h.lon_deg, h.alt_msl_m])?;
        if h.lat_deg.abs() > 89.0 {
            return Err(InvalidParam::new("home.lat_deg", "must be within ±89°"));
        }
        let m = &self.magnetic_field;
        positive("magnetic_field.total_intensity_gauss", m.total_intensity_gauss)?;
        finite("magnetic_field", &[m.declination_deg, m.inclination_deg])?;
        if m.inclination_deg.abs() > 90.0 {
            return Err(InvalidParam::new("magnetic_field.inclination_deg", "must be within ±90°"));
        }
        self.wind.validate().map_err(|e| e.within("wind"))?;
        for (i, obstacle) in self.obstacles.iter().enumerate() {
            obstacle.validate().map_err(|e| e.within(&format!("obstacles[{i}]")))?;
        }
        if let Some(forest) = &self.forest {
            forest.validate().map_err(|e| e.within("forest"))?;
        }
        for (i, fault) in self.faults.iter().enumerate() {
            fault.validate().map_err(|e| e.within(&format!("faults[{i}]")))?;
            if let FaultKind::Wind { gust_m_s, .. } = fault.kind
                && gust_m_s > 0.0
            {
                positive("wind.gust_time_constant_s", self.wind.gust_time_constant_s)
                    .map_err(|e| e.within(&format!("faults[{i}] (gusts)")))?;
            }
        }
        Ok(())
    }
}
