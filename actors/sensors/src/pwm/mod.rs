//! Motor outputs through the Linux PWM sysfs interface (Navio2's RCIO exposes its servo rail
//! as `/sys/class/pwm/pwmchip0`): [`pulses`] maps actuator commands to pulse widths,
//! [`sysfs`] drives one channel's files, [`motor_output`] holds the motors at the disarmed
//! pulse unless armed and fresh commands arrive, and on drop.

pub mod motor_output;
pub mod pulses;
pub mod sysfs;

pub use motor_output::MotorOutput;
pub use pulses::{PulseConfig, pulse_widths_us};
pub use sysfs::{PwmChannel, PwmError};
