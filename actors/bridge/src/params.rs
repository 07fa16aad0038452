//! The bridge's parameters (`[actors.NAME.params]`), checked before any session opens.

use std::collections::BTreeMap;

use serde::Deserialize;

use crate::catalogue::{Bridged, TOPICS, TopicVisitor, visit_topic};
use crate::error::BridgeError;
use crate::key_expr::{check_chunk, instance_vehicle};
use crate::sources::CommandSources;

/// How the bridge joins a Zenoh network (Zenoh's own words).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Talks to other peers directly (two computers on one vehicle, or one machine).
    #[default]
    Peer,
    /// Talks through a Zenoh router (`connect` names it), as a ground station's fleet does.
    Client,
}

impl Mode {
    /// Zenoh's name of the mode.
    pub fn zenoh_name(self) -> &'static str {
        match self {
            Mode::Peer => "peer",
            Mode::Client => "client",
        }
    }
}

/// The transports this build of Zenoh has (`tcp/HOST:PORT`): the crate builds Zenoh with its
/// TCP link alone (Cargo.toml says why).
pub const PROTOCOLS: &[&str] = &["tcp"];

/// The bridge's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BridgeParams {
    /// This vehicle's name, the second chunk of its key expressions `kestrel/<vehicle>/<topic>`.
    pub vehicle: String,
    /// `kestrel run --instance N` (set by the runtime): the vehicle is then `<vehicle>-<N>`.
    #[serde(default)]
    pub instance: Option<u8>,
    #[serde(default)]
    pub mode: Mode,
    /// Endpoints to connect to, e.g. `tcp/192.168.1.10:7447`; retried until they answer.
    #[serde(default)]
    pub connect: Vec<String>,
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:7447`. With `--instance N` each port moves
    /// up by N (port 0, any free port, stays 0), as the link's ports do, so a fleet on one
    /// machine listens on 7447, 7448, ...
    #[serde(default)]
    pub listen: Vec<String>,
    /// A Zenoh config file (json5, Zenoh's own format; relative to the graph config's
    /// directory) with who may connect (`transport.auth.usrpwd`) and what each peer may do
    /// (`access_control`). Required, with access control on and denying by default, when the
    /// bridge subscribes to a topic that moves the motors. See the user guide's "Zenoh keys".
    #[serde(default)]
    pub zenoh_config: Option<String>,
    /// The Zenoh ids (`38a4829bce9166ee`, as Zenoh prints them) that may send the topics that
    /// move the motors (`vehicle_command`, `avoidance_command`, `setpoint`): a sample of those
    /// is taken only when its timestamp names one of them (see [`crate::sources`]).
    #[serde(default)]
    pub command_sources: Vec<String>,
    /// Multicast scouting (finding peers on the LAN by itself). Off by default: a vehicle
    /// talks only to the endpoints it is given.
    #[serde(default)]
    pub scouting: bool,
    /// Local topics sent to the network as `kestrel/<vehicle>/<topic>`; each is also an input
    /// port of the bridge, which the config routes with the mailbox kind it wants.
    #[serde(default)]
    pub publish: Vec<String>,
    /// Topics of this vehicle taken from the network and published into the local graph, as
    /// an output of the bridge of the same name; local actors subscribe to them like any topic.
    #[serde(default)]
    pub subscribe: Vec<String>,
    /// At most this many messages a second sent on a `publish` topic (Hz), e.g.
    /// `{ nav_state = 20.0 }` for a radio link; the others are dropped. Commands
    /// (`vehicle_command`, `command_result`) are never throttled: each one counts.
    #[serde(default)]
    pub max_rate_hz: BTreeMap<String, f64>,
}

impl BridgeParams {
    /// The vehicle name in key expressions.
    pub fn vehicle_name(&self) -> String {
        instance_vehicle(&self.vehicle, self.instance)
    }

    /// `listen` with each port moved up by `instance` (port 0 stays 0).
    pub fn listen_endpoints(&self) -> Result<Vec<String>, BridgeError> {
        let n = u16::from(self.instance.unwrap_or(0));
        self.listen
            .iter()
            .map(|endpoint| {
                let bad = || BridgeError::Param {
                    param: "listen",
                    why: format!("endpoint {endpoint:?}: its port plus the instance {n} is not a port"),
                };
                let (head, port) = endpoint.rsplit_once(':').ok_or_else(bad)?;
                let port: u16 = port.parse().map_err(|_| bad())?;
                let moved = if port == 0 { 0 } else { port.checked_add(n).ok_or_else(bad)? };
                Ok(format!("{head}:{moved}"))
            })
            .collect()
    }

    /// The subscribed topics that move the motors.
    pub fn motor_topics(&self) -> Vec<&str> {
        self.subscribe.iter().map(String::as_str).filter(|t| moves_motors(t)).collect()
    }

    /// Checks every parameter; the first problem found, naming the parameter.
    pub fn check(&self) -> Result<(), BridgeError> {
        check_chunk("vehicle", &self.vehicle_name())?;
        if self.mode == Mode::Client && self.connect.is_empty() {
            return Err(BridgeError::Param {
                param: "connect",
                why: "a client needs a router to connect to (e.g. [\"tcp/127.0.0.1:7447\"])".into(),
            });
        }
        if self.mode == Mode::Peer && self.connect.is_empty() && self.listen.is_empty() && !self.scouting {
            return Err(BridgeError::Param {
                param: "connect",
                why: "a peer with no `connect`, no `listen` and no `scouting` can never meet another".into(),
            });
        }
        for (param, endpoints) in [("connect", &self.connect), ("listen", &self.listen)] {
            for endpoint in endpoints {
                check_endpoint(endpoint).map_err(|why| BridgeError::Param { param, why })?;
            }
        }
        if self.publish.is_empty() && self.subscribe.is_empty() {
            return Err(BridgeError::Param {
                param: "publish",
                why: "nothing to publish or subscribe to".into(),
            });
        }
        for (param, topics) in [("publish", &self.publish), ("subscribe", &self.subscribe)] {
            for (i, topic) in topics.iter().enumerate() {
                if !visit_topic(topic, &mut Nothing) {
                    return Err(BridgeError::UnknownTopic {
                        param,
                        topic: topic.clone(),
                        known: TOPICS.join(", "),
                    });
                }
                if topics[..i].contains(topic) {
                    return Err(BridgeError::Param {
                        param,
                        why: format!("topic '{topic}' is listed twice"),
                    });
                }
            }
        }
        for (topic, &rate_hz) in &self.max_rate_hz {
            let why = if !self.publish.contains(topic) {
                format!("topic '{topic}' is not published")
            } else if UNTHROTTLED.contains(&topic.as_str()) {
                format!("topic '{topic}' carries commands, each of which counts")
            } else if !(rate_hz.is_finite() && rate_hz > 0.0) {
                format!("{topic} = {rate_hz}: a rate must be finite and above 0 Hz")
            } else {
                continue;
            };
            return Err(BridgeError::Param { param: "max_rate_hz", why });
        }
        if let Some(both) = self.publish.iter().find(|t| self.subscribe.contains(t)) {
            return Err(BridgeError::Param {
                param: "subscribe",
                why: format!("topic '{both}' is also published: the bridge would hear itself"),
            });
        }
        let sources = CommandSources::parse(&self.command_sources)?;
        if let Some(topic) = self.motor_topics().first() {
            if self.zenoh_config.is_none() {
                return Err(BridgeError::Param {
                    param: "zenoh_config",
                    why: format!(
                        "subscribing to '{topic}', which moves the motors, needs a Zenoh config file \
                         with access control (see config/zenoh/)"
                    ),
                });
            }
            if sources.is_empty() {
                return Err(BridgeError::Param {
                    param: "command_sources",
                    why: format!(
                        "subscribing to '{topic}', which moves the motors, needs the Zenoh ids that may send it"
                    ),
                });
            }
        } else if !sources.is_empty() {
            return Err(BridgeError::Param {
                param: "command_sources",
                why: "no subscribed topic moves the motors, so no source is checked".into(),
            });
        }
        self.listen_endpoints()?;
        Ok(())
    }
}

/// Topics `max_rate_hz` may not throttle: a dropped command is a lost command.
const UNTHROTTLED: &[&str] = &["vehicle_command", "command_result"];

/// Whether `topic` is a bridged topic that moves the motors ([`Bridged::MOVES_MOTORS`]).
pub fn moves_motors(topic: &str) -> bool {
    struct Moves(bool);
    impl TopicVisitor for Moves {
        fn visit<T: Bridged>(&mut self, _topic: &'static str) {
            self.0 = T::MOVES_MOTORS;
        }
    }
    let mut moves = Moves(false);
    visit_topic(topic, &mut moves);
    moves.0
}

struct Nothing;

impl TopicVisitor for Nothing {
    fn visit<T: Bridged>(&mut self, _topic: &'static str) {}
}

/// Checks a Zenoh endpoint `PROTOCOL/HOST:PORT` (no `#` link options: the bridge sets none).
fn check_endpoint(endpoint: &str) -> Result<(), String> {
    let Some((protocol, address)) = endpoint.split_once('/') else {
        return Err(format!("endpoint {endpoint:?} is not PROTOCOL/HOST:PORT (e.g. tcp/127.0.0.1:7447)"));
    };
    if !PROTOCOLS.contains(&protocol) {
        return Err(format!(
            "endpoint {endpoint:?}: protocol '{protocol}' is not built in; only {}",
            PROTOCOLS.join(", ")
        ));
    }
    let port = address.rsplit_once(':').map(|(host, port)| (host, port.parse::<u16>()));
    match port {
        Some((host, Ok(_))) if !host.is_empty() && !address.contains(['#', '?', '/']) => Ok(()),
        _ => Err(format!("endpoint {endpoint:?}: '{address}' is not HOST:PORT with a port 0..65535")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(toml_text: &str) -> BridgeParams {
        toml::from_str(toml_text).unwrap()
    }

    const GOOD: &str = r#"
        vehicle = "kestrel"
        listen = ["tcp/127.0.0.1:7447"]
        publish = ["nav_state", "ground_truth"]
        subscribe = ["avoidance_command"]
        zenoh_config = "zenoh/flight.json5"
        command_sources = ["a1"]
    "#;

    #[test]
    fn a_good_config_passes_and_names_its_vehicle() {
        let p = params(GOOD);
        p.check().unwrap();
        assert_eq!((p.mode, p.scouting), (Mode::Peer, false), "peer, no scouting by default");
        assert_eq!(p.vehicle_name(), "kestrel");
        assert_eq!(p.listen_endpoints().unwrap(), ["tcp/127.0.0.1:7447"]);
        assert_eq!(p.motor_topics(), ["avoidance_command"]);
        let second = BridgeParams {
            instance: Some(2),
            listen: vec!["tcp/[::1]:7447".into(), "tcp/0.0.0.0:0".into()],
            ..p
        };
        assert_eq!(second.vehicle_name(), "kestrel-2");
        assert_eq!(second.listen_endpoints().unwrap(), ["tcp/[::1]:7449", "tcp/0.0.0.0:0"]);
    }

    #[test]
    fn the_topics_that_move_the_motors_are_the_commands_and_setpoints() {
        let moving: Vec<&str> = TOPICS.iter().copied().filter(|t| moves_motors(t)).collect();
        assert_eq!(moving, ["setpoint", "avoidance_command", "vehicle_command"]);
        assert!(!moves_motors("imu"));
    }

    #[test]
    fn each_bad_parameter_is_named_with_what_is_wrong() {
        let cases: &[(&str, &str)] = &[
            ("vehicle = \"a/b\"", "vehicle name \"a/b\" holds '/'"),
            ("mode = \"client\"\nlisten = []", "parameter 'connect': a client needs a router"),
            ("listen = []", "a peer with no `connect`, no `listen` and no `scouting`"),
            (
                "listen = [\"quic/1.2.3.4:7447\"]",
                "parameter 'listen': endpoint \"quic/1.2.3.4:7447\": protocol 'quic' is not built in; only tcp",
            ),
            ("connect = [\"udp/1.2.3.4:7447\"]", "protocol 'udp' is not built in; only tcp"),
            (
                "connect = [\"tcp/host\"]",
                "parameter 'connect': endpoint \"tcp/host\": 'host' is not HOST:PORT",
            ),
            ("connect = [\"127.0.0.1:7447\"]", "is not PROTOCOL/HOST:PORT"),
            ("listen = [\"tcp/127.0.0.1:99999\"]", "with a port 0..65535"),
            (
                "publish = [\"imu\"]",
                "parameter 'publish': topic 'imu' is not bridged; bridged topics: nav_state, ground_truth",
            ),
            ("publish = [\"nav_state\", \"nav_state\"]", "topic 'nav_state' is listed twice"),
            ("subscribe = [\"nav_state\"]", "topic 'nav_state' is also published"),
            ("publish = []\nsubscribe = []", "nothing to publish or subscribe to"),
            (
                "max_rate_hz = { depth_grid = 5.0 }",
                "parameter 'max_rate_hz': topic 'depth_grid' is not published",
            ),
            ("max_rate_hz = { nav_state = 0.0 }", "nav_state = 0: a rate must be finite and above 0 Hz"),
            ("max_rate_hz = { nav_state = -1.0 }", "a rate must be finite and above 0 Hz"),
            ("max_rate_hz = { nav_state = inf }", "nav_state = inf: a rate must be finite"),
            ("max_rate_hz = { nav_state = nan }", "a rate must be finite and above 0 Hz"),
            (
                "command_sources = []",
                "parameter 'command_sources': subscribing to 'avoidance_command', which moves the motors, needs the Zenoh ids",
            ),
            ("command_sources = [\"A1\"]", "parameter 'command_sources': zenoh id \"A1\" holds a character"),
            (
                "subscribe = [\"depth_grid\"]",
                "parameter 'command_sources': no subscribed topic moves the motors",
            ),
            (
                "listen = [\"tcp/127.0.0.1:65535\"]\ninstance = 1",
                "parameter 'listen': endpoint \"tcp/127.0.0.1:65535\": its port plus the instance 1 is not a port",
            ),
        ];
        for (change, expected) in cases {
            let key = change.split(' ').next().unwrap();
            let kept: String = GOOD
                .lines()
                .filter(|l| !l.trim_start().starts_with(&format!("{key} ")))
                .collect::<Vec<_>>()
                .join("\n");
            let second = change.lines().nth(1).and_then(|l| l.split(' ').next());
            let kept: String = kept
                .lines()
                .filter(|l| second.is_none_or(|k| !l.trim_start().starts_with(&format!("{k} "))))
                .collect::<Vec<_>>()
                .join("\n");
            let e = match toml::from_str::<BridgeParams>(&format!("{kept}\n{change}")) {
                Ok(p) => p.check().unwrap_err().to_string(),
                Err(e) => e.to_string(),
            };
            assert!(e.contains(expected), "{change}: {e}");
        }
        let mut no_file = params(GOOD);
        no_file.zenoh_config = None;
        let e = no_file.check().unwrap_err().to_string();
        assert!(
            e.contains("parameter 'zenoh_config': subscribing to 'avoidance_command', which moves the motors, needs a Zenoh config file"),
            "{e}"
        );
        let unknown = toml::from_str::<BridgeParams>("vehicle = \"v\"\nendpoints = []").unwrap_err();
        assert!(unknown.to_string().contains("unknown field `endpoints`"), "{unknown}");
    }
}
