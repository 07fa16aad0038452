use kestrel_proto::messages::ParamInfo;

use super::*;

fn spec(name: &str, value: f64, min: f64, max: f64, kind: ParamKind) -> ParamSpec {
    ParamSpec { name: name.into(), value, min, max, kind, unit: "m".into() }
}

fn table() -> ParamTable {
    ParamTable::new(vec![
        spec("RTL_ALT_M", 30.0, 5.0, 120.0, ParamKind::Real32),
        spec("FS_ACTION", 1.0, 0.0, 3.0, ParamKind::Int32),
    ])
    .expect("valid table")
}

fn value(m: &MavMessage) -> (String, f32, u16, u16) {
    match m {
        MavMessage::PARAM_VALUE(p) => (
            p.param_id.to_str().unwrap_or_default().trim_end_matches('\0').to_owned(),
            p.param_value,
            p.param_index,
            p.param_count,
        ),
        other => panic!("not a PARAM_VALUE: {other:?}"),
    }
}

fn values(msgs: &[MavMessage]) -> Vec<(String, f32)> {
    msgs.iter()
        .filter(|m| matches!(m, MavMessage::PARAM_VALUE(_)))
        .map(|m| (value(m).0, value(m).1))
        .collect()
}

fn texts(msgs: &[MavMessage]) -> usize {
    msgs.iter().filter(|m| matches!(m, MavMessage::STATUSTEXT(_))).count()
}

fn decl(owner: &str, start: bool, params: &[(&str, f64)]) -> ParamDecl {
    ParamDecl {
        time: Time::ZERO,
        owner: owner.into(),
        start,
        params: params
            .iter()
            .map(|&(name, value)| ParamInfo {
                name: name.into(),
                value,
                min: 0.0,
                max: 100.0,
                unit: "m".into(),
                description: String::new(),
                integer: false,
                disarmed_only: false,
            })
            .collect(),
    }
}

fn param_set(name: &str, value: f64) -> ToGraph {
    ToGraph::Param(ParamSet { time: Time::ZERO, name: name.into(), value, restore: false })
}

fn restored(name: &str, value: f64) -> ToGraph {
    ToGraph::Param(ParamSet { time: Time::ZERO, name: name.into(), value, restore: true })
}

fn text_of(m: &MavMessage) -> Option<String> {
    match m {
        MavMessage::STATUSTEXT(t) => {
            Some(t.text.to_str().unwrap_or_default().trim_end_matches('\0').to_owned())
        }
        _ => None,
    }
}

/// `SERVO1_MAX` (disarmed-only) and `MPC_XY_P` (tunable) of one owner, both in 0..3000.
fn motors(start: bool, servo: f64, gain: f64) -> ParamDecl {
    let mut d = decl("motors", start, &[("SERVO1_MAX", servo), ("MPC_XY_P", gain)]);
    for p in &mut d.params {
        p.max = 3000.0;
    }
    d.params[0].disarmed_only = true;
    d
}

#[test]
fn a_disarmed_only_parameter_is_refused_while_armed_with_the_value_in_force() {
    let mut t = ParamTable::new(Vec::new()).expect("empty table");
    t.declare(&motors(true, 2000.0, 1.0), Time::ZERO);
    t.set_armed(true);
    let out = t.set("SERVO1_MAX", 900.0, Time::ZERO);
    assert!(out.graph.is_empty(), "nothing goes to the owner");
    let texts: Vec<String> = out.mav.iter().filter_map(text_of).collect();
    assert_eq!(texts, ["SERVO1_MAX: cannot change while armed"]);
    assert_eq!(values(&out.mav), [("SERVO1_MAX".to_owned(), 2000.0)]);
    assert_eq!(value(&t.read("SERVO1_MAX", -1).expect("known")).1, 2000.0);
    assert!(!t.take_changed(), "nothing to persist");
    // A gain is tuned in flight as before.
    assert_eq!(t.set("MPC_XY_P", 1.5, Time::ZERO).graph, vec![param_set("MPC_XY_P", 1.5)]);
    // Disarmed, the same set goes to the owner.
    t.set_armed(false);
    assert_eq!(t.set("SERVO1_MAX", 1900.0, Time::ZERO).graph, vec![param_set("SERVO1_MAX", 1900.0)]);
}

#[test]
fn a_restart_while_armed_still_gets_its_stored_values_back() {
    let mut t = ParamTable::new(Vec::new()).expect("empty table");
    t.restore("SERVO1_MAX", 1900.0).expect("held");
    let out = t.declare(&motors(true, 2000.0, 1.0), Time::ZERO).out;
    assert_eq!(out.graph.len(), 1);
    let done = t.declare(&motors(false, 1900.0, 1.0), Time::ZERO);
    assert!(done.out.mav.is_empty() && done.out.graph.is_empty(), "taken");
    // The owner restarts in flight with its configured 2000: the value it flew with is
    // restored (marked so, for an owner that refuses locked sets while armed).
    t.set_armed(true);
    let out = t.declare(&motors(true, 2000.0, 1.0), Time::ZERO).out;
    assert_eq!(out.graph, vec![restored("SERVO1_MAX", 1900.0)]);
}

proptest::proptest! {
    /// Whatever a ground station sends, armed or not, the table never sends a new value of a
    /// disarmed-only parameter to its owner while armed, and so never serves one: its value
    /// holds through every armed stretch. The owner here takes whatever it is sent (the
    /// link's refusal alone holds this).
    #[test]
    fn no_disarmed_only_parameter_changes_while_armed_whatever_the_sets(
        steps in proptest::collection::vec((0u8..4, 0.0f64..3000.0), 1..80)
    ) {
        let mut t = ParamTable::new(Vec::new()).expect("empty table");
        let mut owner = [("SERVO1_MAX", 2000.0), ("MPC_XY_P", 1.0)];
        t.declare(&motors(true, 2000.0, 1.0), Time::ZERO);
        let mut armed = false;
        for (what, v) in steps {
            let before = value(&t.read("SERVO1_MAX", -1).expect("known")).1;
            let out = match what {
                0 => { armed = !armed; t.set_armed(armed); Outputs::none() }
                1 => t.set("SERVO1_MAX", v as f32, Time::ZERO),
                _ => t.set("MPC_XY_P", v as f32, Time::ZERO),
            };
            for g in &out.graph {
                let ToGraph::Param(set) = g else { continue };
                proptest::prop_assert!(!(armed && set.name == "SERVO1_MAX"), "sent armed: {set:?}");
                for p in &mut owner {
                    if p.0 == set.name { p.1 = set.value; }
                }
                t.declare(&motors(false, owner[0].1, owner[1].1), Time::ZERO);
            }
            let after = value(&t.read("SERVO1_MAX", -1).expect("known")).1;
            if armed {
                proptest::prop_assert_eq!(before, after);
            }
        }
    }
}

#[test]
fn list_and_read_by_name_and_index_in_name_order() {
    let t = table();
    let all: Vec<_> = t.list().iter().map(value).collect();
    assert_eq!(all, [("FS_ACTION".into(), 1.0, 0, 2), ("RTL_ALT_M".into(), 30.0, 1, 2)]);
    assert_eq!(value(&t.read("RTL_ALT_M", -1).expect("by name")).2, 1);
    assert_eq!(value(&t.read("", 0).expect("by index")).0, "FS_ACTION");
    assert!(t.read("NOPE", -1).is_none());
    assert!(t.read("", 5).is_none());
}

#[test]
fn set_applies_in_range_and_echoes_the_old_value_otherwise() {
    let mut t = table();
    let out = t.set("RTL_ALT_M", 50.0, Time::ZERO);
    assert_eq!(value(&out.mav[0]).1, 50.0);
    assert_eq!(out.graph, vec![param_set("RTL_ALT_M", 50.0)]);
    let out = t.set("RTL_ALT_M", 500.0, Time::ZERO);
    assert!(matches!(out.mav[0], MavMessage::STATUSTEXT(_)));
    assert_eq!(value(&out.mav[1]).1, 50.0);
    assert!(out.graph.is_empty());
    let out = t.set("RTL_ALT_M", f32::NAN, Time::ZERO);
    assert_eq!(value(&out.mav[1]).1, 50.0);
    let out = t.set("FS_ACTION", 2.4, Time::ZERO);
    assert!(matches!(out.mav[0], MavMessage::STATUSTEXT(_)), "not rounded to 2");
    assert_eq!(value(&out.mav[1]).1, 1.0);
    assert!(out.graph.is_empty());
    let out = t.set("FS_ACTION", 2.0, Time::ZERO);
    assert_eq!(value(&out.mav[0]).1, 2.0);
    let out = t.set("UNKNOWN", 1.0, Time::ZERO);
    assert_eq!(out.mav.len(), 1);
    assert!(matches!(out.mav[0], MavMessage::STATUSTEXT(_)));
}

#[test]
fn a_declared_integer_is_served_as_int32_and_refuses_fractions() {
    let mut t = ParamTable::new(Vec::new()).expect("empty table");
    let mut d = decl("sim", true, &[("SYS_FAILURE_EN", 0.0)]);
    d.params[0].max = 1.0;
    d.params[0].integer = true;
    t.declare(&d, Time::ZERO);
    let MavMessage::PARAM_VALUE(p) = &t.read("SYS_FAILURE_EN", -1).expect("declared") else {
        panic!("not a PARAM_VALUE")
    };
    assert_eq!(p.param_type, MavParamType::MAV_PARAM_TYPE_INT32);
    let out = t.set("SYS_FAILURE_EN", 0.5, Time::ZERO);
    assert!(out.graph.is_empty(), "0.5 is not passed on as 0 or 1");
    assert_eq!(t.set("SYS_FAILURE_EN", 1.0, Time::ZERO).graph, vec![param_set("SYS_FAILURE_EN", 1.0)]);
}

#[test]
fn bad_tables_are_refused() {
    assert!(matches!(
        ParamTable::new(vec![spec("A", 1.0, 2.0, 3.0, ParamKind::Real32)]),
        Err(ParamError::OutOfRange { .. })
    ));
    assert!(matches!(
        ParamTable::new(vec![spec("THIS_NAME_IS_TOO_LONG", 1.0, 0.0, 3.0, ParamKind::Real32)]),
        Err(ParamError::Name(_))
    ));
    let dup = vec![spec("A", 1.0, 0.0, 3.0, ParamKind::Real32), spec("A", 1.0, 0.0, 3.0, ParamKind::Real32)];
    assert!(matches!(ParamTable::new(dup), Err(ParamError::Duplicate(_))));
}

#[test]
fn only_set_or_restored_values_are_persisted_and_they_round_trip() {
    let mut t = table();
    assert_eq!(render_param_file(&t), "", "defaults are not persisted");
    t.set("RTL_ALT_M", 42.5, Time::ZERO);
    t.restore("AVOID_CLIMB_M_S", 2.0).expect("held for an owner that is not running");
    let text = render_param_file(&t);
    assert_eq!(text, "AVOID_CLIMB_M_S=2\nRTL_ALT_M=42.5\n");
    let (pairs, bad) = parse_param_file(&format!("# saved\n{text}garbage\n"));
    assert_eq!(bad, ["garbage"]);
    let mut fresh = table();
    for (n, v) in pairs {
        fresh.restore(&n, v).expect("known or held");
    }
    assert_eq!(value(&fresh.read("RTL_ALT_M", -1).expect("known")).1, 42.5);
    assert_eq!(render_param_file(&fresh), text);
}

#[test]
fn declarations_join_the_table_in_name_order_and_replace_config_entries() {
    let mut t = table();
    let done = t.declare(&decl("commander", true, &[("TKOFF_ALT_M", 10.0), ("RTL_ALT_M", 15.0)]), Time::ZERO);
    assert!(done.out.mav.is_empty() && done.out.graph.is_empty());
    let names: Vec<_> = t.values().collect();
    assert_eq!(names, [("FS_ACTION", 1.0), ("RTL_ALT_M", 15.0), ("TKOFF_ALT_M", 10.0)]);
    // Another actor cannot take a name that is owned.
    let done = t.declare(&decl("estimator", true, &[("RTL_ALT_M", 99.0)]), Time::ZERO);
    assert_eq!(texts(&done.out.mav), 1);
    assert_eq!(value(&t.read("RTL_ALT_M", -1).expect("known")).1, 15.0);
    // A malformed declaration is refused whole.
    let done = t.declare(&decl("x", true, &[("A", 1.0), ("A", 2.0)]), Time::ZERO);
    assert_eq!(texts(&done.out.mav), 1);
    assert_eq!(t.len(), 3);
}

#[test]
fn stored_values_go_to_their_owner_when_it_declares_and_again_after_a_restart() {
    let mut t = table();
    t.restore("TKOFF_ALT_M", 12.5).expect("held");
    let done = t.declare(&decl("commander", true, &[("TKOFF_ALT_M", 10.0)]), Time::ZERO);
    assert_eq!(done.out.graph, vec![restored("TKOFF_ALT_M", 12.5)]);
    assert_eq!(value(&t.read("TKOFF_ALT_M", -1).expect("known")).1, 12.5);
    // The owner's answer confirms it: nothing more to do.
    let done = t.declare(&decl("commander", false, &[("TKOFF_ALT_M", 12.5)]), Time::ZERO);
    assert!(done.out.mav.is_empty() && done.out.graph.is_empty());
    // A restart loses it: the link sends it again.
    let done = t.declare(&decl("commander", true, &[("TKOFF_ALT_M", 10.0)]), Time::ZERO);
    assert_eq!(done.out.graph, vec![restored("TKOFF_ALT_M", 12.5)]);
    // A stored value outside the declared range is dropped with a STATUSTEXT.
    let mut t = table();
    t.restore("TKOFF_ALT_M", 500.0).expect("held");
    let done = t.declare(&decl("commander", true, &[("TKOFF_ALT_M", 10.0)]), Time::ZERO);
    assert!(done.out.graph.is_empty());
    assert_eq!(texts(&done.out.mav), 1);
    assert_eq!(render_param_file(&t), "");
}

#[test]
fn an_owner_refusing_a_set_value_is_believed_and_broadcast() {
    let mut t = table();
    t.declare(&decl("commander", true, &[("BATT_CRT_FRAC", 10.0)]), Time::ZERO);
    let out = t.set("BATT_CRT_FRAC", 50.0, Time::ZERO);
    assert_eq!(out.graph, vec![param_set("BATT_CRT_FRAC", 50.0)]);
    assert!(out.mav.is_empty(), "no echo before the owner answers");
    let done = t.declare(&decl("commander", false, &[("BATT_CRT_FRAC", 10.0)]), Time::ZERO);
    assert_eq!(values(&done.out.mav), [("BATT_CRT_FRAC".to_owned(), 10.0)]);
    assert_eq!(texts(&done.out.mav), 1);
    assert_eq!(render_param_file(&t), "", "the refused value is not persisted");
}

#[test]
fn an_owner_taking_a_set_value_is_echoed_and_persisted() {
    let mut t = table();
    t.declare(&decl("commander", true, &[("BATT_CRT_FRAC", 10.0)]), Time::ZERO);
    t.set("BATT_CRT_FRAC", 20.0, Time::ZERO);
    let done = t.declare(&decl("commander", false, &[("BATT_CRT_FRAC", 20.0)]), Time::ZERO);
    assert_eq!(values(&done.out.mav), [("BATT_CRT_FRAC".to_owned(), 20.0)]);
    assert_eq!(texts(&done.out.mav), 0);
    assert!(done.persist_changed);
    assert_eq!(render_param_file(&t), "BATT_CRT_FRAC=20\n");
    assert!(t.tick(Time::from_secs_f64(5.0)).is_empty(), "confirmed: nothing expires");
}

#[test]
fn sets_sent_together_are_judged_by_the_declaration_answering_each() {
    let mut t = table();
    let both = |a, b| decl("commander", false, &[("BATT_CRT_FRAC", a), ("TKOFF_ALT_M", b)]);
    t.declare(&decl("commander", true, &[("BATT_CRT_FRAC", 10.0), ("TKOFF_ALT_M", 10.0)]), Time::ZERO);
    t.set("BATT_CRT_FRAC", 20.0, Time::ZERO);
    t.set("TKOFF_ALT_M", 12.0, Time::ZERO);
    // The answer to the first set still shows the second's old value: not a refusal.
    let done = t.declare(&both(20.0, 10.0), Time::ZERO);
    assert_eq!(values(&done.out.mav), [("BATT_CRT_FRAC".to_owned(), 20.0)]);
    assert_eq!(texts(&done.out.mav), 0);
    let done = t.declare(&both(20.0, 12.0), Time::ZERO);
    assert_eq!(values(&done.out.mav), [("TKOFF_ALT_M".to_owned(), 12.0)]);
    assert_eq!(render_param_file(&t), "BATT_CRT_FRAC=20\nTKOFF_ALT_M=12\n");
}

#[test]
fn several_stored_values_are_restored_to_one_owner_without_false_refusals() {
    let mut t = table();
    t.restore("BATT_CRT_FRAC", 20.0).expect("held");
    t.restore("TKOFF_ALT_M", 12.0).expect("held");
    let both = |a, b| decl("commander", false, &[("BATT_CRT_FRAC", a), ("TKOFF_ALT_M", b)]);
    let start = decl("commander", true, &[("BATT_CRT_FRAC", 10.0), ("TKOFF_ALT_M", 10.0)]);
    assert_eq!(t.declare(&start, Time::ZERO).out.graph.len(), 2);
    for answer in [both(20.0, 10.0), both(20.0, 12.0)] {
        let done = t.declare(&answer, Time::ZERO);
        assert_eq!(texts(&done.out.mav), 0, "no refusal");
    }
    assert_eq!(render_param_file(&t), "BATT_CRT_FRAC=20\nTKOFF_ALT_M=12\n");
}

#[test]
fn an_owner_that_never_answers_leaves_the_old_value_and_says_so() {
    let mut t = table();
    t.declare(&decl("commander", true, &[("BATT_CRT_FRAC", 10.0)]), Time::ZERO);
    let out = t.set("BATT_CRT_FRAC", 20.0, Time::ZERO);
    assert!(out.mav.is_empty());
    assert!(t.tick(Time::from_secs_f64(0.5)).is_empty(), "still within the timeout");
    let late = t.tick(Time::from_secs_f64(1.0));
    assert_eq!(values(&late), [("BATT_CRT_FRAC".to_owned(), 10.0)]);
    assert_eq!(texts(&late), 1);
    assert_eq!(render_param_file(&t), "");
    assert!(t.tick(Time::from_secs_f64(2.0)).is_empty(), "said once");
}

#[test]
fn a_set_is_echoed_only_after_the_file_holds_it() {
    let mut t = table();
    t.hold_echoes_until_saved();
    let out = t.set("RTL_ALT_M", 40.0, Time::ZERO);
    assert!(values(&out.mav).is_empty(), "no echo before the file is written: {:?}", out.mav);
    assert_eq!(value(&t.read("RTL_ALT_M", -1).expect("known")).1, 40.0, "in use at once");
    let first = t.take_write().expect("a text to write");
    assert_eq!(first.text, "RTL_ALT_M=40\n");
    assert_eq!(t.take_write(), None, "one text per change");
    // A second set while the first write is on its way: its text replaces the first.
    let _ = t.set("RTL_ALT_M", 50.0, Time::ZERO);
    let second = t.take_write().expect("a text to write");
    assert!(second.batch > first.batch);
    // The writer wrote the newest text only: both sets are answered with the values they set.
    let out = t.on_saved(second.batch, Ok(()), Time::ZERO);
    assert_eq!(values(&out.mav), [("RTL_ALT_M".to_owned(), 40.0), ("RTL_ALT_M".to_owned(), 50.0)]);
    assert!(t.on_saved(second.batch, Ok(()), Time::ZERO).mav.is_empty(), "each set answered once");
}

#[test]
fn a_failed_write_echoes_the_old_value_with_why() {
    let mut t = table();
    t.hold_echoes_until_saved();
    let _ = t.set("RTL_ALT_M", 40.0, Time::ZERO);
    let w = t.take_write().expect("a text");
    let out = t.on_saved(w.batch, Err("read-only"), Time::ZERO);
    let texts: Vec<String> = out.mav.iter().filter_map(text_of).collect();
    assert_eq!(texts, ["Param RTL_ALT_M not saved: read-only"]);
    assert_eq!(values(&out.mav), [("RTL_ALT_M".to_owned(), 30.0)], "the value the file holds");
    assert_eq!(value(&t.read("RTL_ALT_M", -1).expect("known")).1, 30.0, "put back in use");
    // The table is written again without the value put back (a later text may hold it).
    assert_eq!(t.take_write().expect("rewrite").text, "");
    assert_eq!(render_param_file(&t), "");
}

#[test]
fn a_failed_write_sends_an_owned_value_back_to_its_owner() {
    let mut t = ParamTable::new(Vec::new()).expect("empty table");
    t.hold_echoes_until_saved();
    t.declare(&decl("nav", true, &[("WPNAV_SPEED", 5.0)]), Time::ZERO);
    assert_eq!(t.set("WPNAV_SPEED", 8.0, Time::ZERO).graph, vec![param_set("WPNAV_SPEED", 8.0)]);
    let done = t.declare(&decl("nav", false, &[("WPNAV_SPEED", 8.0)]), Time::ZERO);
    assert!(values(&done.out.mav).is_empty(), "taken, held until saved");
    let w = t.take_write().expect("a text");
    assert_eq!(w.text, "WPNAV_SPEED=8\n");
    let out = t.on_saved(w.batch, Err("disk full"), Time::ZERO);
    assert_eq!(out.graph, vec![restored("WPNAV_SPEED", 5.0)]);
    assert_eq!(values(&out.mav), [("WPNAV_SPEED".to_owned(), 5.0)]);
    // The owner takes the old value back: no second echo.
    let done = t.declare(&decl("nav", false, &[("WPNAV_SPEED", 5.0)]), Time::ZERO);
    assert!(done.out.mav.is_empty(), "{:?}", done.out.mav);
}
