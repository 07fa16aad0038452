//! `config/ardupilot/sitl.toml`: what `kestrel sitl ardupilot` flies ArduCopter SITL in.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::config_file;
use crate::error::{ConfigError, InvalidParam};

/// The environment variable naming the ArduCopter SITL binary; it wins over `arducopter`.
pub const ARDUCOPTER_ENV: &str = "KESTREL_ARDUCOPTER";

/// The whole file. Relative paths resolve against the file's directory.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SitlConfig {
    /// Vehicle file (`config/vehicles/*.toml`).
    pub vehicle: PathBuf,
    /// World file (`config/worlds/*.toml`): obstacles, wind, `[[faults]]` act as in `kestrel run`.
    pub world: PathBuf,
    /// Seed of wind and sensor noise.
    pub seed: u64,
    /// Physics frames a second (Hz), 400..=10000: one simulator step per SITL frame. 1200 is
    /// ArduCopter SITL's own default (`SIM_RATE_HZ`).
    pub frame_rate_hz: f64,
    /// The `arducopter` binary, when `KESTREL_ARDUCOPTER` is unset.
    pub arducopter: Option<PathBuf>,
    /// Parameter files given to SITL after ArduPilot's own autotest defaults (`copter.parm`
    /// beside the binary), later files winning.
    pub defaults: Vec<PathBuf>,
    /// SITL's `--speedup`: simulated seconds per wall second it may run at, at most; in lockstep
    /// the physics answers as fast as it can, so a large value means "as fast as the host allows".
    pub speedup: f64,
    /// SITL's `-I`: its ports (MAVLink, physics 9002) are the defaults + 10·N.
    pub instance: u16,
    /// Where SITL's serial 0 sends MAVLink (`--serial0`), e.g. `udpclient:127.0.0.1:14550`.
    pub gcs: String,
}

impl Default for SitlConfig {
    fn default() -> SitlConfig {
        SitlConfig {
            vehicle: PathBuf::from("vehicles/quad_x.toml"),
            world: PathBuf::from("worlds/empty.toml"),
            seed: 1,
            frame_rate_hz: 1200.0,
            arducopter: None,
            defaults: vec![PathBuf::from("ardupilot-json.parm")],
            speedup: 100.0,
            instance: 0,
            gcs: "udpclient:127.0.0.1:14550".into(),
        }
    }
}

impl SitlConfig {
    /// Loads and checks `path`; relative paths come back resolved against its directory.
    pub fn load(path: &Path) -> Result<SitlConfig, ConfigError> {
        let mut config: SitlConfig = config_file::load(path, SitlConfig::validate)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        config.vehicle = dir.join(&config.vehicle);
        config.world = dir.join(&config.world);
        config.arducopter = config.arducopter.map(|p| dir.join(p));
        config.defaults = config.defaults.iter().map(|p| dir.join(p)).collect();
        Ok(config)
    }

    /// Checks every field; the error names the offending one.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        use super::backend::{MAX_FRAME_RATE_HZ, MIN_FRAME_RATE_HZ};
        if !(MIN_FRAME_RATE_HZ..=MAX_FRAME_RATE_HZ).contains(&self.frame_rate_hz) {
            return Err(InvalidParam::new(
                "frame_rate_hz",
                format!(
                    "{} Hz: must be within {MIN_FRAME_RATE_HZ}..={MAX_FRAME_RATE_HZ}",
                    self.frame_rate_hz
                ),
            ));
        }
        if !(self.speedup.is_finite() && self.speedup >= 0.01 && self.speedup <= 10_000.0) {
            return Err(InvalidParam::new(
                "speedup",
                format!("{}: must be within 0.01..=10000", self.speedup),
            ));
        }
        if self.instance > 60 {
            return Err(InvalidParam::new("instance", format!("{}: must be within 0..=60", self.instance)));
        }
        let gcs_ok = ["udpclient:", "udp:", "tcp:", "tcpclient:"].iter().any(|p| self.gcs.starts_with(p));
        if !gcs_ok {
            return Err(InvalidParam::new(
                "gcs",
                format!(
                    "{:?}: must be a SITL serial spec, udpclient:IP:PORT, udp:, tcp: or tcpclient:",
                    self.gcs
                ),
            ));
        }
        Ok(())
    }

    /// The SITL binary: `KESTREL_ARDUCOPTER` if set, else `arducopter`, else `None`.
    pub fn binary(&self) -> Option<PathBuf> {
        std::env::var_os(ARDUCOPTER_ENV).map(PathBuf::from).or_else(|| self.arducopter.clone())
    }
}
