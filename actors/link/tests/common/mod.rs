//! A link hub on real endpoints, driven as the actor drives it (heartbeat 1 Hz, scheduler 50 Hz).

use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use kestrel_link::config::{EndpointConfig, ParamKind, ParamSpec};
use kestrel_link::hub::Hub;
use kestrel_link::services::ToGraph;
use kestrel_link::services::params::ParamTable;
use kestrel_link::transport::{OpenEndpoint, Shared, open_all};
use kestrel_link::vehicle::Vehicle;
use kestrel_proto::clock::Sleep;
use kestrel_proto::{Clock, Time};
use tokio_util::sync::CancellationToken;

/// Wall-clock time since the harness started.
pub struct WallClock(pub Instant);

impl Clock for WallClock {
    fn now(&self) -> Time {
        Time::from_micros(self.0.elapsed().as_micros() as u64)
    }
    fn sleep_until(&self, deadline: Time) -> Sleep {
        let d = deadline.saturating_since(self.now());
        Box::pin(tokio::time::sleep(d))
    }
}

/// The link under test.
pub struct Harness {
    pub hub: Arc<Mutex<Hub>>,
    pub graph: Arc<Mutex<Vec<ToGraph>>>,
    pub endpoints: Vec<OpenEndpoint>,
    shutdown: CancellationToken,
}

impl Drop for Harness {
    fn drop(&mut self) {
        self.shutdown.cancel();
    }
}

/// Two parameters of each kind.
pub fn param_specs(n: usize) -> Vec<ParamSpec> {
    (0..n)
        .map(|i| ParamSpec {
            name: format!("TEST_P{i}"),
            value: i as f64,
            min: 0.0,
            max: 1000.0,
            kind: if i % 2 == 0 { ParamKind::Real32 } else { ParamKind::Int32 },
            unit: String::new(),
        })
        .collect()
}

impl Harness {
    /// Opens `endpoints` and ticks the hub as the actor's timers would (heartbeat 1 Hz,
    /// scheduler 50 Hz).
    pub async fn start(endpoints: &[EndpointConfig], params: usize, config_dir: &Path) -> Harness {
        let clock: Arc<dyn Clock> = Arc::new(WallClock(Instant::now()));
        let table = ParamTable::new(param_specs(params)).expect("valid parameters");
        let hub = Arc::new(Mutex::new(Hub::new(Vehicle::new(1, table, Duration::from_secs(5)))));
        let graph = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&graph);
        let shutdown = CancellationToken::new();
        let shared = Shared {
            hub: Arc::clone(&hub),
            clock: Arc::clone(&clock),
            shutdown: shutdown.clone(),
            graph: Arc::new(move |out| sink.lock().expect("graph sink").extend(out)),
            param_writer: None,
            endpoint: 0,
        };
        let endpoints = open_all(endpoints, config_dir, &shared).await.expect("endpoints open");
        let ticker = shared.clone();
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(Duration::from_millis(20));
            let mut n = 0u64;
            loop {
                tokio::select! {
                    _ = ticker.shutdown.cancelled() => break,
                    _ = tick.tick() => {}
                }
                let now = ticker.clock.now();
                let out = {
                    let mut hub = ticker.hub();
                    if n.is_multiple_of(50) {
                        hub.send_heartbeat();
                    }
                    hub.on_tick(now)
                };
                n += 1;
                (ticker.graph)(out);
            }
        });
        Harness { hub, graph, endpoints, shutdown }
    }
}
