//! The SBUS actor against a real pseudo-terminal set to 100 000 baud, 8E2: frames every 7 ms
//! (with noise and a failsafe frame among them) become sticks.

mod support;

use std::time::Duration;

use kestrel_proto::messages::{ManualControl, SensorHealth};
use kestrel_proto::testing::TestSetup;
use kestrel_proto::{Actor, Clock, Context};
use kestrel_sensors::sbus::SbusFrame;
use kestrel_sensors::{SbusActor, SbusActorParams, SbusInput};
use support::WallClock;
use tokio::io::AsyncWriteExt;
use tokio_serial::{SerialPort, SerialStream, StopBits};
use tokio_util::sync::CancellationToken;

/// A frame with roll, pitch, throttle, yaw (AETR) at these raw values, the rest centred.
fn frame(aetr: [u16; 4], failsafe: bool) -> [u8; 25] {
    let mut channels = [992; 16];
    channels[..4].copy_from_slice(&aetr);
    SbusFrame { channels, digital: [false; 2], frame_lost: false, failsafe }.encode()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reads_sticks_at_100000_baud_8e2_over_a_pty() {
    let (mut master, slave) = SerialStream::pair().expect("pseudo-terminal pair");
    let path = slave.name().expect("pty path");
    let params = SbusActorParams { device: path.clone().into(), ..SbusActorParams::default() };
    let mut setup = TestSetup::<SbusInput>::new("rc", ".");
    let mut actor = SbusActor::build(&params, &mut setup).expect("opens the pty at 100000 8E2");
    drop(slave);
    // The pty keeps the rate and stop bits the actor set. Linux's pty driver forces 8 data bits
    // without parity whatever is asked (pty_set_termios clears PARENB), so even parity, which
    // a UART checks in hardware, cannot be observed here.
    assert_eq!(master.baud_rate().expect("termios"), 100_000);
    assert_eq!(master.stop_bits().expect("termios"), StopBits::Two);

    let clock = WallClock::new();
    let ctx = Context::new("rc".into(), clock.clone(), CancellationToken::new());
    actor.start(&ctx).await.expect("start");
    let full_right_half_throttle = frame([1811, 992, 992, 992], false);
    let start = tokio::time::Instant::now();
    for k in 0..20u32 {
        tokio::time::sleep_until(start + Duration::from_millis(7) * k).await;
        let bytes: Vec<u8> = match k {
            5 => [&[0x0F, 0x42, 0x0F][..], &full_right_half_throttle[..]].concat(),
            10 => frame([992; 4], true).to_vec(),
            _ => full_right_half_throttle.to_vec(),
        };
        master.write_all(&bytes).await.expect("write");
    }
    tokio::time::sleep(Duration::from_millis(50)).await;
    actor.handle(&ctx, setup.tick("health_report", clock.now())).await.expect("reader healthy");
    ctx.shutdown().cancel();
    actor.stop(&ctx).await;

    let sticks: Vec<ManualControl> = setup.published("manual_control");
    assert_eq!(sticks.len(), 19, "20 frames, one in failsafe");
    for s in &sticks {
        assert_eq!((s.roll, s.pitch, s.yaw), (1.0, 0.0, 0.0));
        assert!((s.throttle - (992.0 - 172.0) / (1811.0 - 172.0)).abs() < 1e-12);
    }
    let health: Vec<SensorHealth> = setup.published("health");
    assert_eq!(health[0].device, path);
    assert!(health[0].errors_total >= 1, "the noise before frame 5: {:?}", health[0]);
}
