//! `kestrel run --hil`: the Navio2 graph flown on a desk. The graph stays as written; what
//! changes is the board under it. An emulated Navio2 (`kestrel_sim::hil::Navio2Bench`) is built
//! from the graph's own driver parameters — its MPU-9250 and MS5611 plugged in at the spidev
//! and I2C paths the graph names, its u-blox receiver on a pseudo-terminal and its RCIO's PWM
//! and `rcio` trees in a temporary directory, to which the GPS, motor and RCIO drivers' device
//! paths are pointed — and a `hil_sim` actor is added that flies the simulated vehicle on the
//! wall clock and drives the emulated devices. The emulated chips read the simulated vehicle's
//! sensors, which need no calibration on the default vehicle, and nobody is at the desk to turn
//! the board for one: the `calibration` actor's `required` list is emptied, and the log says so.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use kestrel_sensors::{BaroActorParams, GpsActorParams, ImuActorParams, MotorActorParams, RcioActorParams};
use kestrel_sim::hil::{BenchConfig, Navio2Bench};
use serde::Deserialize;
use toml::Spanned;

use crate::config::{ActorDecl, ClockKind, LoadedConfig};

/// The simulator's name in the graph.
pub const HIL_SIM_ACTOR: &str = "sim";

/// What `--hil` is asked for.
#[derive(Clone, Debug)]
pub struct HilOptions {
    /// The bench's directory (the GPS pty's link and the sysfs trees).
    pub dir: PathBuf,
    /// The world file, relative to the config's directory. The vehicle is the graph's own
    /// (its top-level `vehicle`, `crate::vehicle`), which the simulator flies.
    pub world: PathBuf,
    /// What the IMU answers to WHO_AM_I (a wrong part: anything but 0x71).
    pub imu_who_am_i: u8,
}

impl HilOptions {
    /// The graph's vehicle in the empty world, the bench in a directory of this process's own
    /// on a memory filesystem ([`bench_dir`]).
    pub fn new() -> HilOptions {
        HilOptions {
            dir: bench_dir(),
            world: PathBuf::from("worlds/empty.toml"),
            imu_who_am_i: kestrel_sim::hil::mpu9250::MPU9250_WHO_AM_I,
        }
    }
}

impl Default for HilOptions {
    fn default() -> HilOptions {
        HilOptions::new()
    }
}

/// Where a bench lives: `kestrel-hil-<pid>` in `/dev/shm` (a tmpfs on every Linux), else in
/// the temporary directory.
///
/// A Navio2's sysfs files are kernel memory; emulated on a disk filesystem they put the disk
/// under the real-time threads that read and write them. Replacing a value by a rename frees the
/// old file, and freeing waits for its writeback and discard: beside a large write to the same
/// disk, the world thread stalled 574 ms in `rename` (`/proc/<tid>/stack`: `folio_wait_writeback`
/// under `do_renameat2`), the IMU the drivers read froze for 1.3 s and a HIL flight flipped on
/// its landing descent.
pub fn bench_dir() -> PathBuf {
    let shm = Path::new("/dev/shm");
    let parent = if shm.is_dir() { shm.to_path_buf() } else { std::env::temp_dir() };
    parent.join(format!("kestrel-hil-{}", std::process::id()))
}

/// The one actor of type `kind` in `config` (its name and declaration), or an error naming
/// what is missing.
fn the_one<'a>(config: &'a mut LoadedConfig, kind: &str) -> Result<(String, &'a mut ActorDecl), String> {
    let path = config.source.path.display().to_string();
    let mut found = config.graph.actors.iter_mut().filter(|(_, d)| d.kind.get_ref() == kind);
    match (found.next(), found.next()) {
        (Some((name, decl)), None) => Ok((name.get_ref().clone(), decl)),
        (None, _) => Err(format!("--hil needs a '{kind}' actor in {path} (the Navio2 graph)")),
        (Some(_), Some(_)) => {
            Err(format!("--hil emulates one Navio2: {path} has more than one '{kind}' actor"))
        }
    }
}

fn params_of<P: for<'de> Deserialize<'de>>(decl: &ActorDecl, name: &str) -> Result<P, String> {
    let table = decl.params.as_ref().map(|p| p.get_ref().clone()).unwrap_or_default();
    P::deserialize(toml::Value::Table(table)).map_err(|e| format!("actor '{name}' params: {e}"))
}

fn set_param(decl: &mut ActorDecl, key: &str, value: &Path) {
    let params = decl.params.get_or_insert_with(|| Spanned::new(0..0, toml::Table::new())).get_mut();
    params.insert(key.into(), toml::Value::String(value.display().to_string()));
}

/// Builds the emulated board for `config`, points the drivers that open files at it and adds
/// the simulator; the returned bench lives as long as the run.
pub fn apply_hil(config: &mut LoadedConfig, options: &HilOptions) -> Result<Arc<Navio2Bench>, String> {
    if config.graph.run.clock != ClockKind::Realtime {
        return Err(format!(
            "--hil runs on the wall clock, but {} has clock = \"lockstep\"",
            config.source.path.display()
        ));
    }
    let (name, imu) = the_one(config, "mpu9250")?;
    let imu: ImuActorParams = params_of(imu, &name)?;
    let (name, baro) = the_one(config, "ms5611")?;
    let baro: BaroActorParams = params_of(baro, &name)?;
    let (name, motors) = the_one(config, "pwm_motors")?;
    let motors: MotorActorParams = params_of(motors, &name)?;
    let (name, rcio) = the_one(config, "navio2_rcio")?;
    let rcio: RcioActorParams = params_of(rcio, &name)?;
    let (name, gps) = the_one(config, "ublox_gps")?;
    let _: GpsActorParams = params_of(gps, &name)?;
    let bench_config = BenchConfig {
        imu_device: imu.device,
        imu_who_am_i: options.imu_who_am_i,
        baro_device: baro.device,
        baro_address: baro.address,
        pwm_chip: motors.chip,
        pwm_channels: motors.channels,
        voltage_channel: rcio.power_module.voltage_channel,
        current_channel: rcio.power_module.current_channel,
        voltage_divider: rcio.power_module.voltage_divider,
        amps_per_volt: rcio.power_module.amps_per_volt,
        ..BenchConfig::navio2(&options.dir)
    };
    let bench = Navio2Bench::install(bench_config.clone())
        .map_err(|e| format!("cannot build the emulated Navio2 in {}: {e}", options.dir.display()))?;
    set_param(the_one(config, "ublox_gps")?.1, "device", &bench_config.gps_device());
    set_param(the_one(config, "pwm_motors")?.1, "root", &bench_config.pwm_root());
    set_param(the_one(config, "navio2_rcio")?.1, "root", &bench_config.rcio_root());
    if let Ok((name, calibration)) = the_one(config, "calibration") {
        let params =
            calibration.params.get_or_insert_with(|| Spanned::new(0..0, toml::Table::new())).get_mut();
        if params.insert("required".into(), toml::Value::Array(Vec::new())).is_some() {
            tracing::info!(actor = %name, "hardware in the loop: no calibration required of the emulated board");
        }
    }
    let key = Spanned::new(0..0, HIL_SIM_ACTOR.to_owned());
    if config.graph.actors.contains_key(&key) {
        return Err(format!(
            "--hil adds the simulator as '{HIL_SIM_ACTOR}', but {} already has an actor of that name",
            config.source.path.display()
        ));
    }
    let decl = format!(
        "type = \"hil_sim\"\nparams = {{ world = {:?}, seed = 1 }}\n",
        options.world.display().to_string()
    );
    let decl: ActorDecl = toml::from_str(&decl).map_err(|e| format!("--hil simulator: {e}"))?;
    config.graph.actors.insert(key, decl);
    tracing::info!(
        dir = %options.dir.display(),
        gps = %bench_config.gps_device().display(),
        "hardware in the loop: an emulated Navio2 under the graph"
    );
    Ok(bench)
}
