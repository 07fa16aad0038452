//! A mission changed while AUTO flies it, against ArduCopter SITL and `kestrel run`: the one
//! pymavlink script tests/python/mission_change.py flies both (the ArduCopter half when
//! `KESTREL_ARDUCOPTER` names the binary, see tests/support/arducopter.rs), and the test compares
//! what each reported.
//!
//! What ArduCopter 4.7 does (SITL, the script's transcript): a mission uploaded while it flies
//! item 3 of 4 is ACKed ACCEPTED, MISSION_CURRENT stays 3, and item 3 is restarted from the new
//! mission ("Auto mission changed, restarted command"): the vehicle flies to the new item 3 and
//! reports MISSION_ITEM_REACHED 3 there; a download returns the new mission. Kestrel does the
//! same, the new mission taking effect once the whole upload has arrived (ArduCopter writes
//! each item as it comes, and restarts its current one on every write).
//!
//! Where they differ, on purpose: a mission shorter than the item being flown. ArduCopter
//! ACKs it, fails to restart ("Auto mission changed but failed to restart command"), flies on
//! to the item it had loaded, which is in no stored mission any more, reports
//! MISSION_ITEM_REACHED for an item past the new mission's end, and ends the mission there.
//! Kestrel flies the new mission's last item, so MISSION_CURRENT, MISSION_ITEM_REACHED and a
//! download all describe what is flown. Both ACK it ACCEPTED and both download the new one.

mod support;
use support::{arducopter, sim_vehicle};

use std::time::Instant;

use serde_json::Value;
use sim_vehicle::{scripted_session, session_link, sim_config, temp_dir};

const SCRIPT: &str = "mission_change.py";

/// One stack's record of one change (`results.change` or `results.shorter`).
fn record<'a>(result: &'a Value, which: &str) -> &'a Value {
    let r = &result["results"][which];
    assert!(r.is_object(), "no {which} record in {result:#}");
    r
}

fn text(v: &Value) -> &str {
    v.as_str().unwrap_or_else(|| panic!("not a string: {v}"))
}

/// What Kestrel must report for the change to a longer mission while flying item 3 (A2), and
/// for the shorter one while flying item 4 (B3).
fn assert_kestrel(kestrel: &Value) {
    let change = record(kestrel, "change");
    assert_eq!(text(&change["ack"]), "MAV_MISSION_ACCEPTED", "{change:#}");
    assert_eq!(
        (change["current_before"].as_u64(), change["current_after"].as_u64()),
        (Some(3), Some(3)),
        "{change:#}"
    );
    assert_eq!((change["reached"].as_u64(), text(&change["flew_to"])), (Some(3), "B2"), "{change:#}");
    assert_eq!(change["download"], serde_json::json!(["B1", "B2", "B3"]), "{change:#}");
    let shorter = record(kestrel, "shorter");
    assert_eq!(text(&shorter["ack"]), "MAV_MISSION_ACCEPTED", "{shorter:#}");
    assert_eq!(shorter["current_before"].as_u64(), Some(4), "{shorter:#}");
    assert_eq!(shorter["current_after"].as_u64(), Some(2), "the new mission's last item: {shorter:#}");
    assert_eq!((shorter["reached"].as_u64(), text(&shorter["flew_to"])), (Some(2), "C1"), "{shorter:#}");
    assert_eq!(shorter["download"], serde_json::json!(["C1"]), "{shorter:#}");
    for r in [change, shorter] {
        let said = r["statustext"].as_array().map(Vec::as_slice).unwrap_or_default();
        assert!(
            !said.iter().any(|t| t.as_str().is_some_and(|t| t.contains("refused"))),
            "an ACCEPTED upload followed by a refusal: {r:#}"
        );
    }
}

#[test]
fn a_mission_changed_in_auto_is_flown_as_arducopter_flies_it() {
    let started = Instant::now();
    let dir = temp_dir("mission-change");
    let kestrel =
        scripted_session(&dir, "mission-change", SCRIPT, &[], |port| sim_config(&session_link(port, &dir)));
    assert_kestrel(&kestrel);
    println!("kestrel half: {:.1} s", started.elapsed().as_secs_f64());

    let Some(binary) = arducopter::binary() else { return };
    let sitl_started = Instant::now();
    let ardu = arducopter::scripted_session(&binary, SCRIPT, &[]);
    println!("ArduCopter half: {:.1} s", sitl_started.elapsed().as_secs_f64());
    // The same ACK, the same item flown next and reached there, the same download.
    let (ours, theirs) = (record(&kestrel, "change"), record(&ardu, "change"));
    for key in ["ack", "current_before", "current_after", "reached", "flew_to", "download"] {
        assert_eq!(ours[key], theirs[key], "{key}: kestrel {ours:#}\narducopter {theirs:#}");
    }
    // The shorter mission: the same ACK and download; what each flies is the documented
    // difference (ArduCopter: the removed item it had loaded, past the new mission's end).
    let (ours, theirs) = (record(&kestrel, "shorter"), record(&ardu, "shorter"));
    for key in ["ack", "current_before", "download"] {
        assert_eq!(ours[key], theirs[key], "{key}: kestrel {ours:#}\narducopter {theirs:#}");
    }
    println!(
        "shorter mission: ArduCopter flew to {} (MISSION_ITEM_REACHED {}), Kestrel to {} (MISSION_ITEM_REACHED {})",
        theirs["flew_to"], theirs["reached"], ours["flew_to"], ours["reached"]
    );
    let _ = std::fs::remove_dir_all(&dir);
    println!("whole test: {:.1} s", started.elapsed().as_secs_f64());
}
