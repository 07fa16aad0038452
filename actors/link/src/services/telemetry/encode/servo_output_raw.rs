//! SERVO_OUTPUT_RAW: the motor outputs as pulse widths (µs), as ArduCopter reports its motor
//! channels.

use kestrel_proto::messages::{ActuatorOutputs, MAX_MOTORS};
use mavlink::dialects::ardupilotmega::SERVO_OUTPUT_RAW_DATA;

/// The pulse of a stopped motor and of full thrust (µs): ArduCopter's MOT_PWM_MIN/MOT_PWM_MAX
/// as its SITL runs them (1000, 2000), the range ground stations draw.
pub const PWM_MIN_US: u16 = 1000;
pub const PWM_MAX_US: u16 = 2000;

/// SERVO_OUTPUT_RAW from the mixer's newest outputs: motor i on servo i + 1 at
/// `PWM_MIN_US + command · (PWM_MAX_US − PWM_MIN_US)`, every motor at `PWM_MIN_US` while
/// disarmed (as the motors are held); servos 9–16, which no motor drives, 0 ("unused").
/// `time_usec` wraps with the u32 the message gives it.
pub fn servo_output_raw(out: &ActuatorOutputs) -> SERVO_OUTPUT_RAW_DATA {
    let span = f64::from(PWM_MAX_US - PWM_MIN_US);
    let pwm: [u16; MAX_MOTORS] = out.motors.map(|m| {
        let command = if out.armed && m.is_finite() { m.clamp(0.0, 1.0) } else { 0.0 };
        PWM_MIN_US + (command * span).round() as u16
    });
    SERVO_OUTPUT_RAW_DATA {
        time_usec: out.time.as_micros() as u32,
        port: 0,
        servo1_raw: pwm[0],
        servo2_raw: pwm[1],
        servo3_raw: pwm[2],
        servo4_raw: pwm[3],
        servo5_raw: pwm[4],
        servo6_raw: pwm[5],
        servo7_raw: pwm[6],
        servo8_raw: pwm[7],
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;

    use super::*;

    #[test]
    fn commands_map_onto_1000_to_2000_us_and_disarmed_motors_read_the_minimum() {
        let mut out = ActuatorOutputs {
            time: Time::from_micros(5),
            armed: true,
            motors: [0.0, 0.5, 1.0, 1.5, -0.2, f64::NAN, 0.25, 0.0],
        };
        let s = servo_output_raw(&out);
        assert_eq!(
            [
                s.servo1_raw,
                s.servo2_raw,
                s.servo3_raw,
                s.servo4_raw,
                s.servo5_raw,
                s.servo6_raw,
                s.servo7_raw
            ],
            [1000, 1500, 2000, 2000, 1000, 1000, 1250]
        );
        assert_eq!((s.servo9_raw, s.time_usec), (0, 5));
        out.armed = false;
        let s = servo_output_raw(&out);
        assert_eq!([s.servo2_raw, s.servo3_raw], [1000, 1000]);
    }
}
