use kestrel_proto::messages::{FenceKind, FenceZone, MissionItem};
use mavlink::dialects::ardupilotmega::{MavCmd, MavFrame};

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
    let out =
        upload(&mut s, &[item(0, MavCmd::MAV_CMD_NAV_WAYPOINT), item(1, MavCmd::MAV_CMD_NAV_WAYPOINT), nan]);
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
    assert_eq!(ack_result(&s.on_count(OTHER, &count(3), t(0.0))), Some(MavMissionResult::MAV_MISSION_DENIED));
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
        requests +=
            out.mav.iter().filter(|m| matches!(m, MavMessage::MISSION_REQUEST_INT(r) if r.seq == 1)).count();
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

const FENCE: MavMissionType = MavMissionType::MAV_MISSION_TYPE_FENCE;

fn fence_item(seq: u16, command: MavCmd, param1: f32, north_m: i32, east_m: i32) -> MISSION_ITEM_INT_DATA {
    // About 1.1 cm a unit of 1e-7 degree: 90 units a metre, near enough for these tests.
    MISSION_ITEM_INT_DATA {
        param1,
        x: 67_971_000 + north_m * 90,
        y: 799_017_000 + east_m * 90,
        z: 0.0,
        mission_type: FENCE,
        ..item(seq, command)
    }
}

fn upload_fence(s: &mut MissionService, items: &[MISSION_ITEM_INT_DATA]) -> Outputs {
    let n = u16::try_from(items.len()).expect("small");
    let mut out = s.on_count(GCS, &MISSION_COUNT_DATA { mission_type: FENCE, ..count(n) }, t(0.0));
    for it in items {
        assert_eq!(requested(&out), Some(it.seq));
        out = s.on_item(GCS, it, t(0.1));
    }
    out
}

/// An inclusion square of 4 vertices, then the items `rest` numbered on from 4.
fn square_then(rest: &[(MavCmd, f32)]) -> Vec<MISSION_ITEM_INT_DATA> {
    let inc = MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION;
    let mut items: Vec<_> = [(-100, -100), (100, -100), (100, 100), (-100, 100)]
        .iter()
        .enumerate()
        .map(|(i, &(n, e))| fence_item(i as u16, inc, 4.0, n, e))
        .collect();
    for (i, &(cmd, p1)) in rest.iter().enumerate() {
        items.push(fence_item(4 + i as u16, cmd, p1, 20, 20));
    }
    items
}

fn statustext_of(out: &Outputs) -> String {
    out.mav
        .iter()
        .find_map(|m| match m {
            MavMessage::STATUSTEXT(t) => {
                Some(t.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned())
            }
            _ => None,
        })
        .unwrap_or_default()
}

#[test]
fn fence_upload_reaches_the_commander_apart_from_the_mission_and_clear_sends_an_empty_fence() {
    let mut s = MissionService::new();
    let items = square_then(&[
        (MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 15.0),
        (MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT, 0.0),
    ]);
    let out = upload_fence(&mut s, &items);
    assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
    let [ToGraph::Fence(plan)] = &out.graph[..] else { panic!("no fence published: {:?}", out.graph) };
    assert_eq!(plan.zones.len(), 2, "the return point is no zone");
    let FenceZone::Polygon { kind, vertices_deg } = &plan.zones[0] else { panic!("polygon first") };
    assert_eq!((*kind, vertices_deg.len()), (FenceKind::Inclusion, 4));
    assert!((vertices_deg[0][0] - (6.7971 - 100.0 * 90e-7)).abs() < 1e-9, "{:?}", vertices_deg[0]);
    assert!(
        matches!(plan.zones[1], FenceZone::Circle { kind: FenceKind::Exclusion, radius_m, .. } if radius_m == 15.0)
    );
    assert_eq!(s.mission_len(), 0, "the mission is untouched");
    // Downloaded as uploaded.
    let out = s.on_request_list(GCS, FENCE);
    assert!(matches!(out.mav[0], MavMessage::MISSION_COUNT(MISSION_COUNT_DATA { count: 6, .. })));
    let out = s.clear(GCS, FENCE, t(1.0));
    assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
    assert!(matches!(&out.graph[..], [ToGraph::Fence(p)] if p.zones.is_empty()));
    let out = s.clear(GCS, MISSION, t(1.0));
    assert!(matches!(&out.graph[..], [ToGraph::Mission(m)] if m.items.is_empty()));
}

#[test]
fn fence_uploads_ardupilot_refuses_are_refused_with_the_item_and_the_old_fence_kept() {
    let inc = MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION;
    let exc = MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION;
    let circle = MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION;
    let ret = MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT;
    let error = MavMissionResult::MAV_MISSION_ERROR;
    let two = |p1: f32| (0..2).map(|i| fence_item(i, inc, p1, i as i32 * 10, 0)).collect::<Vec<_>>();
    let mut mixed = square_then(&[]);
    mixed[2].param1 = 5.0;
    let mut kinds = square_then(&[]);
    kinds[1].command = exc;
    let cases: Vec<(&str, Vec<MISSION_ITEM_INT_DATA>, u16, MavMissionResult, &str)> = vec![
        ("two vertices", two(2.0), 0, error, "at least 3"),
        ("count over 255", two(300.0), 0, MavMissionResult::MAV_MISSION_INVALID_PARAM1, "out of range"),
        ("counts differ", mixed, 2, error, "its polygon's is 4"),
        ("kinds differ", kinds, 1, error, "other kind"),
        ("short polygon", square_then(&[]).into_iter().take(3).collect(), 2, error, "incomplete"),
        (
            "circle inside a polygon",
            {
                let mut v = square_then(&[]);
                v[3] = fence_item(3, circle, 10.0, 0, 0);
                v
            },
            3,
            error,
            "incomplete",
        ),
        ("zero radius", square_then(&[(circle, 0.0)]), 4, error, "radius"),
        ("two return points", square_then(&[(ret, 0.0), (ret, 0.0)]), 5, error, "return point"),
        (
            "a waypoint",
            square_then(&[(MavCmd::MAV_CMD_NAV_WAYPOINT, 0.0)]),
            4,
            MavMissionResult::MAV_MISSION_UNSUPPORTED,
            "not supported",
        ),
    ];
    for (name, items, seq, result, words) in cases {
        let mut s = MissionService::new();
        let good = square_then(&[]);
        assert_eq!(ack_result(&upload_fence(&mut s, &good)), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
        let out = upload_fence(&mut s, &items);
        assert_eq!(ack_result(&out), Some(result), "{name}");
        let text = statustext_of(&out);
        assert!(text.starts_with(&format!("Fence item {seq}:")) && text.contains(words), "{name}: {text}");
        assert!(out.graph.is_empty(), "{name}: nothing reaches the commander");
        let kept = s.on_request_list(GCS, FENCE);
        assert!(
            matches!(kept.mav[0], MavMessage::MISSION_COUNT(MISSION_COUNT_DATA { count: 4, .. })),
            "{name}"
        );
    }
    let mut frame = square_then(&[]);
    frame[0].frame = MavFrame::MAV_FRAME_LOCAL_NED;
    let out = upload_fence(&mut MissionService::new(), &frame);
    assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME));
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

#[test]
fn rally_upload_reaches_the_graph_a_bad_item_is_refused_by_number_and_clear_empties_it() {
    const RALLY: MavMissionType = MavMissionType::MAV_MISSION_TYPE_RALLY;
    let rally =
        |seq| MISSION_ITEM_INT_DATA { mission_type: RALLY, ..item(seq, MavCmd::MAV_CMD_NAV_RALLY_POINT) };
    let mut s = MissionService::new();
    let n = |n| MISSION_COUNT_DATA { mission_type: RALLY, ..count(n) };
    let send = |s: &mut MissionService, items: &[MISSION_ITEM_INT_DATA]| {
        let mut out = s.on_count(GCS, &n(u16::try_from(items.len()).expect("small")), t(0.0));
        for it in items {
            out = s.on_item(GCS, it, t(0.1));
        }
        out
    };
    let out = send(&mut s, &[rally(0), rally(1)]);
    assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
    let Some(ToGraph::Rally(r)) = out.graph.first() else { panic!("no rally published: {out:?}") };
    assert_eq!(r.points.len(), 2);
    // A waypoint among rally points: refused with its number, the two points kept.
    let waypoint = MISSION_ITEM_INT_DATA { command: MavCmd::MAV_CMD_NAV_WAYPOINT, ..rally(1) };
    let out = send(&mut s, &[rally(0), waypoint]);
    assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_UNSUPPORTED));
    assert!(out.graph.is_empty());
    let said = out.mav.iter().find_map(|m| match m {
        MavMessage::STATUSTEXT(st) => {
            Some(String::from_utf8_lossy(&st.text.to_vec()).trim_end_matches('\0').to_owned())
        }
        _ => None,
    });
    assert_eq!(said.as_deref(), Some("Rally item 1: command not supported"));
    assert!(matches!(
        s.on_request_list(GCS, RALLY).mav[0],
        MavMessage::MISSION_COUNT(MISSION_COUNT_DATA { count: 2, .. })
    ));
    let out = s.clear(GCS, RALLY, t(1.0));
    assert_eq!(ack_result(&out), Some(MavMissionResult::MAV_MISSION_ACCEPTED));
    assert!(matches!(out.graph.first(), Some(ToGraph::Rally(r)) if r.points.is_empty()));
}
