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
//! Each item request is retried [`RETRIES`] times, [`ITEM_TIMEOUT`] apart, before the upload is
//! cancelled.
#![allow(
    deprecated,
    reason = "legacy MAVLink (MISSION_ITEM, REQUEST_DATA_STREAM, SET_MODE, *_INT frames) is still spoken by ground stations and must be accepted"
)]

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::geo::{deg_e7, deg_from_e7};
use kestrel_proto::messages::{
    AltitudeFrame, Command, MAX_MISSION_ITEMS, Mission, MissionItem, MissionPoint,
};
use mavlink::dialects::ardupilotmega::{
    MISSION_ACK_DATA, MISSION_COUNT_DATA, MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA,
    MavCmd, MavFrame, MavMessage, MavMissionResult, MavMissionType, MavSeverity,
};

use super::events::statustext;
use super::{Outputs, Sender, Service, ToGraph};

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
/// Acceptance radius of a waypoint that gives none (m).
const DEFAULT_ACCEPTANCE_M: f64 = 2.0;

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
        let mut out = Outputs::none();
        if t == MavMissionType::MAV_MISSION_TYPE_MISSION {
            let refuse = |text: &str, result| Outputs {
                mav: vec![statustext(MavSeverity::MAV_SEVERITY_ERROR, text), Self::ack(from, t, result)],
                graph: Vec::new(),
            };
            match to_mission(&up.items, now) {
                // Home alone clears the mission (QGroundControl's "remove all" on ArduPilot).
                Ok(mission) if mission.items.is_empty() && self.flying => {
                    return refuse(CLEAR_REFUSED, MavMissionResult::MAV_MISSION_ERROR);
                }
                Ok(mission) if mission.items.is_empty() => out.graph.push(ToGraph::Mission(mission)),
                // The commander's own check, made here so that what is ACKed is never refused.
                Ok(mission) => match mission.check_fields() {
                    Ok(()) => out.graph.push(ToGraph::Mission(mission)),
                    Err(text) => return refuse(&text, MavMissionResult::MAV_MISSION_ERROR),
                },
                Err(ItemRefused { seq, result }) => {
                    // MISSION_ACK carries only the reason; the item it is about goes in words.
                    return refuse(&format!("Mission item {seq}: {}", refusal_text(result)), result);
                }
            }
        }
        if let Some(plan) = self.plan(t) {
            *plan = up.items;
        }
        out.mav.push(Self::ack(from, t, MavMissionResult::MAV_MISSION_ACCEPTED));
        out
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
        let mut out = Outputs::send(Self::ack(from, t, MavMissionResult::MAV_MISSION_ACCEPTED));
        if t == MavMissionType::MAV_MISSION_TYPE_MISSION {
            out.graph.push(ToGraph::Mission(Mission {
                time: now,
                items: Vec::new(),
                cruise_speed_m_s: DEFAULT_CRUISE_M_S,
            }));
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

fn is_global(f: MavFrame) -> bool {
    matches!(
        f,
        MavFrame::MAV_FRAME_GLOBAL
            | MavFrame::MAV_FRAME_GLOBAL_INT
            | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
            | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
            | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT
            | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT
    )
}

fn int_frame(f: MavFrame) -> MavFrame {
    match f {
        MavFrame::MAV_FRAME_GLOBAL => MavFrame::MAV_FRAME_GLOBAL_INT,
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT => MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT => MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
        other => other,
    }
}

fn to_float(m: &MISSION_ITEM_INT_DATA) -> MISSION_ITEM_DATA {
    let global = is_global(m.frame);
    let unscale = |v: i32| if global { deg_from_e7(f64::from(v)) as f32 } else { v as f32 };
    MISSION_ITEM_DATA {
        param1: m.param1,
        param2: m.param2,
        param3: m.param3,
        param4: m.param4,
        x: unscale(m.x),
        y: unscale(m.y),
        z: m.z,
        seq: m.seq,
        command: m.command,
        target_system: m.target_system,
        target_component: m.target_component,
        frame: m.frame,
        current: m.current,
        autocontinue: m.autocontinue,
        mission_type: m.mission_type,
    }
}

fn point(m: &MISSION_ITEM_INT_DATA) -> Result<MissionPoint, MavMissionResult> {
    let frame = match m.frame {
        MavFrame::MAV_FRAME_GLOBAL | MavFrame::MAV_FRAME_GLOBAL_INT => AltitudeFrame::Amsl,
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => {
            AltitudeFrame::RelativeHome
        }
        _ => return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME),
    };
    let (lat_deg, lon_deg) = (deg_from_e7(f64::from(m.x)), deg_from_e7(f64::from(m.y)));
    if lat_deg.abs() > 90.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X);
    }
    if lon_deg.abs() > 180.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y);
    }
    if !m.z.is_finite() {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM7);
    }
    Ok(MissionPoint { lat_deg, lon_deg, alt_m: f64::from(m.z), frame })
}

/// An uploaded item that cannot be flown: its sequence number and the MISSION_ACK result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ItemRefused {
    pub seq: u16,
    pub result: MavMissionResult,
}

/// What a refused item's MISSION_ACK result means, for the STATUSTEXT beside it (short: a
/// STATUSTEXT holds 50 characters, the prefix "Mission item 65535: " takes 20).
fn refusal_text(result: MavMissionResult) -> &'static str {
    match result {
        MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME => "frame not supported",
        MavMissionResult::MAV_MISSION_UNSUPPORTED => "command not supported",
        MavMissionResult::MAV_MISSION_INVALID_PARAM1 => "param1 out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM2 => "param2 out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM5_X => "latitude out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y => "longitude out of range",
        MavMissionResult::MAV_MISSION_INVALID_PARAM7 => "altitude not a number",
        _ => "invalid",
    }
}

/// The commander's mission from uploaded items (item 0, home, skipped).
pub fn to_mission(items: &[MISSION_ITEM_INT_DATA], now: Time) -> Result<Mission, ItemRefused> {
    let mut out = Vec::with_capacity(items.len().saturating_sub(1));
    for m in items.iter().skip(1) {
        let refused = |result| ItemRefused { seq: m.seq, result };
        let item = match m.command {
            MavCmd::MAV_CMD_NAV_WAYPOINT => {
                let hold_s = f64::from(m.param1);
                let radius = f64::from(m.param2);
                if !(hold_s.is_finite() && hold_s >= 0.0) {
                    return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM1));
                }
                if !(radius.is_finite() && radius >= 0.0) {
                    return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM2));
                }
                let acceptance_radius_m = if radius > 0.0 { radius } else { DEFAULT_ACCEPTANCE_M };
                MissionItem::Waypoint { point: point(m).map_err(refused)?, acceptance_radius_m, hold_s }
            }
            MavCmd::MAV_CMD_NAV_TAKEOFF => MissionItem::Takeoff { point: point(m).map_err(refused)? },
            MavCmd::MAV_CMD_NAV_LAND => MissionItem::Land { point: point(m).map_err(refused)? },
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => MissionItem::ReturnToLaunch,
            MavCmd::MAV_CMD_NAV_LOITER_TIME => {
                let duration_s = f64::from(m.param1);
                if !(duration_s.is_finite() && duration_s >= 0.0) {
                    return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM1));
                }
                MissionItem::LoiterTime { duration_s }
            }
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => {
                let speed_m_s = f64::from(m.param2);
                if !(speed_m_s.is_finite() && speed_m_s > 0.0) {
                    return Err(refused(MavMissionResult::MAV_MISSION_INVALID_PARAM2));
                }
                MissionItem::ChangeSpeed { speed_m_s }
            }
            _ => return Err(refused(MavMissionResult::MAV_MISSION_UNSUPPORTED)),
        };
        out.push(item);
    }
    Ok(Mission { time: now, items: out, cruise_speed_m_s: DEFAULT_CRUISE_M_S })
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
mod tests {
    use super::*;

    const GCS: Sender = Sender { system_id: 255, component_id: 190 };
    const OTHER: Sender = Sender { system_id: 254, component_id: 190 };
    const MISSION: MavMissionType = MavMissionType::MAV_MISSION_TYPE_MISSION;

    fn t(s: f64) -> Time {
        Time::from_secs_f64(s)
    }

    fn item(seq: u16, command: MavCmd) -> MISSION_ITEM_INT_DATA {
        MISSION_ITEM_INT_DATA {
            seq,
            command,
            frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            x: 67_971_000 + i32::from(seq) * 100,
            y: 799_017_000,
            z: 20.0,
            target_system: 1,
            target_component: 1,
            mission_type: MISSION,
            autocontinue: 1,
            ..Default::default()
        }
    }

    fn count(n: u16) -> MISSION_COUNT_DATA {
        MISSION_COUNT_DATA {
            count: n,
            target_system: 1,
            target_component: 1,
            mission_type: MISSION,
            opaque_id: 0,
        }
    }

    fn ack_result(out: &Outputs) -> Option<MavMissionResult> {
        out.mav.iter().find_map(|m| match m {
            MavMessage::MISSION_ACK(a) => Some(a.mavtype),
            _ => None,
        })
    }

    fn requested(out: &Outputs) -> Option<u16> {
        out.mav.iter().find_map(|m| match m {
            MavMessage::MISSION_REQUEST_INT(r) => Some(r.seq),
            _ => None,
        })
    }

    fn upload(s: &mut MissionService, items: &[MISSION_ITEM_INT_DATA]) -> Outputs {
        let n = u16::try_from(items.len()).expect("small");
        let mut out = s.on_count(GCS, &count(n), t(0.0));
        for it in items {
            assert_eq!(requested(&out), Some(it.seq));
            out = s.on_item(GCS, it, t(0.1));
        }
        out
    }

    #[test]
    fn upload_then_download_gives_the_same_items() {
        let mut s = MissionService::new();
        let items = [
            item(0, MavCmd::MAV_CMD_NAV_WAYPOINT),
            item(1, MavCmd::MAV_CMD_NAV_TAKEOFF),
            item(2, MavCmd::MAV_CMD_NAV_WAYPOINT),
            item(3, MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH),
        ];
        let out = upload(&mut s, &items);
        assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
        let Some(ToGraph::Mission(m)) = out.graph.first() else { panic!("no mission published") };
        assert_eq!(m.items.len(), 3, "home (item 0) is not flown");
        assert!(matches!(m.items[0], MissionItem::Takeoff { .. }));

        let out = s.on_request_list(GCS, MISSION);
        assert!(matches!(out.mav[0], MavMessage::MISSION_COUNT(MISSION_COUNT_DATA { count: 4, .. })));
        for want in &items {
            let out = s.on_request(GCS, want.seq, MISSION, false);
            let MavMessage::MISSION_ITEM_INT(got) = &out.mav[0] else { panic!("no item") };
            assert_eq!(
                (got.x, got.y, got.z, got.command, got.seq),
                (want.x, want.y, want.z, want.command, want.seq)
            );
        }
        assert_eq!(
            ack_result(&s.on_request(GCS, 9, MISSION, false)),
            Some(MavMissionResult::MAV_MISSION_INVALID_SEQUENCE)
        );
    }

    #[test]
    fn a_bad_item_keeps_the_previous_plan() {
        let mut s = MissionService::new();
        upload(&mut s, &[item(0, MavCmd::MAV_CMD_NAV_WAYPOINT), item(1, MavCmd::MAV_CMD_NAV_WAYPOINT)]);
        let mut bad = item(1, MavCmd::MAV_CMD_NAV_WAYPOINT);
        bad.frame = MavFrame::MAV_FRAME_BODY_FRD;
        let out = upload(&mut s, &[item(0, MavCmd::MAV_CMD_NAV_WAYPOINT), bad]);
        assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME));
        assert!(out.graph.is_empty());
        let said = out.mav.iter().find_map(|m| match m {
            MavMessage::STATUSTEXT(t) => {
                Some(t.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned())
            }
            _ => None,
        });
        assert_eq!(said.as_deref(), Some("Mission item 1: frame not supported"));
        let mut nan = item(2, MavCmd::MAV_CMD_NAV_WAYPOINT);
        nan.z = f32::NAN;
        let out = upload(
            &mut s,
            &[item(0, MavCmd::MAV_CMD_NAV_WAYPOINT), item(1, MavCmd::MAV_CMD_NAV_WAYPOINT), nan],
        );
        assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_INVALID_PARAM7));
        let out = s.on_request(GCS, 1, MISSION, false);
        let MavMessage::MISSION_ITEM_INT(kept) = &out.mav[0] else { panic!("no item") };
        assert_eq!(kept.frame, MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT);
    }

    #[test]
    fn huge_uploads_busy_partners_and_silence_are_refused() {
        let mut s = MissionService::new();
        assert_eq!(
            ack_result(&s.on_count(GCS, &count(10_000), t(0.0))),
            Some(MavMissionResult::MAV_MISSION_NO_SPACE)
        );
        s.on_count(GCS, &count(3), t(0.0));
        assert_eq!(
            ack_result(&s.on_count(OTHER, &count(3), t(0.0))),
            Some(MavMissionResult::MAV_MISSION_DENIED)
        );
        assert!(s.on_item(OTHER, &item(0, MavCmd::MAV_CMD_NAV_WAYPOINT), t(0.1)).mav.is_empty());
        assert_eq!(requested(&s.on_item(GCS, &item(2, MavCmd::MAV_CMD_NAV_WAYPOINT), t(0.1))), Some(0));
        let mut retries = 0;
        let mut now = 0.0;
        loop {
            now += 1.6;
            let out = s.tick(t(now));
            if let Some(r) = ack_result(&out) {
                assert_eq!(r, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED);
                break;
            }
            assert_eq!(requested(&out), Some(0));
            retries += 1;
        }
        assert_eq!(retries, RETRIES);
    }

    #[test]
    fn a_dropped_item_is_requested_again_after_the_timeout_and_the_upload_completes() {
        let mut s = MissionService::new();
        let items = [0, 1, 2].map(|seq| item(seq, MavCmd::MAV_CMD_NAV_WAYPOINT));
        assert_eq!(requested(&s.on_count(GCS, &count(3), t(0.0))), Some(0));
        assert_eq!(requested(&s.on_item(GCS, &items[0], t(0.1))), Some(1));
        // Item 1 is lost on the way: nothing until the timeout, then the same request again.
        assert!(s.tick(t(1.5)).mav.is_empty(), "re-requested before the timeout");
        assert_eq!(requested(&s.tick(t(1.7))), Some(1));
        assert_eq!(requested(&s.on_item(GCS, &items[1], t(1.8))), Some(2));
        let out = s.on_item(GCS, &items[2], t(1.9));
        assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
        assert_eq!(s.mission_len(), 3);
    }

    #[test]
    fn a_ground_station_that_vanishes_mid_upload_is_given_up_and_the_old_mission_kept() {
        let mut s = MissionService::new();
        let old = [0, 1].map(|seq| item(seq, MavCmd::MAV_CMD_NAV_WAYPOINT));
        upload(&mut s, &old);
        s.on_count(GCS, &count(4), t(10.0));
        s.on_item(GCS, &item(0, MavCmd::MAV_CMD_NAV_TAKEOFF), t(10.1));
        let (mut now, mut requests, mut cancelled) = (10.1, 0, None);
        while now < 30.0 && cancelled.is_none() {
            now += 0.02;
            let out = s.tick(t(now));
            requests += out
                .mav
                .iter()
                .filter(|m| matches!(m, MavMessage::MISSION_REQUEST_INT(r) if r.seq == 1))
                .count();
            cancelled = ack_result(&out).map(|r| (r, now));
            assert!(out.graph.is_empty(), "a cancelled upload must not reach the commander");
        }
        let Some((result, at)) = cancelled else { panic!("the upload was never given up") };
        assert_eq!(result, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED);
        assert_eq!(requests, RETRIES as usize, "each retry re-sends the request once");
        let expected = 10.1 + ITEM_TIMEOUT.as_secs_f64() * f64::from(RETRIES + 1);
        assert!((at - expected).abs() < 0.05, "gave up at {at} s, expected {expected} s");
        // The previous mission is what a download returns, and nothing more is sent.
        assert_eq!(s.mission_len(), 2);
        let out = s.on_request(GCS, 1, MISSION, false);
        let MavMessage::MISSION_ITEM_INT(kept) = &out.mav[0] else { panic!("no item") };
        assert_eq!((kept.x, kept.command), (old[1].x, old[1].command));
        assert!(s.tick(t(60.0)).mav.is_empty());
        // A late item of the dead upload is ignored, not taken as a new one.
        assert!(s.on_item(GCS, &item(1, MavCmd::MAV_CMD_NAV_WAYPOINT), t(61.0)).mav.is_empty());
        assert_eq!(s.mission_len(), 2);
    }

    fn download_x(s: &mut MissionService) -> Vec<i32> {
        let n = match s.on_request_list(GCS, MISSION).mav[..] {
            [MavMessage::MISSION_COUNT(MISSION_COUNT_DATA { count, .. })] => count,
            ref other => panic!("no MISSION_COUNT: {other:?}"),
        };
        (0..n)
            .map(|seq| match &s.on_request(GCS, seq, MISSION, false).mav[..] {
                [MavMessage::MISSION_ITEM_INT(it)] => it.x,
                other => panic!("no item {seq}: {other:?}"),
            })
            .collect()
    }

    fn waypoints(n: u16, x0: i32) -> Vec<MISSION_ITEM_INT_DATA> {
        (0..n)
            .map(|seq| MISSION_ITEM_INT_DATA {
                x: x0 + i32::from(seq),
                ..item(seq, MavCmd::MAV_CMD_NAV_WAYPOINT)
            })
            .collect()
    }

    #[test]
    fn an_upload_while_flying_replaces_the_mission_longer_or_shorter() {
        let mut s = MissionService::new();
        upload(&mut s, &waypoints(3, 1000));
        s.set_flying(true);
        for (n, x0) in [(5, 2000), (2, 3000)] {
            let out = upload(&mut s, &waypoints(n, x0));
            assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
            let [ToGraph::Mission(m)] = &out.graph[..] else { panic!("no mission published: {out:?}") };
            assert_eq!(m.items.len(), usize::from(n) - 1);
            assert_eq!(download_x(&mut s), waypoints(n, x0).iter().map(|i| i.x).collect::<Vec<_>>());
        }
    }

    #[test]
    fn clearing_the_mission_while_flying_is_an_error_that_changes_nothing() {
        let mut s = MissionService::new();
        let flown = waypoints(3, 1000);
        upload(&mut s, &flown);
        s.set_flying(true);
        let home_alone = upload(&mut s, &waypoints(1, 5000));
        let cleared = s.clear(GCS, MISSION, t(1.0));
        let counted_zero = s.on_count(GCS, &count(0), t(1.0));
        for out in [home_alone, cleared, counted_zero] {
            assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ERROR));
            assert!(out.graph.is_empty(), "nothing reaches the commander: {out:?}");
            assert!(out.mav.iter().any(|m| matches!(m, MavMessage::STATUSTEXT(_))), "the reason is said");
            assert_eq!(download_x(&mut s), flown.iter().map(|i| i.x).collect::<Vec<_>>());
        }
        // On the ground the same clear is done.
        s.set_flying(false);
        let out = s.clear(GCS, MISSION, t(2.0));
        assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
        assert_eq!(s.mission_len(), 0);
    }

    #[test]
    fn a_cancelled_upload_while_flying_leaves_the_flown_mission() {
        let mut s = MissionService::new();
        let flown = waypoints(3, 1000);
        upload(&mut s, &flown);
        s.set_flying(true);
        s.on_count(GCS, &count(4), t(1.0));
        for it in &waypoints(2, 7000) {
            assert!(s.on_item(GCS, it, t(1.1)).graph.is_empty(), "nothing published before the last item");
        }
        // The ground station gives up (its MISSION_ACK cancels the transfer); the late items of
        // the dead upload are ignored.
        s.on_ack(GCS);
        let late = s.on_item(GCS, &waypoints(4, 7000)[2], t(1.2));
        assert!(late.mav.is_empty() && late.graph.is_empty());
        assert_eq!(download_x(&mut s), flown.iter().map(|i| i.x).collect::<Vec<_>>());
    }

    #[test]
    fn fence_items_are_kept_apart_and_clear_all_publishes_an_empty_mission() {
        let mut s = MissionService::new();
        let mut c = count(1);
        c.mission_type = MavMissionType::MAV_MISSION_TYPE_FENCE;
        s.on_count(GCS, &c, t(0.0));
        let mut f = item(0, MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION);
        f.mission_type = MavMissionType::MAV_MISSION_TYPE_FENCE;
        let out = s.on_item(GCS, &f, t(0.1));
        assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
        assert!(out.graph.is_empty());
        assert_eq!(s.mission_len(), 0);
        let out = s.clear(GCS, MISSION, t(1.0));
        assert!(matches!(&out.graph[0], ToGraph::Mission(m) if m.items.is_empty()));
    }

    #[test]
    fn set_current_maps_past_home_and_refuses_items_we_do_not_have() {
        let mut s = MissionService::new();
        assert!(matches!(s.set_current(0).mav[..], [MavMessage::STATUSTEXT(_)]), "no mission");
        upload(&mut s, &[0, 1, 2].map(|seq| item(seq, MavCmd::MAV_CMD_NAV_WAYPOINT)));
        let current = |s: &MissionService, seq| match &s.set_current(seq).graph[..] {
            [ToGraph::Command(Command::SetMissionCurrent { index })] => Some(*index),
            _ => None,
        };
        assert_eq!(current(&s, 2), Some(1));
        assert_eq!(current(&s, 1), Some(0));
        assert_eq!(current(&s, 0), Some(0), "home: restart at the first flown item");
        let out = s.set_current(3);
        assert!(out.graph.is_empty());
        let MavMessage::STATUSTEXT(text) = &out.mav[0] else { panic!("no STATUSTEXT") };
        assert_eq!(text.severity, MavSeverity::MAV_SEVERITY_ERROR);
    }

    #[test]
    fn legacy_float_items_are_accepted() {
        let mut s = MissionService::new();
        s.on_count(GCS, &count(2), t(0.0));
        for seq in 0..2 {
            let int = item(seq, MavCmd::MAV_CMD_NAV_WAYPOINT);
            let mut f = to_float(&int);
            f.frame = MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT;
            let out = s.on_item_float(GCS, &f, t(0.1));
            if seq == 1 {
                assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
            }
        }
    }
}
