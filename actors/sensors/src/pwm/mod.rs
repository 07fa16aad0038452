//! Motor outputs through the Linux PWM sysfs interface (Navio2's RCIO exposes its servo rail
//! as `/sys/class/pwm/pwmchip0`): [`pulses`] maps actuator commands to pulse widths,
//! [`sysfs`] drives one channel's files, [`motor_output`] holds the motors at the disarmed
//! pulse unless armed, and retries a failed write instead of cutting a motor,
//! [`output_thread`] writes them off the actor's tokio worker and outlives its restarts, and
//! [`watchdog`] reports a controller gone quiet while armed.

pub mod motor_output;
pub mod output_thread;
pub mod pulses;
pub mod sysfs;
pub mod watchdog;

pub use motor_output::{MotorOutput, PwmOut};
pub use output_thread::{OutputCounts, OutputThread};
pub use pulses::{PulseCommand, PulseConfig, pulse_widths_us};
pub use sysfs::{PwmChannel, PwmError};
pub use watchdog::CommandWatchdog;
