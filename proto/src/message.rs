//! What makes a type a message.

use std::fmt::Debug;

use schemars::JsonSchema;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::time::Time;

/// A message routed between actors and recorded to the flight log.
///
/// Messages are plain data. The recorder stores them as JSON with a JSON Schema generated from
/// the type, so any MCAP tool (Foxglove, the Python `mcap` package) can read a Kestrel log.
pub trait Message: Serialize + DeserializeOwned + JsonSchema + Clone + Debug + Send + Sync + 'static {
    /// The schema name in logs and in config type checks, e.g. `kestrel.ImuSample`.
    const TYPE_NAME: &'static str;

    /// When the content was measured or produced (the log's publish time).
    fn time(&self) -> Time;
}

/// Implements [`Message`] for a struct with a `time: Time` field.
#[macro_export]
macro_rules! impl_message {
    ($ty:ident) => {
        impl $crate::message::Message for $ty {
            const TYPE_NAME: &'static str = concat!("kestrel.", stringify!($ty));
            fn time(&self) -> $crate::time::Time {
                self.time
            }
        }
    };
}
