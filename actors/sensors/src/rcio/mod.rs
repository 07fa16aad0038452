//! Navio2's RCIO co-processor as Linux exposes it (the `rcio` kernel driver under
//! `/sys/kernel/rcio`): [`sysfs`] reads its RC input pulse widths and ADC channels, naming the
//! file that is missing or unreadable; [`power_module`] turns the power module's ADC voltages
//! into a [`BatteryStatus`](kestrel_proto::messages::BatteryStatus).

pub mod power_module;
pub mod sysfs;

pub use power_module::{BatteryMonitor, PowerModule};
pub use sysfs::{RcioError, RcioSysfs};
