//! Kestrel's hardware layer for a Linux flight computer (Raspberry Pi + Navio2, thesis §3.1.3):
//! pure decoders and compensators for each sensor, the small transports they run over, the
//! Linux PWM motor output, and thin actor shells.
//!
//! Every driver is a *pure core* (bytes or raw counts in, SI values out, no I/O) plus a thin
//! layer over a transport trait ([`bus::SpiBus`], [`bus::I2cBus`],
//! [`serial::SerialTransport`]) or a directory, so tests
//! drive the real driver against in-memory fakes that answer the chip's protocol. Missing or
//! failing hardware is a typed error naming the device path and what was expected, never a
//! panic.
//!
//! * [`ms5611`] — barometer: PROM CRC-4, first/second-order compensation, non-blocking
//!   sampling; [`altitude`] — ISA pressure altitude.
//! * [`ubx`] — u-blox UBX framing, NAV-PVT → `GpsFix`, configuration messages, time of
//!   validity; [`nmea`] — NMEA 0183 GGA/RMC/VTG fallback; [`gps`] — the two joined into
//!   one receiver's decoder, and its UBX set-up sequence.
//! * [`sbus`] — SBUS RC frames → `ManualControl`; [`rcio`] — Navio2's RC input and power
//!   module through the `rcio` driver's sysfs files.
//! * [`calibration`] — compass, accelerometer, gyro and board-level calibration fits.
//! * [`health`] — per-driver `SensorHealth` reports (rate, errors, IMU clipping).
//! * [`mpu9250`], [`ak8963`], [`axis_map`], [`imu_decimator`] — the IMU, its magnetometer, chip
//!   → body FRD axes, and the 1 kHz → 400 Hz averaging.
//! * [`pwm`] — motor outputs through `/sys/class/pwm`, disarmed unless armed.
//! * [`linux`] — `i2c-dev` and `spidev` implementations of the bus traits; [`serial`] —
//!   `tokio-serial` ports for the byte-stream drivers.
//! * [`baro_actor`], [`imu_actor`], [`gps_actor`], [`sbus_actor`], [`rcio_actor`],
//!   [`motor_actor`] — actor shells.

pub mod ak8963;
pub mod altitude;
pub mod axis_map;
pub mod baro_actor;
pub mod bus;
pub mod calibration;
pub mod calibration_actor;
pub mod gps;
pub mod gps_actor;
pub mod health;
pub mod imu_actor;
pub mod imu_decimator;
pub mod linux;
pub mod live_calibration;
pub mod motor_actor;
pub mod motor_test;
pub mod mpu9250;
pub mod ms5611;
pub mod nmea;
pub mod pwm;
pub mod rcio;
pub mod rcio_actor;
pub mod reader_task;
pub mod sbus;
pub mod sbus_actor;
pub mod serial;
pub mod ubx;

pub use baro_actor::{BaroActor, BaroActorParams, BaroInput};
pub use bus::{BusError, I2cBus, SpiBus};
pub use calibration_actor::{CalibrationActor, CalibrationActorParams, CalibrationInput};
pub use gps_actor::{GpsActor, GpsActorParams, GpsInput};
pub use imu_actor::{ImuActor, ImuActorParams, ImuInput};
pub use motor_actor::{MotorActor, MotorActorParams, MotorInput};
pub use rcio_actor::{RcioActor, RcioActorParams, RcioInput};
pub use sbus_actor::{SbusActor, SbusActorParams, SbusInput};
