//! Sensor calibration over MAVLink as ArduCopter speaks it, between the ground station
//! and the calibration actor: MAV_CMD_PREFLIGHT_CALIBRATION (gyro param1 = 1, accelerometer
//! param5 = 1, level param5 = 2, ESC range param7 = 1 as the MAVLink spec names it, every
//! parameter 0 cancels the running one as in ArduPilot), MAV_CMD_DO_START_MAG_CAL / DO_ACCEPT_MAG_CAL /
//! DO_CANCEL_MAG_CAL, and COMMAND_LONG(MAV_CMD_ACCELCAL_VEHICLE_POS) both ways — the vehicle
//! asks for a position, the ground station answers when the vehicle stands there (ArduPilot's
//! `AP_AccelCal`, MAVProxy's `accelcal`).
//!
//! Every parameter is checked exactly here: a value that is not one the command defines (NaN,
//! ±inf, 0.5, a calibration we do not run) is refused at once with a STATUSTEXT saying why.
//! What is left goes to the calibration actor, whose answer becomes the one COMMAND_ACK
//! (ACCEPTED when the calibration started; progress and results follow as STATUSTEXT,
//! MAG_CAL_PROGRESS and MAG_CAL_REPORT, as ArduPilot acknowledges a started accelerometer or
//! compass calibration).
//!
//! Ground stations confirm a position two ways. QGroundControl and MAVProxy (`accelcal`, then
//! Enter) answer the "Place vehicle … and press any key." STATUSTEXT with a COMMAND_ACK, which
//! ArduPilot's `AP_AccelCal::handleMessage` takes as "placed" for the position it asked for;
//! newer scripts send COMMAND_LONG(ACCELCAL_VEHICLE_POS), after which ArduPilot stops
//! listening for those acknowledgements (`gcs_vehicle_position` clears `_use_gcs_snoop`).
//! [`AccelcalSnoop`] does the same.

use kestrel_proto::messages::{
    CalibrationEvent, CalibrationRequest, CalibrationStep, CalibrationUpdate, MagCalState, Severity,
};
use mavlink::dialects::ardupilotmega::{
    COMMAND_LONG_DATA, MAG_CAL_PROGRESS_DATA, MAG_CAL_REPORT_DATA, MagCalStatus, MavCmd, MavMessage,
    MavResult, MavSeverity, STATUSTEXT_DATA,
};

use super::command::{CommandRequest, switch, whole};

/// Whether `command` is one of the calibration commands.
pub fn is_calibration(command: MavCmd) -> bool {
    matches!(
        command,
        MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION
            | MavCmd::MAV_CMD_DO_START_MAG_CAL
            | MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL
            | MavCmd::MAV_CMD_DO_CANCEL_MAG_CAL
            | MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS
    )
}

/// The calibration request `r` carries, or the COMMAND_ACK result and why not.
pub fn request(r: &CommandRequest) -> Result<CalibrationRequest, (MavResult, String)> {
    let p = r.params;
    let denied = |what: String| Err((MavResult::MAV_RESULT_DENIED, what));
    if let Some(i) = p.iter().position(|v| !v.is_finite()) {
        return denied(format!("Calibration refused: param{} is {}", i + 1, p[i]));
    }
    let start = |step| Ok(CalibrationRequest::Start { step, autosave: false, delay_s: 0.0 });
    match r.command {
        MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION => {
            // param2 compass (ArduPilot: use DO_START_MAG_CAL), param3 baro, param4 radio,
            // param6 compass-motor: none of them is run this way here.
            for i in [1, 2, 3, 5] {
                if p[i] != 0.0 {
                    return Err((
                        MavResult::MAV_RESULT_UNSUPPORTED,
                        format!("Calibration refused: param{} = {} not supported", i + 1, p[i]),
                    ));
                }
            }
            if p[6] != 0.0 && p[6] != 1.0 {
                return Err((
                    MavResult::MAV_RESULT_UNSUPPORTED,
                    format!("Calibration refused: param7 = {} not supported (1: ESC range)", p[6]),
                ));
            }
            match (p[0], p[4], p[6]) {
                (1.0, 0.0, 0.0) => start(CalibrationStep::Gyro),
                (0.0, 1.0, 0.0) => start(CalibrationStep::Accel),
                (0.0, 2.0, 0.0) => start(CalibrationStep::Level),
                (0.0, 0.0, 1.0) => start(CalibrationStep::Esc),
                (0.0, 0.0, 0.0) => Ok(CalibrationRequest::Cancel),
                (g, a, _) if (g == 0.0 || g == 1.0) && (a == 0.0 || a == 1.0 || a == 2.0) => {
                    denied("Calibration refused: one calibration at a time".to_owned())
                }
                (g, a, _) => Err((
                    MavResult::MAV_RESULT_UNSUPPORTED,
                    format!("Calibration refused: param1 = {g}, param5 = {a} not supported"),
                )),
            }
        }
        MavCmd::MAV_CMD_DO_START_MAG_CAL => {
            // param1 the compass bitmask (0 all; we have one), param2 retry, param3 autosave,
            // param4 delay (s), param5 autoreboot.
            let mask = whole(p[0], u8::MAX.into());
            if !matches!(mask, Some(0 | 1)) {
                return denied(format!("Compass calibration refused: compass mask {}", p[0]));
            }
            let (Some(_retry), Some(autosave)) = (switch(p[1]), switch(p[2])) else {
                return denied("Compass calibration refused: retry and autosave are 0 or 1".to_owned());
            };
            if !(0.0..=60.0).contains(&p[3]) {
                return denied(format!("Compass calibration refused: delay {} s", p[3]));
            }
            if switch(p[4]) != Some(false) {
                return Err((
                    MavResult::MAV_RESULT_UNSUPPORTED,
                    "Compass calibration refused: no autoreboot".to_owned(),
                ));
            }
            Ok(CalibrationRequest::Start { step: CalibrationStep::Mag, autosave, delay_s: p[3] })
        }
        MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL | MavCmd::MAV_CMD_DO_CANCEL_MAG_CAL => {
            if !matches!(whole(p[0], u8::MAX.into()), Some(0 | 1)) {
                return denied(format!("Compass calibration: compass mask {}", p[0]));
            }
            Ok(if r.command == MavCmd::MAV_CMD_DO_ACCEPT_MAG_CAL {
                CalibrationRequest::MagAccept
            } else {
                CalibrationRequest::MagCancel
            })
        }
        MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS => match whole(p[0], 6) {
            Some(position @ 1..=6) => Ok(CalibrationRequest::AccelPosition { position }),
            _ => denied(format!("Calibration refused: vehicle position {}", p[0])),
        },
        _ => Err((MavResult::MAV_RESULT_UNSUPPORTED, String::new())),
    }
}

/// Turns a ground station's COMMAND_ACK into "the vehicle stands where asked" during an
/// accelerometer calibration, as ArduPilot snoops for it.
#[derive(Debug, Default)]
pub struct AccelcalSnoop {
    /// The position the vehicle asked for and no one has confirmed yet.
    asked: Option<u32>,
    /// This calibration's ground station answers with COMMAND_LONG(ACCELCAL_VEHICLE_POS).
    answered_by_command: bool,
}

impl AccelcalSnoop {
    /// A calibration update on its way to the ground station.
    pub fn on_update(&mut self, update: &CalibrationUpdate) {
        if let CalibrationUpdate::AccelPosition { position } = update {
            self.asked = (1..=6).contains(position).then_some(*position);
        }
    }

    /// A calibration command from a ground station: a start listens afresh, a position
    /// command means that ground station answers by command.
    pub fn on_command(&mut self, command: MavCmd) {
        match command {
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION => *self = AccelcalSnoop::default(),
            MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS => {
                self.answered_by_command = true;
                self.asked = None;
            }
            _ => {}
        }
    }

    /// A COMMAND_ACK from a ground station: the position asked for, if one waits for it.
    pub fn on_ack(&mut self) -> Option<CalibrationRequest> {
        if self.answered_by_command {
            return None;
        }
        self.asked.take().map(|position| CalibrationRequest::AccelPosition { position })
    }
}

/// The MAVLink messages of a calibration update (not its answer or results, which the vehicle's
/// command and parameter services handle). `text_id` numbers long STATUSTEXTs.
pub fn messages(event: &CalibrationEvent, text_id: &mut u16) -> Vec<MavMessage> {
    match &event.update {
        CalibrationUpdate::Answer { .. } | CalibrationUpdate::Results { .. } => Vec::new(),
        CalibrationUpdate::Text { severity, text } => chunked(severity_of(*severity), text, text_id),
        CalibrationUpdate::AccelPosition { position } => vec![MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: *position as f32,
            command: MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS,
            target_system: 0,
            target_component: 0,
            ..Default::default()
        })],
        CalibrationUpdate::MagProgress { completion_pct, completion_mask, attempt } => {
            vec![MavMessage::MAG_CAL_PROGRESS(MAG_CAL_PROGRESS_DATA {
                compass_id: 0,
                cal_mask: 1,
                cal_status: MagCalStatus::MAG_CAL_RUNNING_STEP_ONE,
                attempt: *attempt,
                completion_pct: *completion_pct,
                completion_mask: *completion_mask,
                ..Default::default()
            })]
        }
        CalibrationUpdate::MagReport(r) => {
            let cal_status = match r.state {
                MagCalState::Success => MagCalStatus::MAG_CAL_SUCCESS,
                MagCalState::Failed => MagCalStatus::MAG_CAL_FAILED,
                MagCalState::Collecting => MagCalStatus::MAG_CAL_RUNNING_STEP_ONE,
                MagCalState::WaitingToStart => MagCalStatus::MAG_CAL_WAITING_TO_START,
            };
            let f = |v: [f64; 3]| v.map(|x| x as f32);
            let ([ofs_x, ofs_y, ofs_z], [diag_x, diag_y, diag_z], [offdiag_x, offdiag_y, offdiag_z]) =
                (f(r.offsets_mgauss), f(r.diagonal), f(r.off_diagonal));
            vec![MavMessage::MAG_CAL_REPORT(MAG_CAL_REPORT_DATA {
                fitness: r.fitness_mgauss as f32,
                ofs_x,
                ofs_y,
                ofs_z,
                diag_x,
                diag_y,
                diag_z,
                offdiag_x,
                offdiag_y,
                offdiag_z,
                compass_id: 0,
                cal_mask: 1,
                cal_status,
                autosaved: u8::from(r.autosaved),
                orientation_confidence: 0.0,
                ..Default::default()
            })]
        }
    }
}

fn severity_of(s: Severity) -> MavSeverity {
    match s {
        Severity::Info => MavSeverity::MAV_SEVERITY_INFO,
        Severity::Warning => MavSeverity::MAV_SEVERITY_WARNING,
        Severity::Critical => MavSeverity::MAV_SEVERITY_CRITICAL,
    }
}

/// `text` as STATUSTEXTs of 50 bytes: one with id 0 when it fits, otherwise chunks sharing a
/// non-zero id with rising `chunk_seq` (MAVLink 2's long STATUSTEXT), cut at characters.
pub fn chunked(severity: MavSeverity, text: &str, text_id: &mut u16) -> Vec<MavMessage> {
    let mut chunks: Vec<[u8; 50]> = Vec::new();
    let mut n = 50;
    for c in text.chars() {
        let len = c.len_utf8();
        if n + len > 50 {
            chunks.push([0; 50]);
            n = 0;
        }
        if let Some(last) = chunks.last_mut() {
            c.encode_utf8(&mut last[n..]);
        }
        n += len;
    }
    let id = if chunks.len() > 1 {
        *text_id = text_id.checked_add(1).unwrap_or(1);
        *text_id
    } else {
        0
    };
    chunks
        .into_iter()
        .enumerate()
        .map(|(i, bytes)| {
            MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                severity,
                text: bytes.into(),
                id,
                chunk_seq: u8::try_from(i).unwrap_or(u8::MAX),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::services::Sender;

    fn req(command: MavCmd, params: [f64; 7]) -> Result<CalibrationRequest, (MavResult, String)> {
        request(&CommandRequest {
            command,
            params,
            frame: None,
            sender: Sender { system_id: 255, component_id: 190 },
        })
    }

    #[test]
    fn each_parameter_is_read_exactly() {
        let pre = MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION;
        let step = |r: Result<CalibrationRequest, _>| match r {
            Ok(CalibrationRequest::Start { step, .. }) => Some(step),
            _ => None,
        };
        assert_eq!(step(req(pre, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])), Some(CalibrationStep::Gyro));
        assert_eq!(step(req(pre, [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0])), Some(CalibrationStep::Accel));
        assert_eq!(step(req(pre, [0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0])), Some(CalibrationStep::Level));
        for bad in [f64::NAN, f64::INFINITY, 0.5, 3.0, 4.0, -1.0] {
            let r = req(pre, [0.0, 0.0, 0.0, 0.0, bad, 0.0, 0.0]);
            let (result, reason) = r.expect_err("refused");
            assert!(result != MavResult::MAV_RESULT_ACCEPTED && !reason.is_empty(), "{bad}: {reason}");
        }
        assert_eq!(req(pre, [0.0; 7]), Ok(CalibrationRequest::Cancel));
        assert_eq!(step(req(pre, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])), Some(CalibrationStep::Esc));
        for bad in [0.5, 2.0, -1.0] {
            let r = req(pre, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, bad]);
            assert_eq!(r.unwrap_err().0, MavResult::MAV_RESULT_UNSUPPORTED, "param7 = {bad}");
        }
        assert_eq!(
            req(pre, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]).unwrap_err().0,
            MavResult::MAV_RESULT_DENIED,
            "gyro and ESC at once"
        );
        assert_eq!(
            req(pre, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]).unwrap_err().0,
            MavResult::MAV_RESULT_DENIED
        );
        assert_eq!(
            req(pre, [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap_err().0,
            MavResult::MAV_RESULT_UNSUPPORTED
        );
        let mag = req(MavCmd::MAV_CMD_DO_START_MAG_CAL, [0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0]);
        assert_eq!(
            mag,
            Ok(CalibrationRequest::Start { step: CalibrationStep::Mag, autosave: true, delay_s: 2.0 })
        );
        assert!(req(MavCmd::MAV_CMD_DO_START_MAG_CAL, [0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0]).is_err());
        assert!(req(MavCmd::MAV_CMD_DO_START_MAG_CAL, [2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]).is_err());
        let pos = |v| req(MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS, [v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(pos(6.0), Ok(CalibrationRequest::AccelPosition { position: 6 }));
        for bad in [0.0, 7.0, 1.5, f64::NAN] {
            assert!(pos(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_ground_stations_ack_confirms_the_position_asked_for_once() {
        let mut snoop = AccelcalSnoop::default();
        snoop.on_command(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION);
        assert_eq!(snoop.on_ack(), None, "nothing asked yet");
        snoop.on_update(&CalibrationUpdate::AccelPosition { position: 1 });
        assert_eq!(snoop.on_ack(), Some(CalibrationRequest::AccelPosition { position: 1 }));
        assert_eq!(snoop.on_ack(), None, "one ACK, one position");
        snoop.on_update(&CalibrationUpdate::AccelPosition { position: 2 });
        assert_eq!(snoop.on_ack(), Some(CalibrationRequest::AccelPosition { position: 2 }));
        snoop.on_update(&CalibrationUpdate::AccelPosition { position: 16_777_215 });
        assert_eq!(snoop.on_ack(), None, "ACCELCAL_VEHICLE_POS_SUCCESS is no position");
    }

    #[test]
    fn a_ground_station_answering_by_command_is_not_snooped() {
        let mut snoop = AccelcalSnoop::default();
        snoop.on_command(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION);
        snoop.on_update(&CalibrationUpdate::AccelPosition { position: 1 });
        snoop.on_command(MavCmd::MAV_CMD_ACCELCAL_VEHICLE_POS);
        snoop.on_update(&CalibrationUpdate::AccelPosition { position: 2 });
        assert_eq!(snoop.on_ack(), None, "its ACKs answer something else");
        snoop.on_command(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION);
        snoop.on_update(&CalibrationUpdate::AccelPosition { position: 1 });
        assert_eq!(
            snoop.on_ack(),
            Some(CalibrationRequest::AccelPosition { position: 1 }),
            "a new start listens again"
        );
    }

    #[test]
    fn long_texts_go_out_in_chunks_that_join_up() {
        let mut id = 0;
        let text =
            "Compass calibration FAILED: the readings spread only 0.0012 G along their flattest direction";
        let msgs = chunked(MavSeverity::MAV_SEVERITY_CRITICAL, text, &mut id);
        assert!(msgs.len() == 2 && id == 1);
        let joined: String = msgs
            .iter()
            .map(|m| match m {
                MavMessage::STATUSTEXT(s) => {
                    String::from_utf8_lossy(&s.text.to_vec()).trim_end_matches('\0').to_owned()
                }
                _ => String::new(),
            })
            .collect();
        assert_eq!(joined, text);
        assert_eq!(chunked(MavSeverity::MAV_SEVERITY_INFO, "short", &mut id).len(), 1);
    }
}
