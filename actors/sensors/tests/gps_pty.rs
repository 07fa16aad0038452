//! The GPS actor against a real pseudo-terminal: it opens the tty by path at the receiver's
//! power-up rate, switches it to 115 200 baud with UBX CFG messages, and decodes recorded
//! M10 epochs (with NMEA, a bad sentence and garbage among them) sent at 5 Hz.
//!
//! The epochs were recorded at 1 Hz (see `data/README.md`); replayed faster than their own
//! time of week advances, each fix's time of validity follows its arrival, so the fix times
//! measure the rate at which the actor really received and decoded them.

mod support;

use std::time::Duration;

use kestrel_proto::messages::{GpsFix, GpsFixType, SensorHealth};
use kestrel_proto::testing::TestSetup;
use kestrel_proto::{Actor, Clock, Context, Time};
use kestrel_sensors::ubx::UbxParser;
use kestrel_sensors::{GpsActor, GpsActorParams, GpsInput};
use support::WallClock;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_serial::{SerialPort, SerialStream};
use tokio_util::sync::CancellationToken;

const EPOCHS: [&[u8]; 4] = [
    include_bytes!("data/m10_epoch1.ubx"),
    include_bytes!("data/m10_epoch2.ubx"),
    include_bytes!("data/m10_epoch3.ubx"),
    include_bytes!("data/m10_epoch4.ubx"),
];
/// Epochs sent: the four recordings, three times over.
const SENT: usize = 12;
const PERIOD: Duration = Duration::from_millis(200);

/// Reads what the actor writes to the receiver until `frames` UBX frames are in.
async fn read_frames(master: &mut SerialStream, frames: usize) -> Vec<(u8, u8, Vec<u8>)> {
    let mut parser = UbxParser::new();
    let mut out = Vec::new();
    let mut buf = [0u8; 256];
    while out.len() < frames {
        let n = tokio::time::timeout(Duration::from_secs(5), master.read(&mut buf))
            .await
            .expect("configuration within 5 s")
            .expect("read");
        parser.push(&buf[..n]);
        out.extend(std::iter::from_fn(|| parser.next_frame()).map(|f| (f.class, f.id, f.payload)));
    }
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn configures_the_receiver_and_decodes_recorded_epochs_at_5_hz_over_a_pty() {
    let (mut master, slave) = SerialStream::pair().expect("pseudo-terminal pair");
    let path = slave.name().expect("pty path");
    let params = GpsActorParams {
        device: path.clone().into(),
        baud: 115_200,
        initial_baud: 9600,
        ..GpsActorParams::default()
    };
    let mut setup = TestSetup::<GpsInput>::new("gps", ".");
    let mut actor = GpsActor::build(&params, &mut setup).expect("opens the pty by path");
    drop(slave);
    let clock = WallClock::new();
    let ctx = Context::new("gps".into(), clock.clone(), CancellationToken::new());
    actor.start(&ctx).await.expect("start");

    // CFG-PRT at 9600 baud, then CFG-PRT, CFG-RATE, CFG-NAV5, CFG-MSG at 115 200.
    let config = read_frames(&mut master, 5).await;
    let ids: Vec<(u8, u8)> = config.iter().map(|(c, i, _)| (*c, *i)).collect();
    assert_eq!(ids, [(6, 0), (6, 0), (6, 8), (6, 0x24), (6, 1)]);
    assert_eq!(&config[0].2[8..12], &115_200u32.to_le_bytes());
    assert_eq!(&config[2].2[0..2], &200u16.to_le_bytes(), "5 Hz measurement rate");
    assert_eq!(config[3].2[2], 7, "airborne < 2 g");
    assert_eq!(config[4].2, [0x01, 0x07, 0x01], "NAV-PVT every solution");
    assert_eq!(master.baud_rate().expect("termios"), 115_200, "the tty was switched");

    let start = tokio::time::Instant::now();
    for k in 0..SENT {
        tokio::time::sleep_until(start + PERIOD * k as u32).await;
        master.write_all(EPOCHS[k % EPOCHS.len()]).await.expect("write");
    }
    tokio::time::sleep(PERIOD).await;
    actor.handle(&ctx, setup.tick("health_report", clock.now())).await.expect("reader healthy");
    ctx.shutdown().cancel();
    actor.stop(&ctx).await;

    let fixes: Vec<GpsFix> = setup.published("gps");
    assert_eq!(fixes.len(), SENT, "one fix per NAV-PVT, none from NMEA while UBX flows");
    let span_s = fixes[SENT - 1].time.saturating_since(fixes[0].time).as_secs_f64();
    let rate_hz = (SENT - 1) as f64 / span_s;
    eprintln!("{SENT} fixes over {span_s:.3} s: {rate_hz:.3} Hz");
    assert!((rate_hz - 5.0).abs() < 0.1, "{rate_hz} Hz");
    for pair in fixes.windows(2) {
        let gap_ms = pair[1].time.saturating_since(pair[0].time).as_secs_f64() * 1e3;
        assert!((gap_ms - 200.0).abs() < 50.0, "{gap_ms} ms between fixes");
    }
    let first = &fixes[0];
    assert_eq!((first.fix_type, first.satellites), (GpsFixType::Fix3d, 14));
    assert!((first.lat_deg - 63.374_386_8).abs() < 1e-9 && (first.lon_deg - 10.341_231_6).abs() < 1e-9);
    assert!((first.alt_msl_m - 160.186).abs() < 1e-9);
    assert_eq!(first.vel_ned_m_s, [-0.015, -0.004, 0.013]);
    assert!((first.h_acc_m - 2.796).abs() < 1e-9 && (first.v_acc_m - 5.483).abs() < 1e-9);
    assert!((first.s_acc_m_s - 0.407).abs() < 1e-9);
    // Epoch 2's NAV-PVT (iTOW 136 905 000): velocity north +14 mm/s, east +6, down +21.
    assert_eq!(fixes[1].vel_ned_m_s, [0.014, 0.006, 0.021]);
    assert!(fixes.iter().all(|f| f.time > Time::ZERO));

    let health: Vec<SensorHealth> = setup.published("health");
    assert_eq!(health.len(), 1);
    assert_eq!(health[0].device, path);
    // One overlong, wrongly summed NMEA sentence per cycle of four epochs; the garbage bytes
    // are skipped while searching for a sync pair, not counted as frames.
    assert_eq!(health[0].errors_total, 3, "{:?}", health[0]);
    assert!((health[0].rate_hz - 5.0).abs() < 0.6, "{:?}", health[0]);
}

#[tokio::test]
async fn a_missing_port_is_an_error_naming_it() {
    let params = GpsActorParams { device: "/dev/ttyKESTREL-none".into(), ..GpsActorParams::default() };
    let err = GpsActor::build(&params, &mut TestSetup::new("gps", ".")).err().expect("no device");
    assert!(err.to_string().contains("/dev/ttyKESTREL-none"), "{err}");
}
