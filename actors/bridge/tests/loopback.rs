//! Two bridges over real Zenoh on loopback TCP, as two processes of a split graph meet: a
//! NavState published into one comes out of the other with its capture time on the receiver's
//! clock. Run on tokio's current-thread scheduler, which a lockstep graph runs on and which
//! Zenoh itself refuses: the bridge keeps Zenoh on a runtime of its own.

use std::time::Duration;

use kestrel_bridge::{BridgeActor, BridgeInput, BridgeParams};
use kestrel_proto::messages::NavState;
use kestrel_proto::testing::TestSetup;
use kestrel_proto::{Actor, Time};

/// A TCP port nobody listens on now.
fn free_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("a loopback port");
    listener.local_addr().expect("its address").port()
}

fn params(text: &str) -> BridgeParams {
    let params: BridgeParams = toml::from_str(text).expect("bridge params");
    params.check().expect("valid params");
    params
}

#[tokio::test]
async fn a_nav_state_crosses_two_bridges_onto_the_receivers_clock() {
    let port = free_port();
    let sender = params(&format!(
        "vehicle = \"quad\"\nlisten = [\"tcp/127.0.0.1:{port}\"]\npublish = [\"nav_state\"]"
    ));
    let receiver = params(&format!(
        "vehicle = \"quad\"\nconnect = [\"tcp/127.0.0.1:{port}\"]\nsubscribe = [\"nav_state\"]"
    ));
    // The sender's graph clock reads 10 s and the receiver's 3 s at the same instant: the
    // receiver started 7 s later.
    let mut a_setup = TestSetup::<BridgeInput>::new("bridge_a", ".");
    a_setup.manual_clock().set(Time::from_secs_f64(10.0));
    let mut b_setup = TestSetup::<BridgeInput>::new("bridge_b", ".");
    b_setup.manual_clock().set(Time::from_secs_f64(3.0));
    let mut a = BridgeActor::build(&sender, &mut a_setup).expect("sender");
    let mut b = BridgeActor::build(&receiver, &mut b_setup).expect("receiver");
    assert_eq!(a_setup.input_ports(), ["nav_state"]);
    assert_eq!(b_setup.output_ports(), ["nav_state"]);
    let (a_ctx, b_ctx) = (a_setup.context(), b_setup.context());
    a.start(&a_ctx).await.expect("sender session");
    b.start(&b_ctx).await.expect("receiver session");

    let nav = NavState::exact(
        Time::from_secs_f64(9.5),
        [1.0, 0.0, 0.0, 0.0],
        [0.0; 3],
        [1.0, 2.0, 3.0],
        [4.0, 5.0, -6.0],
    );
    // The receiver connects and declares its subscription asynchronously: send until it hears.
    for _ in 0..200 {
        a.handle(&a_ctx, a_setup.input("nav_state", nav.clone())).await.expect("send");
        if b_setup.count("nav_state") > 0 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let got = b_setup.published::<NavState>("nav_state");
    assert!(!got.is_empty(), "no NavState crossed in 10 s");
    // Captured 0.5 s before the sender's now, so 0.5 s before the receiver's: 2.5 s on its clock
    // (less the hop's own latency, which the receiver cannot tell from age).
    let t = got[0].time.as_secs_f64();
    assert!((2.0..=2.5).contains(&t), "captured at {t} s on the receiver's clock");
    assert_eq!((got[0].position_ned_m, got[0].velocity_ned_m_s), (nav.position_ned_m, nav.velocity_ned_m_s));
    a.stop(&a_ctx).await;
    b.stop(&b_ctx).await;
}

#[tokio::test]
async fn max_rate_hz_sends_one_nav_state_per_interval_of_the_graph_clock() {
    let port = free_port();
    let sender = params(&format!(
        "vehicle = \"quad\"\nlisten = [\"tcp/127.0.0.1:{port}\"]\npublish = [\"nav_state\"]\nmax_rate_hz = {{ nav_state = 10.0 }}"
    ));
    let receiver = params(&format!(
        "vehicle = \"quad\"\nconnect = [\"tcp/127.0.0.1:{port}\"]\nsubscribe = [\"nav_state\"]"
    ));
    let mut a_setup = TestSetup::<BridgeInput>::new("bridge_a", ".");
    let mut b_setup = TestSetup::<BridgeInput>::new("bridge_b", ".");
    let mut a = BridgeActor::build(&sender, &mut a_setup).expect("sender");
    let mut b = BridgeActor::build(&receiver, &mut b_setup).expect("receiver");
    let (a_ctx, b_ctx) = (a_setup.context(), b_setup.context());
    a.start(&a_ctx).await.expect("sender session");
    b.start(&b_ctx).await.expect("receiver session");
    let clock = a_setup.manual_clock();
    let mut now_ms = 0u64;
    let nav_at = |ms: u64| {
        NavState::exact(Time::from_micros(ms * 1000), [1.0, 0.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0; 3])
    };
    // Until the receiver hears, one message per 100 ms of graph time: each is due.
    for _ in 0..200 {
        now_ms += 100;
        clock.set(Time::from_micros(now_ms * 1000));
        a.handle(&a_ctx, a_setup.input("nav_state", nav_at(now_ms))).await.expect("send");
        if b_setup.count("nav_state") > 0 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    assert!(b_setup.count("nav_state") > 0, "no NavState crossed in 10 s");
    // The ones sent before the first arrived may still be on their way (one was, once: 11 of
    // 10 counted below): let them land before counting.
    tokio::time::sleep(Duration::from_millis(300)).await;
    let heard = b_setup.count("nav_state");
    // A 100 Hz stream for 1 s of graph time, starting a full interval after the last one sent:
    // 10 of the 100 messages are due (at 0, 100, … 900 ms).
    for k in 0..100 {
        clock.set(Time::from_micros((now_ms + 100 + 10 * k) * 1000));
        a.handle(&a_ctx, a_setup.input("nav_state", nav_at(now_ms + 100 + 10 * k))).await.expect("send");
    }
    for _ in 0..100 {
        if b_setup.count("nav_state") >= heard + 10 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // Time for any message beyond the ten to arrive as well, had the limit let it through.
    tokio::time::sleep(Duration::from_millis(300)).await;
    // At most the ten due: Zenoh drops a put it cannot deliver under congestion (its default
    // for data), and on a loaded host it dropped 8 of the 10 once; without the limit some 100
    // arrive. Exactly which are admitted is the unit test's (`rate_limit.rs`).
    let got = b_setup.count("nav_state") - heard;
    assert!((1..=10).contains(&got), "sent at 10 Hz of the graph clock: {got} of 100 arrived");
    a.stop(&a_ctx).await;
    b.stop(&b_ctx).await;
}
