//! Mutated and arbitrary QGroundControl `.plan` files are converted or refused, never panic;
//! what converts holds only finite numbers where the commander needs them.

use kestrel_control::parse_plan;
use kestrel_proto::bad_input::mutate;
use kestrel_proto::messages::MissionItem;
use proptest::prelude::*;

const PLANS: [&str; 4] = [
    include_str!("../../../config/missions/square.plan"),
    include_str!("../../../config/missions/patrol.plan"),
    include_str!("../../../config/missions/leg-40m.plan"),
    include_str!("../../../config/missions/leg-100m.plan"),
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_plans_convert_or_are_refused(
        which in 0..PLANS.len(),
        edits in prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..6),
    ) {
        let text = String::from_utf8_lossy(&mutate(PLANS[which].as_bytes(), &edits)).into_owned();
        if let Ok(mission) = parse_plan(&text) {
            prop_assert!(mission.cruise_speed_m_s.is_finite() && mission.cruise_speed_m_s > 0.0);
            for item in &mission.items {
                match item {
                    MissionItem::Waypoint { point, acceptance_radius_m, hold_s } => {
                        prop_assert!(point.alt_m.is_finite() && acceptance_radius_m.is_finite() && hold_s.is_finite());
                    }
                    MissionItem::LoiterTime { duration_s, .. } => prop_assert!(duration_s.is_finite()),
                    MissionItem::ChangeSpeed { speed_m_s } => prop_assert!(speed_m_s.is_finite()),
                    _ => {}
                }
            }
        }
    }

    #[test]
    fn arbitrary_text_is_no_plan(text in ".{0,400}") {
        let _ = parse_plan(&text);
    }
}
