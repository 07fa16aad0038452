use kestrel_proto::messages::CommandResult;
use mavlink::dialects::ardupilotmega::{COMMAND_LONG_DATA, MavCmd, MavMessage, MavResult};
use num_traits::FromPrimitive;
use proptest::prelude::*;

use super::{COMPONENT_ID, Vehicle};
use crate::services::command::ACK_TIMEOUT;
use crate::services::params::ParamTable;
use crate::services::{Sender, ToGraph};
use kestrel_proto::Time;

const GCS: Sender = Sender { system_id: 245, component_id: 190 };

/// Every MAV_CMD id the dialect knows (common and ArduPilot's).
fn every_command() -> Vec<MavCmd> {
    (0..=u16::MAX.into()).filter_map(MavCmd::from_u32).collect()
}

fn param() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(0.0),
        Just(1.0),
        Just(-1.0),
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        (0u32..100).prop_map(|n| n as f32),
        any::<f32>(),
        -1e3f32..1e3,
    ]
}

fn acks(mav: &[MavMessage], command: MavCmd) -> Vec<(MavResult, u8, u8)> {
    mav.iter()
        .filter_map(|m| match m {
            MavMessage::COMMAND_ACK(a) if a.command == command => {
                Some((a.result, a.target_system, a.target_component))
            }
            _ => None,
        })
        .collect()
}

/// A vehicle that knows where it is (DO_REPOSITION, GET_HOME_POSITION need an origin).
fn vehicle() -> Vehicle {
    let mut v =
        Vehicle::new(1, ParamTable::new(Vec::new()).expect("valid"), std::time::Duration::from_secs(5));
    v.on_nav(super::tests::at_origin());
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]
    #[test]
    fn every_command_gets_exactly_one_ack(
        index in any::<prop::sample::Index>(),
        p in prop::array::uniform7(param()),
        refused in any::<bool>(),
    ) {
        let commands = every_command();
        let command = commands[index.index(commands.len())];
        let mut v = vehicle();
        let msg = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            command,
            param1: p[0], param2: p[1], param3: p[2], param4: p[3], param5: p[4], param6: p[5], param7: p[6],
            target_system: 1,
            target_component: COMPONENT_ID,
            confirmation: 0,
        });
        let now = Time::from_secs_f64(1.0);
        let out = v.on_message(GCS, &msg, now);
        let mut answers = acks(&out.mav, command);
        let asked: Vec<u32> = out.graph.iter().filter_map(|g| match g {
            ToGraph::Request { id, .. } => Some(*id),
            _ => None,
        }).collect();
        prop_assert!(asked.len() <= 1, "{command:?}: {} requests", asked.len());
        for id in &asked {
            let refusal = refused.then(|| "refused".to_owned());
            let got = v.on_command_result(&CommandResult { time: now, id: *id, command: kestrel_proto::messages::Command::Heartbeat { system_id: 255 }, refusal });
            answers.extend(acks(&got.mav, command));
            // The same answer again (a duplicate on the graph) is not acknowledged twice.
            let again = v.on_command_result(&CommandResult { time: now, id: *id, command: kestrel_proto::messages::Command::Heartbeat { system_id: 255 }, refusal: None });
            answers.extend(acks(&again.mav, command));
        }
        let (late, _) = v.on_tick(now + ACK_TIMEOUT + ACK_TIMEOUT);
        answers.extend(acks(&late.mav, command));
        prop_assert_eq!(answers.len(), 1, "{:?} {:?}: {:?}", command, p, answers);
        let (result, system, component) = answers[0];
        prop_assert_eq!((system, component), (245, 190), "addressed to its sender");
        if result == MavResult::MAV_RESULT_UNSUPPORTED {
            prop_assert!(out.graph.is_empty(), "{command:?} is unsupported yet reached the graph: {:?}", out.graph);
        }
        if !asked.is_empty() {
            // A refused DO_REPOSITION is FAILED, as ArduCopter answers a destination it will not
            // fly, and so is a refused DO_LAND_START, as it answers one with no landing sequence.
            let want = match (refused, command) {
                (false, _) => MavResult::MAV_RESULT_ACCEPTED,
                (true, MavCmd::MAV_CMD_DO_REPOSITION | MavCmd::MAV_CMD_DO_LAND_START) => {
                    MavResult::MAV_RESULT_FAILED
                }
                (true, _) => MavResult::MAV_RESULT_DENIED,
            };
            prop_assert_eq!(result, want, "{:?}: the commander's answer", command);
        }
    }
}

#[test]
fn the_dialect_has_the_commands_ground_stations_send() {
    let all = every_command();
    assert!(all.len() > 150, "{} commands", all.len());
    for c in
        [MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, MavCmd::MAV_CMD_DO_REPOSITION, MavCmd::MAV_CMD_MISSION_START]
    {
        assert!(all.contains(&c));
    }
}
