//! SERVO_OUTPUT_RAW: the motor outputs as pulse widths (µs), as ArduCopter reports its motor
//! channels.

use kestrel_proto::esc::{DIRECT_PULSE_TIMEOUT, SAFE_PULSE_MAX_US, SAFE_PULSE_MIN_US};
use kestrel_proto::messages::{ActuatorOutputs, EscPulses, MAX_MOTORS};
use mavlink::dialects::ardupilotmega::SERVO_OUTPUT_RAW_DATA;

/// The pulse of a stopped motor and of full thrust (µs): ArduCopter's MOT_PWM_MIN/MOT_PWM_MAX
/// as its SITL runs them (1000, 2000), the range ground stations draw.
pub const PWM_MIN_US: u16 = 1000;
pub const PWM_MAX_US: u16 = 2000;

/// SERVO_OUTPUT_RAW from the mixer's newest outputs: motor i on servo i + 1 at
/// `PWM_MIN_US + command · (PWM_MAX_US − PWM_MIN_US)`, every motor at `PWM_MIN_US` while
/// disarmed (as the motors are held); servos 9–16, which no motor drives, 0 ("unused").
/// `time_usec` wraps with the u32 the message gives it.
///
/// Disarmed, `direct` pulses (a motor test's, `EscPulses`) that drive the outputs are shown
/// instead, as ArduCopter shows its motor test's: those that hold control and are no older than
/// `DIRECT_PULSE_TIMEOUT` against the mixer's newest outputs — the span after which every
/// consumer drops them (`kestrel_proto::esc::DirectPulses`).
pub fn servo_output_raw(out: &ActuatorOutputs, direct: Option<&EscPulses>) -> SERVO_OUTPUT_RAW_DATA {
    let span = f64::from(PWM_MAX_US - PWM_MIN_US);
    let obeyed = direct
        .filter(|d| !out.armed && d.control && out.time.saturating_since(d.time) <= DIRECT_PULSE_TIMEOUT);
    let pwm: [u16; MAX_MOTORS] = match obeyed {
        // Checked by every consumer to lie within the safe range; a value that does not is
        // refused there, so it is shown as the disarmed pulse here.
        Some(d) => d.pulses_us.map(|p| {
            if p.is_finite() && (SAFE_PULSE_MIN_US..=SAFE_PULSE_MAX_US).contains(&p) {
                p.round() as u16
            } else {
                PWM_MIN_US
            }
        }),
        None => out.motors.map(|m| {
            let command = if out.armed && m.is_finite() { m.clamp(0.0, 1.0) } else { 0.0 };
            PWM_MIN_US + (command * span).round() as u16
        }),
    };
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
        let s = servo_output_raw(&out, None);
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
        let s = servo_output_raw(&out, None);
        assert_eq!([s.servo2_raw, s.servo3_raw], [1000, 1000]);
    }

    #[test]
    fn a_motor_tests_pulses_are_shown_disarmed_while_obeyed() {
        let mut out =
            ActuatorOutputs { time: Time::from_micros(1_000_000), armed: false, motors: [0.0; MAX_MOTORS] };
        let mut test =
            EscPulses { time: Time::from_micros(950_000), control: true, pulses_us: [1000.0; MAX_MOTORS] };
        test.pulses_us[3] = 1349.6;
        assert_eq!(servo_output_raw(&out, Some(&test)).servo4_raw, 1350);
        out.time = Time::from_micros(1_050_001);
        assert_eq!(servo_output_raw(&out, Some(&test)).servo4_raw, 1000, "older than 100 ms: dropped");
        out.time = Time::from_micros(1_000_000);
        out.armed = true;
        assert_eq!(servo_output_raw(&out, Some(&test)).servo4_raw, 1000, "armed: the mixer rules");
        out.armed = false;
        test.control = false;
        assert_eq!(servo_output_raw(&out, Some(&test)).servo4_raw, 1000, "released");
        test.control = true;
        test.pulses_us[3] = f64::NAN;
        assert_eq!(servo_output_raw(&out, Some(&test)).servo4_raw, 1000, "refused by every consumer");
    }
}
