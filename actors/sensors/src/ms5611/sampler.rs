//! Sampling the MS5611 without blocking: each call starts the next conversion and reads the
//! one started by the previous call, alternating temperature and pressure, so a caller
//! ticking at twice the output rate (20 Hz for 10 Hz samples, as PX4's driver does) never
//! waits out a conversion. Each pressure is compensated with the latest temperature.

use kestrel_proto::Time;
use kestrel_proto::messages::BaroSample;

use crate::altitude::isa_altitude_m;
use crate::bus::I2cBus;
use crate::ms5611::compensation::compensate;
use crate::ms5611::driver::{Conversion, Ms5611, Ms5611Error};

/// The interleaving state.
#[derive(Clone, Debug, Default)]
pub struct Ms5611Sampler {
    /// The conversion in flight and when it was started.
    pending: Option<(Conversion, Time)>,
    /// The latest raw temperature.
    d2: Option<u32>,
}

impl Ms5611Sampler {
    pub fn new() -> Ms5611Sampler {
        Ms5611Sampler::default()
    }

    /// Reads the conversion started last call (at least a conversion time ago), starts the
    /// other one, and returns a sample when a pressure completed. The sample is stamped with
    /// the end of its pressure conversion.
    pub fn tick<B: I2cBus>(
        &mut self,
        baro: &mut Ms5611<B>,
        now: Time,
    ) -> Result<Option<BaroSample>, Ms5611Error> {
        let mut sample = None;
        let next = match self.pending.take() {
            Some((Conversion::Temperature, _)) => {
                self.d2 = Some(baro.read_result()?);
                Conversion::Pressure
            }
            Some((Conversion::Pressure, started)) => {
                let d1 = baro.read_result()?;
                if let Some(d2) = self.d2 {
                    let reading = compensate(baro.prom(), d1, d2);
                    let pressure_pa = f64::from(reading.pressure_pa);
                    sample = Some(BaroSample {
                        time: started + baro.oversampling().conversion_time(),
                        pressure_pa,
                        altitude_m: isa_altitude_m(pressure_pa),
                        temperature_c: reading.temperature_c(),
                    });
                }
                Conversion::Temperature
            }
            None => Conversion::Temperature,
        };
        baro.start(next)?;
        self.pending = Some((next, now));
        Ok(sample)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ms5611::driver::Oversampling;
    use crate::ms5611::fake::FakeMs5611;
    use crate::ms5611::prom::tests::datasheet_prom_words;

    #[test]
    fn alternates_and_stamps_the_end_of_the_pressure_conversion() {
        let fake = FakeMs5611::new(datasheet_prom_words(), 9_085_466, 8_569_150);
        let mut baro = Ms5611::new(fake, Oversampling::Osr4096, &mut |_| {}).expect("init");
        let mut sampler = Ms5611Sampler::new();
        let samples: Vec<BaroSample> = (0..6u64)
            .filter_map(|k| sampler.tick(&mut baro, Time::from_micros(50_000 * k)).expect("tick"))
            .collect();
        // Ticks: start T, read T/start P, read P (sample)/start T, ...
        assert_eq!(samples.len(), 2);
        assert_eq!(samples[0].time, Time::from_micros(50_000 + 9_040));
        assert_eq!(samples[1].time, Time::from_micros(150_000 + 9_040));
        assert_eq!(samples[0].pressure_pa, 100_009.0);
        assert!((samples[0].temperature_c - 20.07).abs() < 1e-12);
        assert!((samples[0].altitude_m - isa_altitude_m(100_009.0)).abs() < 1e-12);
        assert!((samples[0].altitude_m - 110.13).abs() < 0.01);
    }
}
