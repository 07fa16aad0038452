//! What can go wrong in the bridge, each naming the parameter, topic or key expression at fault.

/// A bridge failure: bad parameters (refused at start-up) or a sample that cannot be taken.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// A vehicle or topic name that cannot be a key expression chunk.
    #[error("{what} name {name:?} {why}")]
    Name { what: &'static str, name: String, why: String },
    /// A parameter of `[actors.NAME.params]` is unusable.
    #[error("parameter '{param}': {why}")]
    Param { param: &'static str, why: String },
    /// A topic listed in `publish` or `subscribe` that the bridge cannot carry.
    #[error("parameter '{param}': topic '{topic}' is not bridged; bridged topics: {known}")]
    UnknownTopic { param: &'static str, topic: String, known: String },
    /// The Zenoh config file (`zenoh_config`) is unusable; `field` is Zenoh's path of the field
    /// at fault (`listen/endpoints`), empty for the file as a whole.
    #[error("zenoh config {}{}{field}: {why}", file.display(), if field.is_empty() { "" } else { ", field " })]
    ZenohConfig { file: std::path::PathBuf, field: String, why: String },
    /// A sample whose payload is not a valid message of its topic's type.
    #[error("sample on '{key}' ({schema}): {why}")]
    Payload { key: String, schema: &'static str, why: String },
}
