//! The link actor's parameters (`[actors.link.params]`): endpoints, identity, parameter table.
//!
//! ```toml
//! [actors.link]
//! type = "link"
//! params.system_id = 1
//! params.gcs_timeout_s = 5.0
//! params.param_file = "link_params.txt"   # NAME=VALUE lines, rewritten atomically on PARAM_SET
//! params.endpoints = [
//!   # PX4 SITL's ports: to QGroundControl / MAVProxy from local port 18570, and to MAVSDK /
//!   # MAVROS / scripts, which listen on 14540, from local port 14580 (which accepts as well).
//!   { type = "udp_out", address = "127.0.0.1:14550", bind = "127.0.0.1:18570" },
//!   { type = "udp_out", address = "127.0.0.1:14540", bind = "127.0.0.1:14580", per_instance = true },
//!   { type = "udp_in", bind = "0.0.0.0:14560", max_peers = 8 },  # answers whoever talks
//!   { type = "tcp_in", bind = "0.0.0.0:5760" },
//!   { type = "serial", device = "/dev/ttyUSB0", baud = 57600, flow_control = false,
//!     signing_key_file = "radio.key" },
//! ]
//! params.params = [
//!   { name = "RTL_ALT_M", value = 30.0, min = 5.0, max = 120.0, unit = "m" },
//!   { name = "FS_GCS_ENABLE", value = 1, min = 0, max = 1, kind = "int32" },
//! ]
//! ```

use std::net::SocketAddr;
use std::path::PathBuf;

use serde::Deserialize;

/// Everything the link actor is configured with; every field has a default, so `params = {}`
/// gives PX4 SITL's ports: MAVLink to UDP 127.0.0.1:14550 from local port 18570, and to
/// 127.0.0.1:14540 from local port 14580.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkParams {
    /// Our MAVLink system id (1..=255).
    #[serde(default = "default_system_id")]
    pub system_id: u8,
    /// Where MAVLink goes in and out; several at once are routed between each other.
    #[serde(default = "default_endpoints")]
    pub endpoints: Vec<EndpointConfig>,
    /// Parameters the link serves itself, for benches without their owners (a "link only"
    /// graph). The graph's actors declare their own on the `param_decl` port; a declaration
    /// replaces a listed parameter of the same name.
    #[serde(default)]
    pub params: Vec<ParamSpec>,
    /// Where changed parameter values persist (`NAME=VALUE` lines, replaced atomically);
    /// relative to the config directory. `None`: changes live only until restart.
    #[serde(default)]
    pub param_file: Option<PathBuf>,
    /// Seconds without a ground-station heartbeat before a STATUSTEXT says the link is lost
    /// (the commander's own data-link timer decides the failsafe).
    #[serde(default = "default_gcs_timeout_s")]
    pub gcs_timeout_s: f64,
    /// Which of several vehicles on one machine this is (`kestrel run --instance N`), as PX4's
    /// multi-vehicle SITL numbers them: the system id becomes `system_id + N`, every local
    /// port (`bind`) moves up by N, and so does the `address` port of endpoints marked
    /// `per_instance` (the API port 14540 + N); the ground station's 14550 stays, so one
    /// ground station sees every vehicle. See [`LinkParams::for_instance`].
    #[serde(default)]
    pub instance: u8,
    /// The vehicle's log directory, served by log download and FTP (`services::log_download`,
    /// `services::ftp`). The runtime sets it from `[record] dir`; `None`: no logs are served.
    #[serde(default)]
    pub log_dir: Option<PathBuf>,
    /// Where the vehicle keeps what a restart must not lose: the uploaded mission, fence and
    /// rally points (`services::mission::store`) and the parameters set (`params.parm`, unless
    /// `param_file` names a file). The runtime sets it from the graph's `[state] dir`; relative
    /// to the config directory otherwise. `None`: nothing outlives the run.
    #[serde(default)]
    pub state_dir: Option<PathBuf>,
}

impl Default for LinkParams {
    fn default() -> Self {
        LinkParams {
            system_id: default_system_id(),
            endpoints: default_endpoints(),
            params: Vec::new(),
            param_file: None,
            gcs_timeout_s: default_gcs_timeout_s(),
            instance: 0,
            log_dir: None,
            state_dir: None,
        }
    }
}

impl LinkParams {
    /// The parameters with `instance` applied (system id and ports moved; `instance` then 0), or
    /// why that is impossible: a system id past 255 or a port past 65535.
    pub fn for_instance(&self) -> Result<LinkParams, String> {
        let n = self.instance;
        let system_id = u8::try_from(u16::from(self.system_id) + u16::from(n))
            .map_err(|_| format!("instance {n}: system id {} + {n} is past 255", self.system_id))?;
        let shift = |a: SocketAddr| -> Result<SocketAddr, String> {
            let port = a.port();
            if port == 0 {
                return Ok(a);
            }
            let moved = u16::try_from(u32::from(port) + u32::from(n))
                .map_err(|_| format!("instance {n}: port {port} + {n} is past 65535"))?;
            Ok(SocketAddr::new(a.ip(), moved))
        };
        let mut endpoints = self.endpoints.clone();
        for e in &mut endpoints {
            match &mut e.kind {
                EndpointKind::UdpOut { address, bind, per_instance } => {
                    if let Some(b) = bind {
                        *b = shift(*b)?;
                    }
                    if *per_instance {
                        *address = shift(*address)?;
                    }
                }
                EndpointKind::UdpIn { bind, .. } | EndpointKind::TcpIn { bind } => *bind = shift(*bind)?,
                EndpointKind::Serial { .. } => {}
            }
        }
        Ok(LinkParams { system_id, endpoints, instance: 0, ..self.clone() })
    }
}

fn default_system_id() -> u8 {
    1
}

fn default_gcs_timeout_s() -> f64 {
    5.0
}

fn default_endpoints() -> Vec<EndpointConfig> {
    vec![
        EndpointConfig {
            kind: EndpointKind::UdpOut {
                address: SocketAddr::from(([127, 0, 0, 1], 14550)),
                bind: Some(SocketAddr::from(([127, 0, 0, 1], 18570))),
                per_instance: false,
            },
            signing_key_file: None,
        },
        EndpointConfig {
            kind: EndpointKind::UdpOut {
                address: SocketAddr::from(([127, 0, 0, 1], 14540)),
                bind: Some(SocketAddr::from(([127, 0, 0, 1], 14580))),
                per_instance: true,
            },
            signing_key_file: None,
        },
    ]
}

/// One endpoint and its signing policy.
#[derive(Clone, Debug, Deserialize)]
pub struct EndpointConfig {
    #[serde(flatten)]
    pub kind: EndpointKind,
    /// MAVLink 2 signing key for this endpoint: a file holding 32 raw bytes or 64 hex digits,
    /// readable by its owner alone (mode 0600; otherwise refused). When set, outgoing frames are
    /// signed and unsigned inbound frames (but RADIO_STATUS) are refused and counted; see
    /// `transport::signing`.
    #[serde(default)]
    pub signing_key_file: Option<PathBuf>,
}

/// The kinds of endpoint, as in mavlink-router's config.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum EndpointKind {
    /// UDP client: sends to `address`, from `bind` (a fixed local port, as PX4 SITL's 18570 and
    /// 14580) or else an ephemeral one, and hears every frame arriving there, from anyone.
    UdpOut {
        #[serde(deserialize_with = "address")]
        address: SocketAddr,
        #[serde(default, deserialize_with = "optional_bind")]
        bind: Option<SocketAddr>,
        /// `--instance N` adds N to `address`'s port too (the API port, 14540 + N).
        #[serde(default)]
        per_instance: bool,
    },
    /// UDP server: listens on `bind` and answers every peer that has sent it a valid MAVLink
    /// frame, at most `max_peers` at once (a newcomer to a full table replaces a peer silent
    /// for 3 s, or is refused and counted).
    UdpIn {
        #[serde(deserialize_with = "bind")]
        bind: SocketAddr,
        #[serde(default = "default_max_peers")]
        max_peers: usize,
    },
    /// TCP server: every accepted connection is a link of its own.
    TcpIn {
        #[serde(deserialize_with = "bind")]
        bind: SocketAddr,
    },
    /// Serial port, e.g. a 433 MHz SiK radio.
    Serial {
        device: PathBuf,
        #[serde(default = "default_baud")]
        baud: u32,
        /// RTS/CTS hardware flow control (SiK radios support it when wired).
        #[serde(default)]
        flow_control: bool,
    },
}

/// An endpoint's `address`, refused with the field and the text when it is not `IP:PORT`.
fn address<'de, D: serde::Deserializer<'de>>(d: D) -> Result<SocketAddr, D::Error> {
    socket_address("address", d)
}

/// An endpoint's `bind`, refused with the field and the text when it is not `IP:PORT`.
fn bind<'de, D: serde::Deserializer<'de>>(d: D) -> Result<SocketAddr, D::Error> {
    socket_address("bind", d)
}

/// A `udp_out`'s optional `bind`.
fn optional_bind<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<SocketAddr>, D::Error> {
    socket_address("bind", d).map(Some)
}

fn socket_address<'de, D: serde::Deserializer<'de>>(field: &str, d: D) -> Result<SocketAddr, D::Error> {
    let text = String::deserialize(d)?;
    text.parse().map_err(|e| {
        serde::de::Error::custom(format!(
            "endpoint {field} \"{text}\": {e} (expected IP:PORT with a port 0..=65535, e.g. \"127.0.0.1:14550\" or \"[::1]:14550\")"
        ))
    })
}

fn default_max_peers() -> usize {
    8
}

fn default_baud() -> u32 {
    57_600
}

/// A named, typed, bounded parameter.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamSpec {
    /// At most 16 characters (MAVLink's `param_id`).
    pub name: String,
    pub value: f64,
    #[serde(default = "neg_inf")]
    pub min: f64,
    #[serde(default = "pos_inf")]
    pub max: f64,
    #[serde(default)]
    pub kind: ParamKind,
    /// Unit, for documentation and STATUSTEXT (`m`, `m/s`, `s`, ...).
    #[serde(default)]
    pub unit: String,
}

fn neg_inf() -> f64 {
    f64::NEG_INFINITY
}

fn pos_inf() -> f64 {
    f64::INFINITY
}

/// How a parameter's value is typed on the wire (C-cast into `param_value`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParamKind {
    #[default]
    Real32,
    Int32,
    Uint8,
}
