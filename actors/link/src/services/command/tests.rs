use super::*;

const GCS: Sender = Sender { system_id: 255, component_id: 190 };

fn request(command: MavCmd, params: [f64; 7]) -> CommandRequest {
    CommandRequest { command, params, frame: None, sender: GCS }
}

fn result(m: &MavMessage) -> (MavCmd, MavResult, u8) {
    match m {
        MavMessage::COMMAND_ACK(a) => (a.command, a.result, a.target_system),
        other => panic!("not an ack: {other:?}"),
    }
}

fn answer(id: u32, command: Command, refusal: Option<&str>) -> CommandResult {
    CommandResult { time: Time::ZERO, id, command, refusal: refusal.map(str::to_owned) }
}

const ARM: [f64; 7] = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];

#[test]
fn a_command_is_acknowledged_by_the_commanders_result_for_its_id() {
    let mut s = CommandService::new();
    let out = s.handle(request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, ARM), Time::ZERO).expect("handled");
    assert_eq!(out.graph, vec![ToGraph::Request { id: 1, command: Command::Arm }]);
    assert!(out.mav.is_empty(), "no answer before the commander's");
    assert!(s.on_result(&answer(7, Command::Arm, None)).is_none(), "not an id we wait for");
    let ack = s.on_result(&answer(1, Command::Arm, None)).expect("ack");
    assert_eq!(result(&ack), (MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, MavResult::MAV_RESULT_ACCEPTED, 255));
    assert!(s.on_result(&answer(1, Command::Arm, None)).is_none(), "one ACK per command");
}

#[test]
fn every_retry_of_a_refused_command_gets_its_own_denial_and_silence_times_out() {
    let mut s = CommandService::new();
    // MAVSDK resends after 0.5 s without an ACK; the commander refuses each alike.
    for (n, t) in [(1, 0.0), (2, 0.5), (3, 1.0)] {
        let out = s
            .handle(request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, ARM), Time::from_secs_f64(t))
            .expect("handled");
        assert_eq!(out.graph, vec![ToGraph::Request { id: n, command: Command::Arm }]);
    }
    for id in [1, 2, 3] {
        let ack = s.on_result(&answer(id, Command::Arm, Some("arming refused: no GPS"))).expect("ack");
        assert_eq!(result(&ack).1, MavResult::MAV_RESULT_DENIED);
    }
    s.handle(request(MavCmd::MAV_CMD_NAV_LAND, [0.0; 7]), Time::from_secs_f64(2.0));
    assert!(s.on_tick(Time::from_secs_f64(3.0)).is_empty());
    let acks = s.on_tick(Time::from_secs_f64(3.6));
    assert_eq!(result(&acks[0]), (MavCmd::MAV_CMD_NAV_LAND, MavResult::MAV_RESULT_DENIED, 255));
    assert!(s.on_tick(Time::from_secs_f64(9.0)).is_empty(), "answered once");
}

#[test]
fn force_disarm_modes_and_bad_takeoff() {
    let mut s = CommandService::new();
    let out = s
        .handle(
            request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0, 21196.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            Time::ZERO,
        )
        .unwrap();
    assert_eq!(graph(&out), Some(Command::Disarm { force: true }));
    let out = s
        .handle(request(MavCmd::MAV_CMD_DO_SET_MODE, [1.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0]), Time::ZERO)
        .unwrap();
    assert_eq!(graph(&out), Some(Command::SetMode(FlightMode::Auto)));
    let out = s
        .handle(request(MavCmd::MAV_CMD_DO_SET_MODE, [1.0, 77.0, 0.0, 0.0, 0.0, 0.0, 0.0]), Time::ZERO)
        .unwrap();
    assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_FAILED);
    let out = s
        .handle(request(MavCmd::MAV_CMD_NAV_TAKEOFF, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f64::NAN]), Time::ZERO)
        .unwrap();
    assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED);
    assert!(out.graph.is_empty());
    assert!(s.handle(request(MavCmd::MAV_CMD_DO_PARACHUTE, [0.0; 7]), Time::ZERO).is_none());
}

fn graph(out: &Outputs) -> Option<Command> {
    out.graph.iter().find_map(|g| match g {
        ToGraph::Request { command, .. } => Some(*command),
        _ => None,
    })
}

#[test]
fn arm_disarm_takes_exactly_zero_or_one_and_refuses_the_rest() {
    let mut s = CommandService::new();
    for param1 in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.5, 0.9, 2.0, -1.0, 1e30] {
        for param2 in [0.0, 21196.0] {
            let out = s
                .handle(
                    request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [param1, param2, 0.0, 0.0, 0.0, 0.0, 0.0]),
                    Time::ZERO,
                )
                .expect("handled");
            assert!(out.graph.is_empty(), "param1 {param1} param2 {param2} reached the commander");
            assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "param1 {param1}");
        }
    }
    let disarm = s
        .handle(
            request(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]),
            Time::ZERO,
        )
        .expect("handled");
    assert_eq!(graph(&disarm), Some(Command::Disarm { force: false }), "NaN is not the force code");
}

#[test]
fn mode_and_mission_start_refuse_what_is_not_a_whole_number() {
    let mut s = CommandService::new();
    for params in [
        [f64::NAN, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1.0, 3.5, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1.0, -3.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [257.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1.0, 4_294_967_299.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ] {
        let out = s.handle(request(MavCmd::MAV_CMD_DO_SET_MODE, params), Time::ZERO).expect("handled");
        assert!(out.graph.is_empty(), "{params:?}");
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{params:?}");
    }
    for first in [f64::NAN, f64::INFINITY, 2.0] {
        let p = [first, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let out = s.handle(request(MavCmd::MAV_CMD_MISSION_START, p), Time::ZERO).expect("handled");
        assert!(out.graph.is_empty(), "{first}");
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED);
    }
    for param1 in [f64::NAN, 0.5, f64::NEG_INFINITY] {
        let p = [param1, 0.0, 0.0, 0.0, 6.8, 79.9, 30.0];
        let out = s.handle(request(MavCmd::MAV_CMD_DO_SET_HOME, p), Time::ZERO).expect("handled");
        assert!(out.graph.is_empty(), "{param1}");
        let p = [param1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let out = s.handle(request(MavCmd::MAV_CMD_DO_FENCE_ENABLE, p), Time::ZERO).expect("handled");
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{param1}");
    }
}

#[test]
fn set_home_reads_long_and_int_forms_and_denies_what_is_not_a_position() {
    let mut s = CommandService::new();
    let here =
        s.handle(request(MavCmd::MAV_CMD_DO_SET_HOME, [1.0, 0.0, 0.0, 0.0, 6.8, 79.9, 30.0]), Time::ZERO);
    assert_eq!(graph(&here.expect("handled")), Some(Command::SetHome { point: None }));
    let long =
        s.handle(request(MavCmd::MAV_CMD_DO_SET_HOME, [0.0, 0.0, 0.0, 0.0, 6.8, 79.9, 30.0]), Time::ZERO);
    let Some(Command::SetHome { point: Some(p) }) = graph(&long.expect("handled")) else {
        panic!("no point")
    };
    assert_eq!((p.lat_deg, p.lon_deg, p.alt_m, p.frame), (6.8, 79.9, 30.0, AltitudeFrame::Amsl));
    let int = CommandRequest {
        frame: Some(MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT),
        ..request(MavCmd::MAV_CMD_DO_SET_HOME, [0.0, 0.0, 0.0, 0.0, 67_971_000.0, 799_017_000.0, 5.0])
    };
    let Some(Command::SetHome { point: Some(p) }) = graph(&s.handle(int, Time::ZERO).expect("handled"))
    else {
        panic!("no point")
    };
    assert!((p.lat_deg - 6.7971).abs() < 1e-9 && (p.lon_deg - 79.9017).abs() < 1e-9, "{p:?}");
    assert_eq!(p.frame, AltitudeFrame::RelativeHome);
    for (params, frame) in [
        ([0.0, 0.0, 0.0, 0.0, 95.0, 79.9, 30.0], None),
        ([0.0, 0.0, 0.0, 0.0, 6.8, 79.9, f64::NAN], None),
        ([0.0, 0.0, 0.0, 0.0, 68e6, 799e6, 5.0], Some(MavFrame::MAV_FRAME_LOCAL_NED)),
    ] {
        let bad = CommandRequest { frame, ..request(MavCmd::MAV_CMD_DO_SET_HOME, params) };
        let out = s.handle(bad, Time::ZERO).expect("handled");
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{params:?}");
        assert!(out.graph.is_empty());
    }
}

#[test]
fn fence_enable_switches_and_refuses_the_floor_and_nonsense() {
    let mut s = CommandService::new();
    let off = s.handle(request(MavCmd::MAV_CMD_DO_FENCE_ENABLE, [0.0; 7]), Time::ZERO).expect("handled");
    assert_eq!(graph(&off), Some(Command::SetGeofence { enabled: false }));
    for (param1, want) in [(2.0, MavResult::MAV_RESULT_UNSUPPORTED), (7.0, MavResult::MAV_RESULT_DENIED)] {
        let p = [param1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let out = s.handle(request(MavCmd::MAV_CMD_DO_FENCE_ENABLE, p), Time::ZERO).expect("handled");
        assert_eq!(result(&out.mav[0]).1, want);
        assert!(out.graph.is_empty());
    }
}

#[test]
fn change_speed_and_pause_continue_take_their_parameters_exactly() {
    let mut s = CommandService::new();
    let speed = |s: &mut CommandService, p2: f64| {
        s.handle(request(MavCmd::MAV_CMD_DO_CHANGE_SPEED, [1.0, p2, -1.0, 0.0, 0.0, 0.0, 0.0]), Time::ZERO)
            .expect("handled")
    };
    assert_eq!(graph(&speed(&mut s, 3.5)), Some(Command::ChangeSpeed { speed_m_s: 3.5 }));
    for bad in [-1.0, -2.0, 0.0, f64::NAN, f64::INFINITY] {
        let out = speed(&mut s, bad);
        assert!(out.graph.is_empty(), "{bad}");
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{bad}");
    }
    let pause = |s: &mut CommandService, p1: f64| {
        s.handle(request(MavCmd::MAV_CMD_DO_PAUSE_CONTINUE, [p1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), Time::ZERO)
            .expect("handled")
    };
    assert_eq!(graph(&pause(&mut s, 0.0)), Some(Command::PauseMission));
    assert_eq!(graph(&pause(&mut s, 1.0)), Some(Command::ContinueMission));
    assert_eq!(result(&pause(&mut s, 0.5).mav[0]).1, MavResult::MAV_RESULT_DENIED);
    let yaw = |s: &mut CommandService, p: [f64; 7]| {
        s.handle(request(MavCmd::MAV_CMD_CONDITION_YAW, p), Time::ZERO).expect("handled")
    };
    let absolute = yaw(&mut s, [450.0, 20.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(graph(&absolute), Some(Command::Yaw { heading_deg: Some(90.0), relative_deg: None }));
    let left = yaw(&mut s, [30.0, 20.0, -1.0, 1.0, 0.0, 0.0, 0.0]);
    assert_eq!(graph(&left), Some(Command::Yaw { heading_deg: None, relative_deg: Some(-30.0) }));
    for bad in [[f64::NAN, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], [10.0, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0]] {
        assert_eq!(result(&yaw(&mut s, bad).mav[0]).1, MavResult::MAV_RESULT_DENIED, "{bad:?}");
    }
}

#[test]
fn a_reposition_the_commander_refuses_fails_and_one_out_of_guided_is_denied() {
    let origin = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };
    let goto = CommandRequest {
        command: MavCmd::MAV_CMD_DO_REPOSITION,
        params: [-1.0, 0.0, 0.0, f64::NAN, 67_972_000.0, 799_017_000.0, 10.0],
        frame: Some(MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT),
        sender: GCS,
    };
    let mut s = CommandService::new();
    let out = s.reposition(goto, Some(origin), false, Time::ZERO);
    assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "not in GUIDED, no change-mode flag");
    assert!(out.graph.is_empty());
    let out = s.reposition(goto, Some(origin), true, Time::ZERO);
    let [ToGraph::Request { id, command }] = out.graph[..] else { panic!("not passed on: {:?}", out.graph) };
    let ack = s.on_result(&answer(id, command, Some("guided target refused: outside the geofence polygon")));
    assert_eq!(ack.map(|a| result(&a).1), Some(MavResult::MAV_RESULT_FAILED));
    let out = s.reposition(goto, Some(origin), true, Time::ZERO);
    let [ToGraph::Request { id, command }] = out.graph[..] else { panic!("not passed on") };
    assert_eq!(
        s.on_result(&answer(id, command, None)).map(|a| result(&a).1),
        Some(MavResult::MAV_RESULT_ACCEPTED)
    );
}

#[test]
fn do_orbit_reads_radius_speed_yaw_and_centre_and_denies_nonsense() {
    let mut s = CommandService::new();
    let origin = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };
    let nan = f64::NAN;
    // MAVSDK's `do_orbit` with no centre: here, at the height flown, defaults for NaN.
    let here =
        s.orbit(request(MavCmd::MAV_CMD_DO_ORBIT, [10.0, nan, 0.0, nan, nan, nan, nan]), None, Time::ZERO);
    assert_eq!(
        graph(&here),
        Some(Command::Orbit {
            radius_m: 10.0,
            speed_m_s: None,
            yaw: OrbitYaw::FaceCentre,
            centre_ne_m: None,
            centre_down_m: None
        })
    );
    // A centre 0.0001° north (11.06 m) at 30 m AMSL (10 m up), counter-clockwise at 2 m/s,
    // nose along the track.
    let north = s.orbit(
        request(MavCmd::MAV_CMD_DO_ORBIT, [-5.0, 2.0, 3.0, nan, 6.7972, 79.9017, 30.0]),
        Some(origin),
        Time::ZERO,
    );
    let Some(Command::Orbit { radius_m, speed_m_s, yaw, centre_ne_m: Some([n, e]), centre_down_m: Some(d) }) =
        graph(&north)
    else {
        panic!("no centre: {north:?}")
    };
    assert_eq!((radius_m, speed_m_s, yaw), (-5.0, Some(2.0), OrbitYaw::Tangent));
    assert!((n - 11.06).abs() < 0.05 && e.abs() < 1e-6 && (d + 10.0).abs() < 1e-6, "{n} {e} {d}");
    // COMMAND_INT's INT32_MAX latitude and longitude: here, at the altitude given.
    let int = CommandRequest {
        frame: Some(MavFrame::MAV_FRAME_GLOBAL_INT),
        ..request(
            MavCmd::MAV_CMD_DO_ORBIT,
            [8.0, nan, 1.0, nan, f64::from(i32::MAX), f64::from(i32::MAX), 25.0],
        )
    };
    let Some(Command::Orbit {
        centre_ne_m: None, centre_down_m: Some(d), yaw: OrbitYaw::HoldInitial, ..
    }) = graph(&s.orbit(int, Some(origin), Time::ZERO))
    else {
        panic!("INT32_MAX is no centre")
    };
    assert!((d + 5.0).abs() < 1e-6);
    // A centre without an origin waits for one; a bad yaw behaviour or an infinite radius is DENIED.
    let no_origin =
        s.orbit(request(MavCmd::MAV_CMD_DO_ORBIT, [5.0, nan, 0.0, nan, 6.8, 79.9, 30.0]), None, Time::ZERO);
    assert_eq!(result(&no_origin.mav[0]).1, MavResult::MAV_RESULT_TEMPORARILY_REJECTED);
    for params in [[5.0, nan, 7.0, nan, nan, nan, nan], [f64::INFINITY, nan, 0.0, nan, nan, nan, nan]] {
        let out = s.orbit(request(MavCmd::MAV_CMD_DO_ORBIT, params), Some(origin), Time::ZERO);
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{params:?}");
        assert!(out.graph.is_empty());
    }
}

#[test]
fn reboot_and_motor_test_go_to_the_commander_and_what_we_do_not_do_is_unsupported() {
    let mut s = CommandService::new();
    let reboot = s.handle(
        request(MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        Time::ZERO,
    );
    assert_eq!(graph(&reboot.expect("handled")), Some(Command::Reboot { force: false }));
    let forced = s.handle(
        request(MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, [1.0, 0.0, 0.0, 0.0, 0.0, 20190226.0, 0.0]),
        Time::ZERO,
    );
    assert_eq!(graph(&forced.expect("handled")), Some(Command::Reboot { force: true }));
    for param1 in [0.0, 2.0, 3.0] {
        let out = s
            .handle(
                request(MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, [param1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                Time::ZERO,
            )
            .expect("handled");
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_UNSUPPORTED, "param1 {param1}");
    }
    for (params, command) in [
        (
            [2.0, 0.0, 15.0, 1.5, 0.0, 0.0, 0.0],
            Command::MotorTest {
                first: 2,
                count: 1,
                throttle: MotorTestThrottle::Share(0.15),
                duration_s: 1.5,
            },
        ),
        (
            [1.0, 1.0, 1100.0, 2.0, 4.0, 2.0, 0.0],
            Command::MotorTest {
                first: 1,
                count: 4,
                throttle: MotorTestThrottle::PulseUs(1100.0),
                duration_s: 2.0,
            },
        ),
        (
            [8.0, 0.0, 100.0, 1e6, 1.0, 0.0, 0.0],
            Command::MotorTest {
                first: 8,
                count: 1,
                throttle: MotorTestThrottle::Share(1.0),
                duration_s: 600.0,
            },
        ),
    ] {
        let out = s.handle(request(MavCmd::MAV_CMD_DO_MOTOR_TEST, params), Time::ZERO);
        assert_eq!(graph(&out.expect("handled")), Some(command), "{params:?}");
    }
    for (params, answer) in [
        ([2.0, 2.0, 0.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_UNSUPPORTED),
        ([2.0, 3.0, 0.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_UNSUPPORTED),
        ([2.0, 4.0, 10.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([2.0, 1.0, 799.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([2.0, 1.0, 2201.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([0.0, 0.0, 10.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([9.0, 0.0, 10.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([1.5, 0.0, 10.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([5.0, 0.0, 10.0, 1.0, 5.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([1.0, 0.0, 101.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([1.0, 0.0, -1.0, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([1.0, 0.0, 10.0, 0.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([1.0, 0.0, 10.0, f64::INFINITY, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([1.0, 0.0, f64::NAN, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
        ([1.0, 1.0, f64::NAN, 1.0, 1.0, 0.0, 0.0], MavResult::MAV_RESULT_DENIED),
    ] {
        let out = s.handle(request(MavCmd::MAV_CMD_DO_MOTOR_TEST, params), Time::ZERO).expect("handled");
        assert_eq!(result(&out.mav[0]).1, answer, "{params:?}");
        assert!(out.graph.is_empty());
    }
}

#[test]
fn reposition_flies_its_speed_and_heading() {
    let mut s = CommandService::new();
    let origin = Some(kestrel_proto::geo::Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 });
    let go = |s: &mut CommandService, speed: f64, yaw: f64| {
        let r = request(MavCmd::MAV_CMD_DO_REPOSITION, [speed, 0.0, 0.0, yaw, 6.7972, 79.9017, 30.0]);
        s.reposition(r, origin, true, Time::ZERO)
    };
    let Some(Command::PositionTarget(t)) = graph(&go(&mut s, 3.0, 90.0)) else { panic!("a target") };
    assert_eq!((t.speed_m_s, t.yaw_rad), (Some(3.0), Some(90f64.to_radians())));
    let p = t.position_ned_m.expect("position");
    assert!((p[0] - 11.06).abs() < 0.05 && p[1].abs() < 0.01 && (p[2] + 10.0).abs() < 0.01, "{p:?}");
    assert!(
        matches!(graph(&go(&mut s, -1.0, f64::NAN)), Some(Command::GotoNed { .. })),
        "default speed, heading kept: a plain goto"
    );
    let Some(Command::PositionTarget(t)) = graph(&go(&mut s, f64::NAN, 10.0)) else { panic!("a target") };
    assert_eq!(t.speed_m_s, None, "NaN: the default speed");
    let Some(Command::PositionTarget(t)) = graph(&go(&mut s, 0.0, 10.0)) else { panic!("a target") };
    assert_eq!(t.speed_m_s, None, "0 (MAVSDK's goto_location): the default speed");
    for (speed, yaw) in [(f64::INFINITY, 0.0), (f64::NEG_INFINITY, 0.0), (1.0, f64::INFINITY)] {
        let out = go(&mut s, speed, yaw);
        assert_eq!(result(&out.mav[0]).1, MavResult::MAV_RESULT_DENIED, "{speed} {yaw}");
        assert!(out.graph.is_empty());
    }
}
