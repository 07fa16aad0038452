//! The bus traits the drivers are generic over, from the contract (`kestrel_proto::bus`) where
//! the simulator's device emulators implement them too.

pub use kestrel_proto::bus::{BusError, I2cBus, SpiBus, spi_read_registers, spi_write_register};
