//! The topics the bridge carries, each with its message type, and what the receiving side must
//! do to a message of that type: move every time in it onto the local clock, and check it.
//!
//! A bridged topic has one message type everywhere, so the topic's name says how to read its
//! key expression's payload on any machine. Adding a topic is one line of [`catalogue!`] and
//! one [`Bridged`] impl.

use kestrel_proto::messages::{
    AvoidanceCommand, CommandResult, DepthGrid, GroundTruth, NavState, Setpoint, VehicleCommand,
    VehicleStatus,
};
use kestrel_proto::{Message, Time};

/// A message the bridge can carry.
pub trait Bridged: Message {
    /// The topic that carries this type across machines (its name in Kestrel's graphs).
    const TOPIC: &'static str;

    /// Whether a message of this topic can move the motors where a graph routes it (a command,
    /// a setpoint, an avoidance correction): the bridge takes it only from a listed source
    /// (`command_sources`, see [`crate::sources`]).
    const MOVES_MOTORS: bool = false;

    /// Calls `f` with every time in the message (each once).
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time));

    /// Moves every time in the message by `by_us` (µs), from the sender's clock onto the
    /// receiver's: graph clocks count from their own process's start.
    fn shift_times(&mut self, by_us: i64) {
        self.visit_times(&mut |t| *t = shifted(*t, by_us));
    }

    /// Clamps every time in the message to `latest` (the receiver's clock now): a message from
    /// the network is never captured in the future, whatever the sender's clock or intent
    /// (a future time would outlive every staleness timeout). Returns by how much the furthest
    /// time was ahead (µs), 0 if none was. Held by `payload::tests::a_clamped_time_is_never_after_the_host_clock`.
    fn clamp_times(&mut self, latest: Time) -> u64 {
        let mut ahead_us = 0;
        self.visit_times(&mut |t| {
            if *t > latest {
                ahead_us = ahead_us.max(t.as_micros() - latest.as_micros());
                *t = latest;
            }
        });
        ahead_us
    }

    /// Whether the receiving graph may take the message; `Err` says what is wrong. The sender's
    /// graph checked it too, but a sample may come from any Zenoh client.
    fn check(&self) -> Result<(), String> {
        Ok(())
    }
}

/// `time` moved by `by_us`, clamped to the clock's range (a time before the receiver's start is
/// its start: the receiver has no earlier time).
pub fn shifted(time: Time, by_us: i64) -> Time {
    Time::from_micros(time.as_micros().saturating_add_signed(by_us))
}

/// Calls the visitor with the message type of a bridged topic.
pub trait TopicVisitor {
    /// Called with `T`, the type of `topic`.
    fn visit<T: Bridged>(&mut self, topic: &'static str);
}

/// Declares the bridged topics once: [`TOPICS`] and [`visit_topic`] both come from this list.
macro_rules! catalogue {
    ($($ty:ty),* $(,)?) => {
        /// Every bridged topic, in the catalogue's order.
        pub const TOPICS: &[&str] = &[$(<$ty as Bridged>::TOPIC),*];

        /// Calls `visitor` with the type of `topic`; `false` if the topic is not bridged.
        pub fn visit_topic(topic: &str, visitor: &mut impl TopicVisitor) -> bool {
            $(
                if topic == <$ty as Bridged>::TOPIC {
                    visitor.visit::<$ty>(<$ty as Bridged>::TOPIC);
                    return true;
                }
            )*
            false
        }
    };
}

catalogue!(
    NavState,
    GroundTruth,
    Setpoint,
    DepthGrid,
    AvoidanceCommand,
    VehicleStatus,
    VehicleCommand,
    CommandResult,
);

impl Bridged for NavState {
    const TOPIC: &'static str = "nav_state";
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time)) {
        f(&mut self.time);
    }
}

impl Bridged for GroundTruth {
    const TOPIC: &'static str = "ground_truth";
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time)) {
        f(&mut self.time);
    }
}

impl Bridged for Setpoint {
    const TOPIC: &'static str = "setpoint";
    const MOVES_MOTORS: bool = true;
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time)) {
        f(&mut self.time);
    }
}

impl Bridged for DepthGrid {
    const TOPIC: &'static str = "depth_grid";
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time)) {
        f(&mut self.time);
    }
}

impl Bridged for AvoidanceCommand {
    const TOPIC: &'static str = "avoidance_command";
    const MOVES_MOTORS: bool = true;
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time)) {
        f(&mut self.time);
        if let Some(grid_time) = &mut self.grid_time {
            f(grid_time);
        }
    }
}

impl Bridged for VehicleStatus {
    const TOPIC: &'static str = "vehicle_status";
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time)) {
        f(&mut self.time);
        if let Some(failsafe) = &mut self.failsafe {
            f(&mut failsafe.since);
        }
    }
}

/// The command ids a Zenoh client may use: the link numbers its MAVLink commands from 1
/// upwards, so the upper half of the range can never answer one of them by mistake.
pub const FIRST_BRIDGED_COMMAND_ID: u32 = 1 << 31;

impl Bridged for VehicleCommand {
    const TOPIC: &'static str = "vehicle_command";
    const MOVES_MOTORS: bool = true;
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time)) {
        f(&mut self.time);
    }

    /// The commander checks what a command asks for (arming checks, modes, finite targets);
    /// the bridge checks only that its answer cannot go to a ground station's command.
    fn check(&self) -> Result<(), String> {
        if self.id != 0 && self.id < FIRST_BRIDGED_COMMAND_ID {
            return Err(format!(
                "command id {} is in the link's range; use 0 (no answer) or at least {FIRST_BRIDGED_COMMAND_ID}",
                self.id
            ));
        }
        Ok(())
    }
}

impl Bridged for CommandResult {
    const TOPIC: &'static str = "command_result";
    fn visit_times(&mut self, f: &mut dyn FnMut(&mut Time)) {
        f(&mut self.time);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Names(Vec<(&'static str, &'static str)>);

    impl TopicVisitor for Names {
        fn visit<T: Bridged>(&mut self, topic: &'static str) {
            self.0.push((topic, T::TYPE_NAME));
        }
    }

    #[test]
    fn every_topic_has_one_type_and_every_type_one_topic() {
        let mut names = Names(Vec::new());
        for topic in TOPICS {
            assert!(visit_topic(topic, &mut names), "{topic}");
        }
        assert!(!visit_topic("imu", &mut names));
        let mut types: Vec<_> = names.0.iter().map(|(_, t)| *t).collect();
        types.sort_unstable();
        types.dedup();
        assert_eq!(types.len(), TOPICS.len(), "{:?}", names.0);
        assert!(names.0.contains(&("nav_state", "kestrel.NavState")), "{:?}", names.0);
    }

    #[test]
    fn a_shift_clamps_at_the_clock_origin_and_moves_nested_times() {
        assert_eq!(shifted(Time::from_micros(1_000), -400), Time::from_micros(600));
        assert_eq!(shifted(Time::from_micros(1_000), -4_000), Time::ZERO);
        let mut cmd = AvoidanceCommand {
            time: Time::from_micros(5_000),
            grid_time: Some(Time::from_micros(4_000)),
            ..AvoidanceCommand::default()
        };
        cmd.shift_times(1_000);
        assert_eq!((cmd.time, cmd.grid_time), (Time::from_micros(6_000), Some(Time::from_micros(5_000))));
    }
}
