use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// What happened to a supervised actor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SupervisorEventKind {
    /// The actor returned an error or panicked and will be restarted after a backoff.
    Failed,
    /// The actor was restarted.
    Restarted,
    /// The actor failed more often than its restart limit allows, or in a way restarting
    /// cannot mend (its parameters), or its policy is `never`; it stays stopped.
    GaveUp,
    /// The actor ended normally ([`crate::Context::stop`]); restarted only if its policy is
    /// `permanent`.
    Stopped,
}

/// A failure report from the supervisor, published on the runtime's `supervisor` topic so the
/// commander can treat a flight-critical failure as a failsafe cause.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SupervisorEvent {
    pub time: Time,
    /// The actor's name in the config.
    pub actor: String,
    pub kind: SupervisorEventKind,
    /// Whether the config marks this actor flight-critical.
    pub critical: bool,
    /// The error or panic message.
    pub reason: String,
    /// Restarts within the current window, including this one.
    pub restarts_in_window: u32,
}
crate::impl_message!(SupervisorEvent);
