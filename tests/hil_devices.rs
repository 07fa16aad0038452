//! The simulator's device emulators (`kestrel_sim::hil`) read by the real drivers of
//! `kestrel-sensors`: what the driver makes of the chip's protocol is the simulated value.

use std::path::Path;

use kestrel_proto::Time;
use kestrel_sensors::axis_map::AxisMap;
use kestrel_sensors::mpu9250::{AccelRange, GyroRange, Mpu9250, Mpu9250Config, Mpu9250Error};
use kestrel_sensors::ms5611::{Ms5611, Oversampling};
use kestrel_sim::hil::mpu9250::MPU9250_WHO_AM_I;
use kestrel_sim::hil::ms5611::DATASHEET_COEFFICIENTS;
use kestrel_sim::hil::{Mpu9250Emulator, Ms5611Emulator};
use proptest::prelude::*;

/// A typical AK8963 fuse ROM: X ×1.1875, Y ×1, Z ×0.8125.
const ASA: [u8; 3] = [176, 128, 80];

fn mpu9250(config: Mpu9250Config, chip: Mpu9250Emulator) -> Mpu9250<Mpu9250Emulator> {
    Mpu9250::new(chip, config, &mut |_| {}).expect("the driver brings the emulated IMU up")
}

/// The chip's axes as the driver's default mounting sees them (chip flat, X forward): FRD =
/// (x, −y, −z), so chip = (f, −r, −d).
fn chip_axes(frd: [f64; 3]) -> [f64; 3] {
    [frd[0], -frd[1], -frd[2]]
}

fn ms5611(emulator: Ms5611Emulator) -> Ms5611<Ms5611Emulator> {
    Ms5611::new(emulator, Oversampling::Osr4096, &mut |_| {}).expect("the driver accepts the emulated PROM")
}

#[test]
fn ms5611_driver_reads_the_datasheet_example_back() {
    // Datasheet "Pressure and temperature calculation": with C1..C6 = 40127, 36924, 23317,
    // 23282, 33464, 28312 the chip reads TEMP = 2007 (20.07 °C) and P = 100009 (1000.09 mbar).
    let mut chip = Ms5611Emulator::new(Path::new("/dev/i2c-hil"), DATASHEET_COEFFICIENTS);
    chip.set_reading(100_009.0, 20.07);
    let (d1, d2) = chip.raw();
    // The datasheet's own D1 = 9085466 and D2 = 8569150 lie in the same 1 Pa and 0.01 °C
    // steps; ours are the steps' middles, within a few counts of them.
    assert!((i64::from(d1) - 9_085_466).abs() < 200, "D1 = {d1}");
    assert!((i64::from(d2) - 8_569_150).abs() < 400, "D2 = {d2}");
    let mut driver = ms5611(chip);
    assert_eq!(driver.prom().c(1), 40127);
    let reading = driver.measure(&mut |_| {}).expect("a reading");
    assert_eq!((reading.temperature_centi_c, reading.pressure_pa), (2007, 100_009));
}

#[test]
fn ms5611_emulated_prom_passes_the_drivers_crc_4() {
    let chip = Ms5611Emulator::new(Path::new("/dev/i2c-hil"), DATASHEET_COEFFICIENTS);
    let prom = chip.prom();
    assert_eq!(prom[7] & 0x000F, u16::from(kestrel_sensors::ms5611::crc4(&prom)));
    let mut corrupt = prom;
    corrupt[3] ^= 0x0100;
    assert!(kestrel_sensors::ms5611::Prom::new(corrupt).is_err(), "a flipped bit fails the CRC");
}

#[test]
fn mpu9250_driver_reads_the_simulated_motion_and_field_back() {
    let chip = Mpu9250Emulator::new(Path::new("/dev/spidev-hil"), MPU9250_WHO_AM_I, ASA);
    let world = chip.world();
    let mut imu = mpu9250(Mpu9250Config::default(), chip);
    assert_eq!(imu.mag_adjustment(), Some([1.1875, 1.0, 0.8125]));
    assert_eq!(imu.read(Time::ZERO).expect("a reading").mag_frd_gauss, None, "no field measured yet");
    // Level, nose up at 0.3 rad/s, a 0.5 G field north and down.
    let (accel_frd, gyro_frd, field_frd) = ([0.4, -0.2, -9.7], [0.01, 0.3, -0.05], [0.2, 0.05, 0.45]);
    world.set_motion(chip_axes(accel_frd), chip_axes(gyro_frd), 36.5);
    world.set_field(chip_axes(field_frd), ASA);
    let r = imu.read(Time::from_micros(2500)).expect("a reading");
    // Half a count: 1/2048 g at ±16 g, 1/16.4 °/s at ±2000 °/s, 0.0015 G × adjustment, 1/333.87 °C.
    for i in 0..3 {
        assert!((r.accel_frd_m_s2[i] - accel_frd[i]).abs() <= 0.5 * 9.80665 / 2048.0 + 1e-9, "{r:?}");
        assert!(
            (r.gyro_frd_rad_s[i] - gyro_frd[i]).abs() <= 0.5 * (1.0f64 / 16.4).to_radians() + 1e-9,
            "{r:?}"
        );
    }
    assert!((r.temperature_c - 36.5).abs() <= 0.5 / 333.87 + 1e-9, "{r:?}");
    let mag = r.mag_frd_gauss.expect("a fresh field");
    for i in 0..3 {
        assert!((mag[i] - field_frd[i]).abs() <= 0.5 * 0.0015 * 1.1875 + 1e-9, "{mag:?}");
    }
    // The field was read: the next sample has none until the magnetometer measures again.
    assert_eq!(imu.read(Time::from_micros(5000)).expect("a reading").mag_frd_gauss, None);
}

#[test]
fn mpu9250_counts_follow_the_ranges_the_driver_configured_and_clip() {
    // 3 g and 300 °/s: inside ±4 g / ±500 °/s, past ±2 g / ±250 °/s.
    let (accel, gyro) = ([0.0, 0.0, -3.0 * 9.80665], [300f64.to_radians(), 0.0, 0.0]);
    let chip = || {
        let chip = Mpu9250Emulator::new(Path::new("/dev/spidev-hil"), MPU9250_WHO_AM_I, ASA);
        chip.world().set_motion(chip_axes(accel), chip_axes(gyro), 25.0);
        chip
    };
    let config = |gyro_range, accel_range| Mpu9250Config {
        gyro_range,
        accel_range,
        magnetometer: false,
        ..Mpu9250Config::default()
    };
    let mut wide = mpu9250(config(GyroRange::Dps500, AccelRange::G4), chip());
    let r = wide.read(Time::ZERO).expect("a reading");
    assert!(
        (r.accel_frd_m_s2[2] - accel[2]).abs() < 0.01 && (r.gyro_frd_rad_s[0] - gyro[0]).abs() < 1e-3,
        "{r:?}"
    );
    assert_eq!((r.accel_clipped, r.gyro_clipped), ([false; 3], [false; 3]));
    let mut narrow = mpu9250(config(GyroRange::Dps250, AccelRange::G2), chip());
    let r = narrow.read(Time::ZERO).expect("a reading");
    assert_eq!((r.accel_clipped[2], r.gyro_clipped[0]), (true, true), "{r:?}");
}

#[test]
fn an_imu_with_the_wrong_who_am_i_is_a_clear_error_naming_the_device() {
    let chip = Mpu9250Emulator::new(Path::new("/dev/spidev-hil"), 0x70, ASA);
    let err = Mpu9250::new(chip, Mpu9250Config::default(), &mut |_| {}).err().expect("a wrong part");
    assert!(matches!(err, Mpu9250Error::Identity { found: 0x70, .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("/dev/spidev-hil") && text.contains("0x70") && text.contains("MPU-9250"), "{text}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Any axis map the driver accepts: what it reads in body FRD is the simulated value.
    #[test]
    fn mpu9250_driver_reads_back_any_motion_through_any_mounting(
        accel in prop::array::uniform3(-150.0f64..150.0),
        gyro in prop::array::uniform3(-30.0f64..30.0),
        perm in 0usize..6,
        signs in prop::array::uniform3(prop::bool::ANY),
    ) {
        let axis = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]][perm];
        let axes = AxisMap { axis, sign: signs.map(|s| if s { 1.0 } else { -1.0 }) };
        // chip[axis[i]] = sign[i] · frd[i].
        let to_chip = |frd: [f64; 3]| {
            let mut chip = [0.0; 3];
            for i in 0..3 {
                chip[axis[i]] = axes.sign[i] * frd[i];
            }
            chip
        };
        let chip = Mpu9250Emulator::new(Path::new("/dev/spidev-hil"), MPU9250_WHO_AM_I, ASA);
        chip.world().set_motion(to_chip(accel), to_chip(gyro), 30.0);
        let config = Mpu9250Config { axes, magnetometer: false, ..Mpu9250Config::default() };
        let r = mpu9250(config, chip).read(Time::ZERO).expect("a reading");
        for i in 0..3 {
            prop_assert!((r.accel_frd_m_s2[i] - accel[i]).abs() <= 0.5 * 9.80665 / 2048.0 + 1e-9, "{r:?}");
            prop_assert!((r.gyro_frd_rad_s[i] - gyro[i]).abs() <= 0.5 * (1.0f64 / 16.4).to_radians() + 1e-9, "{r:?}");
        }
    }

    /// Across the chip's range, second-order compensation included (below 20 °C and below
    /// −15 °C), the driver reads back the simulated pressure to 1 Pa and temperature to 0.01 °C.
    #[test]
    fn ms5611_driver_reads_back_the_simulated_pressure_and_temperature(
        pressure_pa in 30_000.0f64..110_000.0,
        temperature_c in -40.0f64..85.0,
    ) {
        let mut chip = Ms5611Emulator::new(Path::new("/dev/i2c-hil"), DATASHEET_COEFFICIENTS);
        chip.set_reading(pressure_pa, temperature_c);
        let reading = ms5611(chip).measure(&mut |_| {}).expect("a reading");
        let want_t = (temperature_c * 100.0).floor() as i32;
        let want_p = pressure_pa.floor() as i32;
        prop_assert!((reading.temperature_centi_c - want_t).abs() <= 1, "{reading:?} vs {want_t}");
        prop_assert!((reading.pressure_pa - want_p).abs() <= 1, "{reading:?} vs {want_p}");
    }
}
