//! A Navio2 on the desk: every device the Navio2 graph opens, emulated and plugged in where its
//! driver looks — the MPU-9250 and MS5611 into the contract's bus table under the graph's own
//! `/dev/spidev*` and `/dev/i2c-*` paths, the u-blox receiver on a pseudo-terminal and the
//! RCIO's PWM and `rcio` sysfs trees in the bench's directory (the graph's device paths for
//! those are pointed there). The [`HilSimActor`](super::HilSimActor) drives them from the
//! simulator.
//!
//! A process runs one board, so the bench is installed once per process, like the bus table.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use kestrel_proto::bus::{I2cBus, SpiBus, WriteFault, plug_i2c, plug_spi, plug_write_fault};

use super::mpu9250::{MPU9250_WHO_AM_I, Mpu9250World};
use super::ms5611::{DATASHEET_COEFFICIENTS, Ms5611World};
use super::navio2_sysfs::{EscCalibration, PwmChip, RcioTree};
use super::pty::Pty;
use super::ublox::{POWER_UP_BAUD, UbloxReceiver};
use super::{Mpu9250Emulator, Ms5611Emulator};

/// A typical AK8963 fuse ROM (X ×1.1875, Y ×1, Z ×0.8125), so the driver's adjustment is
/// exercised.
pub const BENCH_ASA: [u8; 3] = [176, 128, 80];

/// Where the graph's drivers look for their devices, and what the board is.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// The bench's own directory: the GPS pty's link and the sysfs trees go here.
    pub dir: PathBuf,
    /// The IMU's spidev node, as the graph names it.
    pub imu_device: PathBuf,
    /// What the IMU answers to WHO_AM_I (0x71; anything else is a wrong part on the bus).
    pub imu_who_am_i: u8,
    /// The barometer's I2C bus node and address, as the graph names them.
    pub baro_device: PathBuf,
    pub baro_address: u8,
    /// The PWM chip and the motors' channels, in the frame's motor order.
    pub pwm_chip: u32,
    pub pwm_channels: Vec<u32>,
    pub esc: EscCalibration,
    /// The power module: ADC channels and scaling (the board's, as the driver is told).
    pub voltage_channel: usize,
    pub current_channel: usize,
    pub voltage_divider: f64,
    pub amps_per_volt: f64,
}

impl BenchConfig {
    /// A Navio2 as `config/navio2.toml` describes it, with its files under `dir`.
    pub fn navio2(dir: &Path) -> BenchConfig {
        BenchConfig {
            dir: dir.to_owned(),
            imu_device: PathBuf::from("/dev/spidev0.1"),
            imu_who_am_i: MPU9250_WHO_AM_I,
            baro_device: PathBuf::from("/dev/i2c-1"),
            baro_address: 0x77,
            pwm_chip: 0,
            pwm_channels: vec![0, 1, 2, 3],
            esc: EscCalibration::default(),
            voltage_channel: 2,
            current_channel: 3,
            voltage_divider: 11.3,
            amps_per_volt: 17.0,
        }
    }

    /// The path the GPS driver opens.
    pub fn gps_device(&self) -> PathBuf {
        self.dir.join("ttyGPS")
    }

    /// The PWM class directory the motor driver writes under.
    pub fn pwm_root(&self) -> PathBuf {
        self.dir.join("pwm")
    }

    /// The `rcio` directory the RC and power-module driver reads.
    pub fn rcio_root(&self) -> PathBuf {
        self.dir.join("rcio")
    }
}

/// The receiver and its line.
#[derive(Debug)]
pub struct GpsLine {
    pub receiver: UbloxReceiver,
    /// `None` while the line is unplugged (a fault test).
    pub pty: Option<Pty>,
}

/// The emulated board.
#[derive(Debug)]
pub struct Navio2Bench {
    pub config: BenchConfig,
    pub imu: Mpu9250World,
    pub baro: Ms5611World,
    pub pwm: PwmChip,
    pub rcio: RcioTree,
    gps: Mutex<GpsLine>,
    /// Each PWM channel's `duty_cycle` fault switch.
    pwm_faults: Vec<Arc<WriteFault>>,
}

static INSTALLED: Mutex<Option<Arc<Navio2Bench>>> = Mutex::new(None);

impl Navio2Bench {
    /// Builds the board in `config.dir` and plugs its chips in; replaces a bench installed
    /// before.
    pub fn install(config: BenchConfig) -> io::Result<Arc<Navio2Bench>> {
        std::fs::create_dir_all(&config.dir)?;
        let pty = Pty::open(&config.gps_device(), POWER_UP_BAUD)?;
        let pwm = PwmChip::create(&config.pwm_root(), config.pwm_chip, &config.pwm_channels, config.esc)?;
        let rcio = RcioTree::create(&config.rcio_root())?;
        let imu = Mpu9250World::default();
        let baro_chip = Ms5611Emulator::new(&config.baro_device, DATASHEET_COEFFICIENTS);
        let chip_dir = config.pwm_root().join(format!("pwmchip{}", config.pwm_chip));
        let pwm_faults = config
            .pwm_channels
            .iter()
            .map(|ch| plug_write_fault(&chip_dir.join(format!("pwm{ch}")).join("duty_cycle")))
            .collect();
        let bench = Arc::new(Navio2Bench {
            imu: imu.clone(),
            baro: baro_chip.world(),
            pwm,
            rcio,
            gps: Mutex::new(GpsLine { receiver: UbloxReceiver::new(), pty: Some(pty) }),
            pwm_faults,
            config: config.clone(),
        });
        let (path, who_am_i) = (config.imu_device.clone(), config.imu_who_am_i);
        plug_spi(
            &config.imu_device,
            Arc::new(move || -> Box<dyn SpiBus + Send> {
                Box::new(Mpu9250Emulator::with_world(&path, who_am_i, BENCH_ASA, imu.clone()))
            }),
        );
        plug_i2c(
            &config.baro_device,
            config.baro_address,
            Arc::new(move || -> Box<dyn I2cBus + Send> { Box::new(baro_chip.clone()) }),
        );
        *INSTALLED.lock().unwrap_or_else(PoisonError::into_inner) = Some(Arc::clone(&bench));
        Ok(bench)
    }

    /// The bench installed in this process, if any.
    pub fn installed() -> Option<Arc<Navio2Bench>> {
        INSTALLED.lock().unwrap_or_else(PoisonError::into_inner).clone()
    }

    /// Makes every write to the PWM channels' `duty_cycle` fail with EIO (`true`) or work again.
    pub fn fail_pwm_writes(&self, failing: bool) {
        for fault in &self.pwm_faults {
            fault.set(failing);
        }
    }

    /// The receiver and its line.
    pub fn gps(&self) -> MutexGuard<'_, GpsLine> {
        self.gps.lock().unwrap_or_else(PoisonError::into_inner)
    }
}
