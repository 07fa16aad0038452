//! The mission protocol (mavlink.io "Mission Protocol"): upload with MISSION_COUNT →
//! MISSION_REQUEST_INT / MISSION_ITEM_INT → MISSION_ACK, download with MISSION_REQUEST_LIST →
//! MISSION_COUNT → MISSION_REQUEST_INT → MISSION_ITEM_INT, MISSION_CLEAR_ALL and
//! MISSION_SET_CURRENT; missions, geofences and rally points kept apart by `mission_type`.
//!
//! ArduPilot convention (we announce ArduPilot): item 0 of a flight mission is the home
//! position, stored and sent back but not flown. An upload replaces the stored plan only once
//! every item has arrived and passed the checks the commander makes on it
//! (`Mission::check_fields`): one that fails, times out or is cancelled changes nothing, and
//! every refusal is the MISSION_ACK's error, never ACCEPTED. A mission uploaded while AUTO flies
//! the old one is flown from the same item index (the commander's `MissionRunner::replace`), as
//! ArduCopter does; clearing it then is refused with MAV_MISSION_ERROR, as ArduPilot refuses to
//! clear a running mission.
//! A fence upload is checked whole (`fence`) and sent to the commander, which enforces it; clearing
//! it sends an empty one.
//! Each item request is retried [`RETRIES`] times, [`ITEM_TIMEOUT`] apart, before the upload is
//! cancelled.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::geo::deg_e7;
use kestrel_proto::messages::{Command, FencePlan, MAX_MISSION_ITEMS, Mission, RallyPoints};
use mavlink::dialects::ardupilotmega::{
    MISSION_ACK_DATA, MISSION_COUNT_DATA, MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA,
    MavMessage, MavMissionResult, MavMissionType, MavSeverity,
};

use super::events::statustext;
use super::{Outputs, Sender, Service, ToGraph};

mod fence;
mod items;
pub use fence::{FenceRefused, to_fence};
mod rally;
mod store;
pub use items::{ItemRefused, to_mission};
use items::{int_frame, is_global, refusal_text, to_float};
pub use rally::to_rally;
pub use store::{PLAN_FILES, PlanFileError, PlanStore};

/// Most items a plan of any type may hold (home included); larger uploads are refused with
/// NO_SPACE. The one limit for missions however they arrive (`MAX_MISSION_ITEMS`).
pub const MAX_ITEMS: u16 = MAX_MISSION_ITEMS as u16;
/// Time to wait for a requested item before asking again.
pub const ITEM_TIMEOUT: Duration = Duration::from_millis(1500);
/// Requests repeated before an upload is given up.
pub const RETRIES: u32 = 5;
/// Cruise speed of a mission that does not set one (m/s).
pub const DEFAULT_CRUISE_M_S: f64 = 5.0;
/// Why clearing the mission (MISSION_CLEAR_ALL, or an upload of home alone or of nothing) is
/// refused while AUTO flies it.
const CLEAR_REFUSED: &str = "Mission clear refused while flying AUTO";

#[derive(Debug)]
struct Upload {
    partner: Sender,
    mission_type: MavMissionType,
    count: u16,
    items: Vec<MISSION_ITEM_INT_DATA>,
    deadline: Time,
    retries: u32,
}

/// Plans stored on the vehicle and the upload in progress.
#[derive(Debug, Default)]
pub struct MissionService {
    mission: Vec<MISSION_ITEM_INT_DATA>,
    fence: Vec<MISSION_ITEM_INT_DATA>,
    rally: Vec<MISSION_ITEM_INT_DATA>,
    upload: Option<Upload>,
    /// The commander flies the mission (armed, in AUTO), as its last status said: clearing the
    /// mission is refused then.
    flying: bool,
    /// Items or acks that did not fit the transfer in progress.
    pub ignored: u64,
    /// Where accepted plans are kept across restarts (`store`); `None`: not kept.
    store: Option<PlanStore>,
}

impl MissionService {
    /// Empty plans.
    pub fn new() -> MissionService {
        MissionService {
            mission: Vec::new(),
            fence: Vec::new(),
            rally: Vec::new(),
            upload: None,
            flying: false,
            ignored: 0,
            store: None,
        }
    }

    /// Whether the commander flies the mission now (armed in AUTO), from its status.
    pub fn set_flying(&mut self, flying: bool) {
        self.flying = flying;
    }

    /// Items of the stored flight mission (home included).
    pub fn mission_len(&self) -> usize {
        self.mission.len()
    }

    fn plan(&mut self, t: MavMissionType) -> Option<&mut Vec<MISSION_ITEM_INT_DATA>> {
        match t {
            MavMissionType::MAV_MISSION_TYPE_MISSION => Some(&mut self.mission),
            MavMissionType::MAV_MISSION_TYPE_FENCE => Some(&mut self.fence),
            MavMissionType::MAV_MISSION_TYPE_RALLY => Some(&mut self.rally),
            _ => None,
        }
    }

    fn ack(to: Sender, mission_type: MavMissionType, result: MavMissionResult) -> MavMessage {
        MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: to.target_system(),
            target_component: to.component_id,
            mavtype: result,
            mission_type,
            opaque_id: 0,
        })
    }

    fn request(&self, up: &Upload) -> MavMessage {
        MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq: u16::try_from(up.items.len()).unwrap_or(u16::MAX),
            target_system: up.partner.target_system(),
            target_component: up.partner.component_id,
            mission_type: up.mission_type,
        })
    }

    /// The commander's index of stored item `seq`, `None` when there is no such flown item.
    /// Item 0 is home, so, as ArduPilot does, making it current restarts at the first flown item.
    pub fn commander_index(&self, seq: u16) -> Option<u32> {
        (self.mission.len() > 1 && usize::from(seq) < self.mission.len())
            .then(|| u32::from(seq.saturating_sub(1)))
    }

    /// MISSION_SET_CURRENT: the commander is told (its next status carries the new item, and
    /// MISSION_CURRENT with it); an item we do not have is refused with a STATUSTEXT, the
    /// message having no acknowledgement of its own (mavlink.io mission protocol).
    pub fn set_current(&self, seq: u16) -> Outputs {
        match self.commander_index(seq) {
            Some(index) => Outputs {
                mav: Vec::new(),
                graph: vec![ToGraph::Command(Command::SetMissionCurrent { index })],
            },
            None => Outputs::send(statustext(
                MavSeverity::MAV_SEVERITY_ERROR,
                &format!("Mission item {seq} refused: {} items stored", self.mission.len()),
            )),
        }
    }

    /// MISSION_COUNT: starts an upload (or clears the plan when `count` is 0).
    pub fn on_count(&mut self, from: Sender, m: &MISSION_COUNT_DATA, now: Time) -> Outputs {
        let t = m.mission_type;
        if self.upload.as_ref().is_some_and(|u| u.partner != from) {
            return Outputs::send(Self::ack(from, t, MavMissionResult::MAV_MISSION_DENIED));
        }
        if self.plan(t).is_none() {
            return Outputs::send(Self::ack(from, t, MavMissionResult::MAV_MISSION_UNSUPPORTED));
        }
        if m.count > MAX_ITEMS {
            self.upload = None;
            return Outputs::send(Self::ack(from, t, MavMissionResult::MAV_MISSION_NO_SPACE));
        }
        if m.count == 0 {
            self.upload = None;
            return self.clear(from, t, now);
        }
        let up = Upload {
            partner: from,
            mission_type: t,
            count: m.count,
            items: Vec::with_capacity(usize::from(m.count)),
            deadline: now + ITEM_TIMEOUT,
            retries: 0,
        };
        let out = Outputs::send(self.request(&up));
        self.upload = Some(up);
        out
    }

    /// MISSION_ITEM (legacy float form): converted and handled as MISSION_ITEM_INT.
    pub fn on_item_float(&mut self, from: Sender, m: &MISSION_ITEM_DATA, now: Time) -> Outputs {
        let global = is_global(m.frame);
        let scale = |v: f32| if global { deg_e7(f64::from(v)) } else { v as i32 };
        let item = MISSION_ITEM_INT_DATA {
            param1: m.param1,
            param2: m.param2,
            param3: m.param3,
            param4: m.param4,
            x: scale(m.x),
            y: scale(m.y),
            z: m.z,
            seq: m.seq,
            command: m.command,
            target_system: m.target_system,
            target_component: m.target_component,
            frame: int_frame(m.frame),
            current: m.current,
            autocontinue: m.autocontinue,
            mission_type: m.mission_type,
        };
        self.on_item(from, &item, now)
    }

    /// MISSION_ITEM_INT during an upload.
    pub fn on_item(&mut self, from: Sender, m: &MISSION_ITEM_INT_DATA, now: Time) -> Outputs {
        let Some(up) = self.upload.as_mut().filter(|u| u.partner == from && u.mission_type == m.mission_type)
        else {
            self.ignored += 1;
            return Outputs::none();
        };
        if usize::from(m.seq) != up.items.len() {
            self.ignored += 1;
            let up = self.upload.as_ref().map(|u| self.request(u));
            return Outputs { mav: up.into_iter().collect(), graph: Vec::new() };
        }
        up.items.push(m.clone());
        up.deadline = now + ITEM_TIMEOUT;
        up.retries = 0;
        if up.items.len() < usize::from(up.count) {
            let req = self.upload.as_ref().map(|u| self.request(u));
            return Outputs { mav: req.into_iter().collect(), graph: Vec::new() };
        }
        let Some(up) = self.upload.take() else { return Outputs::none() };
        let t = up.mission_type;
        match self.accept(t, up.items, now) {
            Ok(graph) => {
                Outputs { mav: vec![Self::ack(from, t, MavMissionResult::MAV_MISSION_ACCEPTED)], graph }
            }
            Err((text, result)) => Outputs {
                mav: vec![statustext(MavSeverity::MAV_SEVERITY_ERROR, &text), Self::ack(from, t, result)],
                graph: Vec::new(),
            },
        }
    }

    /// A complete plan of type `t`, uploaded or restored: checked as the commander checks it,
    /// then stored (and kept on disk) with what the graph must be told; or why not, in words
    /// naming the item and as the MISSION_ACK's result, the stored plan unchanged.
    fn accept(
        &mut self,
        t: MavMissionType,
        items: Vec<MISSION_ITEM_INT_DATA>,
        now: Time,
    ) -> Result<Vec<ToGraph>, (String, MavMissionResult)> {
        let mut graph = Vec::new();
        // The fence goes to the commander, checked whole first (`fence`).
        if t == MavMissionType::MAV_MISSION_TYPE_FENCE {
            match to_fence(&items, now) {
                Ok(plan) => graph.push(ToGraph::Fence(plan)),
                Err(FenceRefused { seq, result, reason }) => {
                    return Err((format!("Fence item {seq}: {reason}"), result));
                }
            }
        }
        if t == MavMissionType::MAV_MISSION_TYPE_MISSION {
            match to_mission(&items, now) {
                // Home alone clears the mission (QGroundControl's "remove all" on ArduPilot).
                Ok(mission) if mission.items.is_empty() && self.flying => {
                    return Err((CLEAR_REFUSED.into(), MavMissionResult::MAV_MISSION_ERROR));
                }
                Ok(mission) if mission.items.is_empty() => graph.push(ToGraph::Mission(mission)),
                // The commander's own check, made here so that what is ACKed is never refused.
                Ok(mission) => match mission.check_fields() {
                    Ok(()) => graph.push(ToGraph::Mission(mission)),
                    Err(text) => return Err((text, MavMissionResult::MAV_MISSION_ERROR)),
                },
                // MISSION_ACK carries only the reason; the item it is about goes in words.
                Err(ItemRefused { seq, result }) => {
                    return Err((format!("Mission item {seq}: {}", refusal_text(result)), result));
                }
            }
        }
        if t == MavMissionType::MAV_MISSION_TYPE_RALLY {
            match to_rally(&items, now) {
                Ok(rally) => graph.push(ToGraph::Rally(rally)),
                Err(ItemRefused { seq, result }) => {
                    return Err((format!("Rally item {seq}: {}", refusal_text(result)), result));
                }
            }
        }
        if let Some(store) = &self.store {
            store.save(t, &items);
        }
        if let Some(plan) = self.plan(t) {
            *plan = items;
        }
        Ok(graph)
    }

    /// Keeps the plans in `store` from now on, starting from the ones it holds: each is checked
    /// as an upload is; what the graph must be told, and for each plan that could not be read
    /// or is refused, why (naming the file and line or the item). Such a plan is not restored
    /// (the vehicle starts without it rather than with part of it), and its file is left as it
    /// is until the next upload of that type replaces it.
    pub fn keep_in(&mut self, store: PlanStore, now: Time) -> (Vec<ToGraph>, Vec<String>) {
        let (mut graph, mut errors) = (Vec::new(), Vec::new());
        for (t, _) in PLAN_FILES {
            let file = store.file(t).map(|f| f.display().to_string()).unwrap_or_default();
            match store.load(t) {
                Ok(None) => {}
                Ok(Some(items)) if items.is_empty() => {}
                Ok(Some(items)) => match self.accept(t, items, now) {
                    Ok(out) => graph.extend(out),
                    Err((text, _)) => errors.push(format!("{file}: {text}")),
                },
                Err(e) => errors.push(e.to_string()),
            }
        }
        self.store = Some(store);
        (graph, errors)
    }

    /// Writes the plans still pending to disk (at shutdown).
    pub fn finish_store(&self) {
        if let Some(store) = &self.store {
            store.finish();
        }
    }

    /// MISSION_ACK from the ground station: ends a download, or cancels its upload.
    pub fn on_ack(&mut self, from: Sender) {
        if self.upload.as_ref().is_some_and(|u| u.partner == from) {
            self.upload = None;
        }
    }

    /// MISSION_REQUEST_LIST.
    pub fn on_request_list(&mut self, from: Sender, t: MavMissionType) -> Outputs {
        let Some(count) = self.plan(t).map(|p| p.len()) else {
            return Outputs::send(Self::ack(from, t, MavMissionResult::MAV_MISSION_UNSUPPORTED));
        };
        Outputs::send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: u16::try_from(count).unwrap_or(u16::MAX),
            target_system: from.target_system(),
            target_component: from.component_id,
            mission_type: t,
            opaque_id: 0,
        }))
    }

    /// MISSION_REQUEST_INT (or the legacy MISSION_REQUEST when `legacy`).
    pub fn on_request(&mut self, from: Sender, seq: u16, t: MavMissionType, legacy: bool) -> Outputs {
        let Some(item) = self.plan(t).and_then(|p| p.get(usize::from(seq))).cloned() else {
            return Outputs::send(Self::ack(from, t, MavMissionResult::MAV_MISSION_INVALID_SEQUENCE));
        };
        // Every field as uploaded, `current` too: a ground station (MAVSDK, QGroundControl)
        // checks that what it downloads is what it sent; which item is being flown, MISSION_CURRENT says.
        let item = MISSION_ITEM_INT_DATA {
            target_system: from.target_system(),
            target_component: from.component_id,
            ..item
        };
        if legacy {
            return Outputs::send(MavMessage::MISSION_ITEM(to_float(&item)));
        }
        Outputs::send(MavMessage::MISSION_ITEM_INT(item))
    }

    /// MISSION_CLEAR_ALL.
    pub fn clear(&mut self, from: Sender, t: MavMissionType, now: Time) -> Outputs {
        if t == MavMissionType::MAV_MISSION_TYPE_MISSION && self.flying {
            return Outputs {
                mav: vec![
                    statustext(MavSeverity::MAV_SEVERITY_ERROR, CLEAR_REFUSED),
                    Self::ack(from, t, MavMissionResult::MAV_MISSION_ERROR),
                ],
                graph: Vec::new(),
            };
        }
        let Some(plan) = self.plan(t) else {
            return Outputs::send(Self::ack(from, t, MavMissionResult::MAV_MISSION_UNSUPPORTED));
        };
        plan.clear();
        if let Some(store) = &self.store {
            store.save(t, &[]);
        }
        let mut out = Outputs::send(Self::ack(from, t, MavMissionResult::MAV_MISSION_ACCEPTED));
        if t == MavMissionType::MAV_MISSION_TYPE_MISSION {
            out.graph.push(ToGraph::Mission(Mission {
                time: now,
                items: Vec::new(),
                cruise_speed_m_s: DEFAULT_CRUISE_M_S,
            }));
        }
        if t == MavMissionType::MAV_MISSION_TYPE_FENCE {
            out.graph.push(ToGraph::Fence(FencePlan { time: now, zones: Vec::new() }));
        }
        if t == MavMissionType::MAV_MISSION_TYPE_RALLY {
            out.graph.push(ToGraph::Rally(RallyPoints { time: now, points: Vec::new() }));
        }
        out
    }

    /// Repeats an unanswered request, or cancels the upload after [`RETRIES`].
    fn tick(&mut self, now: Time) -> Outputs {
        let Some(up) = self.upload.as_mut().filter(|u| now >= u.deadline) else {
            return Outputs::none();
        };
        if up.retries >= RETRIES {
            let (partner, t) = (up.partner, up.mission_type);
            self.upload = None;
            return Outputs::send(Self::ack(partner, t, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED));
        }
        up.retries += 1;
        up.deadline = now + ITEM_TIMEOUT;
        let req = self.upload.as_ref().map(|u| self.request(u));
        Outputs { mav: req.into_iter().collect(), graph: Vec::new() }
    }
}

/// The mission protocol: uploads (COUNT, ITEM_INT or legacy ITEM, ACK), downloads
/// (REQUEST_LIST, REQUEST_INT or legacy REQUEST, ACK) and CLEAR_ALL, with retries on ticks.
/// MISSION_SET_CURRENT needs the commander's status too, and is `Vehicle`'s.
impl Service for MissionService {
    fn on_message(&mut self, from: Sender, msg: &MavMessage, now: Time) -> Option<Outputs> {
        Some(match msg {
            MavMessage::MISSION_COUNT(m) => self.on_count(from, m, now),
            MavMessage::MISSION_ITEM_INT(m) => self.on_item(from, m, now),
            MavMessage::MISSION_ITEM(m) => self.on_item_float(from, m, now),
            MavMessage::MISSION_REQUEST_LIST(m) => self.on_request_list(from, m.mission_type),
            MavMessage::MISSION_REQUEST_INT(m) => self.on_request(from, m.seq, m.mission_type, false),
            MavMessage::MISSION_REQUEST(m) => self.on_request(from, m.seq, m.mission_type, true),
            MavMessage::MISSION_CLEAR_ALL(m) => self.clear(from, m.mission_type, now),
            MavMessage::MISSION_ACK(_) => {
                self.on_ack(from);
                Outputs::none()
            }
            _ => return None,
        })
    }

    fn on_tick(&mut self, now: Time) -> Outputs {
        self.tick(now)
    }
}

#[cfg(test)]
mod tests;
