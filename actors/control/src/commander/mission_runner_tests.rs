use kestrel_proto::Time;
use kestrel_proto::messages::{Mission, MissionItem};

use super::MissionRunner;

fn loiters(n: usize) -> Mission {
    Mission {
        time: Time::ZERO,
        items: vec![MissionItem::LoiterTime { duration_s: 1.0, point: None }; n],
        cruise_speed_m_s: 5.0,
    }
}

proptest::proptest! {
    /// Whatever the lengths, the item flown after a replacement is the same index or the new
    /// mission's last, the count of reached items goes on, and a finished run stays finished.
    #[test]
    fn replace_keeps_the_index_within_the_new_mission(
        old_len in 1usize..20,
        index in 0usize..25,
        new_len in 1usize..20,
        reached in 0u32..10,
    ) {
        let mut runner = MissionRunner::new(loiters(old_len));
        let index = index.min(old_len);
        runner.current = index;
        runner.pending_walk = (index < old_len).then_some(index);
        runner.reached = reached;
        runner.replace(loiters(new_len));
        let p = runner.progress();
        let finished = index >= old_len;
        let want = if finished { new_len } else { index.min(new_len - 1) };
        proptest::prop_assert_eq!(p.current as usize, want);
        proptest::prop_assert_eq!(p.completed, finished);
        proptest::prop_assert_eq!(p.total as usize, new_len);
        proptest::prop_assert_eq!(p.reached, reached);
    }
}

mod items {
    use std::time::Duration;

    use kestrel_proto::Time;
    use kestrel_proto::geo::{Geodetic, LocalFrame};
    use kestrel_proto::messages::{AltitudeFrame, CameraAction, Mission, MissionItem, MissionPoint};
    use nalgebra::Vector3;

    use super::super::{MissionEvent, MissionRunner, MissionStep, wrap_pi};

    const DT_S: f64 = 0.05;

    fn frame() -> LocalFrame {
        LocalFrame::new(Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 })
    }

    /// The mission point at NED north/east (m), `alt_m` above home.
    fn at(north_m: f64, east_m: f64, alt_m: f64) -> MissionPoint {
        let g = frame().to_geodetic([north_m, east_m, 0.0]);
        MissionPoint { lat_deg: g.lat_deg, lon_deg: g.lon_deg, alt_m, frame: AltitudeFrame::RelativeHome }
    }

    fn wp(north_m: f64, east_m: f64) -> MissionItem {
        MissionItem::Waypoint { point: at(north_m, east_m, 10.0), acceptance_radius_m: 1.0, hold_s: 0.0 }
    }

    fn mission(items: Vec<MissionItem>) -> Mission {
        Mission { time: Time::ZERO, items, cruise_speed_m_s: 5.0 }
    }

    /// A vehicle that goes where the setpoint says at up to its speed limit (velocity
    /// feed-forward ignored) and turns its nose at up to 90 deg/s: enough to see what each item
    /// asks for.
    struct Flight {
        runner: MissionRunner,
        now: Time,
        pos: Vector3<f64>,
        heading_rad: f64,
        /// Each step's sample.
        log: Vec<Sample>,
        events: Vec<MissionEvent>,
    }

    /// One step of a [`Flight`]: the time (s) the step was taken at, the vehicle's position
    /// after it, the mission's step and the item current after it.
    struct Sample {
        t_s: f64,
        pos: Vector3<f64>,
        step: MissionStep,
        current: u32,
    }

    impl Flight {
        fn new(items: Vec<MissionItem>) -> Flight {
            Flight {
                runner: MissionRunner::new(mission(items)),
                now: Time::ZERO,
                pos: Vector3::new(0.0, 0.0, -10.0),
                heading_rad: 0.0,
                log: Vec::new(),
                events: Vec::new(),
            }
        }

        fn step(&mut self) -> MissionStep {
            let home = Vector3::zeros();
            let step = self.runner.update(self.now, &self.pos, self.heading_rad, &frame(), &home, None);
            self.events.extend(self.runner.drain_events());
            if let MissionStep::Fly(sp) = step {
                if let [Some(n), Some(e), Some(d)] = sp.position_ned_m {
                    let to = Vector3::new(n, e, d) - self.pos;
                    let max = sp.max_horizontal_speed_m_s.unwrap_or(5.0).max(1.0) * 1.5 * DT_S;
                    self.pos += if to.norm() > max { to.normalize() * max } else { to };
                }
                if let Some(yaw) = sp.yaw_rad {
                    let max = 90f64.to_radians() * DT_S;
                    self.heading_rad =
                        wrap_pi(self.heading_rad + wrap_pi(yaw - self.heading_rad).clamp(-max, max));
                }
            }
            self.log.push(Sample {
                t_s: self.now.as_secs_f64(),
                pos: self.pos,
                step,
                current: self.runner.progress().current,
            });
            self.now = self.now + Duration::from_secs_f64(DT_S);
            step
        }

        /// Steps until the mission asks for something other than flying, or `max_s` passed.
        fn run(&mut self, max_s: f64) -> MissionStep {
            loop {
                let step = self.step();
                if !matches!(step, MissionStep::Fly(_)) || self.now.as_secs_f64() > max_s {
                    return step;
                }
            }
        }

        /// The time (s) item `index` stopped being current, if it did.
        fn left(&self, index: u32) -> Option<f64> {
            let mut was = false;
            for sample in &self.log {
                if sample.current == index {
                    was = true;
                } else if was {
                    return Some(sample.t_s);
                }
            }
            None
        }
    }

    #[test]
    fn loiter_time_flies_to_its_point_and_waits_there() {
        let mut f =
            Flight::new(vec![MissionItem::LoiterTime { duration_s: 5.0, point: Some(at(20.0, 0.0, 10.0)) }]);
        assert_eq!(f.run(60.0), MissionStep::Finished);
        assert!((f.pos - Vector3::new(20.0, 0.0, -10.0)).norm() < 2.0, "{:?}", f.pos);
        // 20 m at 7.5 m/s then 5 s waiting, arriving within 2 m.
        let t = f.left(0).unwrap();
        assert!((7.0..8.5).contains(&t), "left after {t} s");
    }

    #[test]
    fn loiter_turns_circles_its_point_the_number_of_turns() {
        let center = Vector3::new(0.0, 30.0, -10.0);
        let mut f = Flight::new(vec![MissionItem::LoiterTurns {
            point: Some(at(0.0, 30.0, 10.0)),
            turns: 2.0,
            radius_m: 10.0,
        }]);
        assert_eq!(f.run(200.0), MissionStep::Finished);
        // Once on the circle: at its radius, and the angle swept is two turns clockwise.
        let on: Vec<_> =
            f.log.iter().map(|l| l.pos).filter(|p| ((p - center).xy().norm() - 10.0).abs() < 0.5).collect();
        let mut swept = 0.0;
        for w in on.windows(2) {
            let a = (w[0].y - center.y).atan2(w[0].x - center.x);
            let b = (w[1].y - center.y).atan2(w[1].x - center.x);
            swept += wrap_pi(b - a);
        }
        assert!((swept - 4.0 * std::f64::consts::PI).abs() < 0.3, "swept {swept} rad");
        // 20 deg/s is slower than 5 m/s at 10 m: 18 s a turn.
        let t = f.left(0).unwrap();
        assert!((36.0..42.0).contains(&t), "circled for {t} s");
    }

    #[test]
    fn loiter_unlimited_holds_at_its_point_until_moved_on() {
        let mut f = Flight::new(vec![
            MissionItem::LoiterUnlimited { point: Some(at(10.0, 0.0, 10.0)) },
            wp(0.0, 0.0),
        ]);
        f.run(120.0);
        assert_eq!(f.runner.progress().current, 0);
        assert!((f.pos - Vector3::new(10.0, 0.0, -10.0)).norm() < 0.1);
        assert!(f.runner.set_current(1));
        assert_eq!(f.run(240.0), MissionStep::Finished);
    }

    #[test]
    fn nav_delay_holds_where_the_vehicle_is() {
        let mut f = Flight::new(vec![wp(10.0, 0.0), MissionItem::Delay { duration_s: 4.0 }, wp(0.0, 0.0)]);
        f.run(60.0);
        let (arrived, left) = (f.left(0).unwrap(), f.left(1).unwrap());
        assert!((left - arrived - 4.0).abs() < 0.11, "held {} s", left - arrived);
    }

    #[test]
    fn a_condition_delay_holds_back_the_do_items_after_it_not_the_flight() {
        let mut f = Flight::new(vec![
            wp(5.0, 0.0),
            MissionItem::ConditionDelay { duration_s: 3.0 },
            MissionItem::ChangeSpeed { speed_m_s: 2.0 },
            wp(100.0, 0.0),
        ]);
        let mut changed_at = None;
        while f.now.as_secs_f64() < 60.0 {
            if let MissionStep::Fly(sp) = f.step()
                && sp.max_horizontal_speed_m_s == Some(2.0)
            {
                changed_at.get_or_insert(f.now.as_secs_f64());
            }
        }
        let started = f.left(0).unwrap();
        let changed = changed_at.expect("the speed changed");
        assert!(
            (changed - started - 3.0).abs() < 0.11,
            "changed {} s after the leg began",
            changed - started
        );
    }

    #[test]
    fn do_items_not_run_when_their_leg_ends_are_dropped() {
        let mut f = Flight::new(vec![
            wp(1.0, 0.0),
            MissionItem::ConditionDelay { duration_s: 100.0 },
            MissionItem::ChangeSpeed { speed_m_s: 2.0 },
            wp(2.0, 0.0),
            wp(30.0, 0.0),
        ]);
        while f.now.as_secs_f64() < 30.0 {
            if let MissionStep::Fly(sp) = f.step() {
                assert_eq!(sp.max_horizontal_speed_m_s, Some(5.0), "the change never runs");
            }
        }
    }

    #[test]
    fn a_condition_distance_waits_until_the_vehicle_is_that_near() {
        let mut f = Flight::new(vec![
            wp(0.0, 0.0),
            MissionItem::ConditionDistance { distance_m: 10.0 },
            MissionItem::Camera { action: CameraAction::Shoot },
            wp(50.0, 0.0),
        ]);
        while f.events.is_empty() && f.now.as_secs_f64() < 60.0 {
            f.step();
        }
        assert_eq!(f.events, vec![MissionEvent::Camera { index: 2, action: CameraAction::Shoot }]);
        let to_go = 50.0 - f.pos.x;
        assert!((8.0..=10.0).contains(&to_go), "{to_go} m to go");
    }

    #[test]
    fn a_condition_yaw_turns_the_nose_at_its_rate_and_holds_back_what_follows() {
        let mut f = Flight::new(vec![
            wp(0.0, 0.0),
            MissionItem::ConditionYaw { angle_deg: 90.0, rate_deg_s: 30.0, clockwise: true, relative: true },
            MissionItem::NoOutput { command: 183 },
            MissionItem::LoiterTime { duration_s: 10.0, point: None },
        ]);
        while f.events.is_empty() && f.now.as_secs_f64() < 60.0 {
            f.step();
        }
        assert!(
            (f.heading_rad - 90f64.to_radians()).abs() < 2f64.to_radians(),
            "{}",
            f.heading_rad.to_degrees()
        );
        // 90 degrees at 30 deg/s: 3 s.
        // The first waypoint is where the vehicle starts: the turn begins at once.
        let t = f.now.as_secs_f64();
        assert!((2.9..3.4).contains(&t), "turned in {t} s");
        assert_eq!(f.events, vec![MissionEvent::NoOutput { index: 2, command: 183 }]);
    }

    #[test]
    fn a_region_of_interest_keeps_the_nose_on_it_until_none() {
        let mut f = Flight::new(vec![
            MissionItem::RegionOfInterest { point: Some(at(0.0, 50.0, 0.0)) },
            wp(20.0, 0.0),
            MissionItem::RegionOfInterest { point: None },
            wp(20.0, 20.0),
        ]);
        f.step();
        loop {
            let MissionStep::Fly(sp) = f.step() else { panic!("flying") };
            if f.runner.progress().current != 1 {
                assert_eq!(sp.yaw_rad, None, "ROI none: the commander's held heading");
                break;
            }
            let p = f.log.last().unwrap().pos;
            let want = (50.0 - p.y).atan2(-p.x);
            let yaw = sp.yaw_rad.expect("the mission aims the nose");
            assert!(wrap_pi(yaw - want).abs() < 0.2, "yaw {yaw} want {want}");
        }
    }

    #[test]
    fn the_landing_sequence_nearest_the_vehicle_is_jumped_to() {
        let items = vec![
            wp(100.0, 0.0),
            MissionItem::LandStart { point: Some(at(100.0, 0.0, 0.0)) },
            MissionItem::Land { point: at(100.0, 0.0, 0.0) },
            MissionItem::LandStart { point: Some(at(0.0, 5.0, 0.0)) },
            wp(0.0, 5.0),
            MissionItem::Land { point: at(0.0, 5.0, 0.0) },
        ];
        let mut f = Flight::new(items.clone());
        f.step();
        let home = Vector3::zeros();
        assert!(f.runner.jump_to_landing_sequence(&f.pos, &frame(), &home));
        f.step();
        assert_eq!(f.runner.progress().current, 4, "the waypoint after the nearer DO_LAND_START");
        let mut none = MissionRunner::new(mission(vec![wp(1.0, 0.0)]));
        assert!(!none.jump_to_landing_sequence(&f.pos, &frame(), &home));
    }

    #[test]
    fn spline_waypoints_pass_through_each_point_smoothly() {
        let mut f = Flight::new(vec![
            MissionItem::SplineWaypoint { point: at(30.0, 0.0, 10.0), hold_s: 0.0 },
            MissionItem::SplineWaypoint { point: at(30.0, 30.0, 10.0), hold_s: 0.0 },
            MissionItem::SplineWaypoint { point: at(0.0, 30.0, 10.0), hold_s: 0.0 },
        ]);
        assert_eq!(f.run(120.0), MissionStep::Finished);
        for p in
            [Vector3::new(30.0, 0.0, -10.0), Vector3::new(30.0, 30.0, -10.0), Vector3::new(0.0, 30.0, -10.0)]
        {
            let nearest = f.log.iter().map(|l| (l.pos - p).norm()).fold(f64::INFINITY, f64::min);
            assert!(nearest < 2.0, "passed {nearest} m from {p:?}");
        }
        // Smooth: the setpoint never turns through more than a few degrees a step at the
        // corners, where a straight leg would turn 90 degrees at once.
        let sps: Vec<Vector3<f64>> = f
            .log
            .iter()
            .filter_map(|l| match l.step {
                MissionStep::Fly(sp) => sp.position_ned_m.iter().copied().collect::<Option<Vec<_>>>(),
                _ => None,
            })
            .map(|v| Vector3::new(v[0], v[1], v[2]))
            .collect();
        let dirs: Vec<_> =
            sps.windows(2).map(|w| w[1] - w[0]).filter(|d| d.norm() > 0.05).map(|d| d.normalize()).collect();
        let worst =
            dirs.windows(2).map(|w| w[0].dot(&w[1]).clamp(-1.0, 1.0).acos().to_degrees()).fold(0.0, f64::max);
        assert!(worst < 10.0, "turned {worst} deg in one step");
    }

    #[test]
    fn a_return_to_launch_item_is_reached_when_rtl_takes_over() {
        let mut f = Flight::new(vec![MissionItem::ReturnToLaunch, wp(1.0, 0.0)]);
        assert_eq!(f.step(), MissionStep::ReturnToLaunch);
        let p = f.runner.progress();
        assert_eq!((p.reached, p.last_reached, p.current, p.completed), (1, Some(0), 1, false));
    }

    #[test]
    fn a_jump_repeats_its_legs_as_often_as_it_says() {
        let mut f = Flight::new(vec![
            wp(5.0, 0.0),
            wp(0.0, 0.0),
            MissionItem::Jump { target: 0, repeat: 2 },
            wp(0.0, 5.0),
        ]);
        assert_eq!(f.run(200.0), MissionStep::Finished);
        let mut seq: Vec<u32> = f.log.iter().map(|l| l.current).collect();
        seq.dedup();
        assert_eq!(seq, vec![0, 1, 0, 1, 0, 1, 3, 4]);
    }
}

mod jumps {
    use std::time::Duration;

    use kestrel_proto::Time;
    use kestrel_proto::geo::{Geodetic, LocalFrame};
    use kestrel_proto::messages::{Mission, MissionItem};
    use nalgebra::Vector3;
    use proptest::prelude::*;

    use super::super::MissionRunner;

    /// The items a mission of navigation items and jumps flies, as MAVLink's DO_JUMP reads: a
    /// jump taken while taken fewer times than its count (always at -1), a search for the next
    /// item giving up after 64 jumps. At most `max` items; `true` when the mission ended.
    fn reference(items: &[MissionItem], max: usize) -> (Vec<usize>, bool) {
        let mut taken = vec![0; items.len()];
        let (mut pc, mut flown) = (0, Vec::new());
        loop {
            let mut jumps = 0;
            while let Some(MissionItem::Jump { target, repeat }) = items.get(pc) {
                jumps += 1;
                if jumps > 64 {
                    return (flown, true);
                }
                if *repeat == -1 || taken[pc] < *repeat {
                    taken[pc] += i32::from(*repeat != -1);
                    pc = *target as usize;
                } else {
                    pc += 1;
                }
            }
            if pc >= items.len() {
                return (flown, true);
            }
            flown.push(pc);
            if flown.len() >= max {
                return (flown, false);
            }
            pc += 1;
        }
    }

    fn item(n: usize) -> impl Strategy<Value = MissionItem> {
        prop_oneof![
            2 => Just(MissionItem::Delay { duration_s: 1.0 }),
            1 => (0..n as u32, prop_oneof![4 => 0i32..4, 1 => Just(-1)])
                .prop_map(|(target, repeat)| MissionItem::Jump { target, repeat }),
        ]
    }

    proptest! {
        /// Whatever the jumps, the runner flies exactly the items the counts say, in order, and
        /// ends exactly when they say it ends (a loop for ever goes on for ever).
        #[test]
        fn jumps_fly_the_items_the_counts_say(items in (2usize..9).prop_flat_map(|n| proptest::collection::vec(item(n), n))) {
            let items: Vec<_> = items
                .iter()
                .enumerate()
                .map(|(i, it)| match *it {
                    // A jump to itself is refused at upload (`check_fields`).
                    MissionItem::Jump { target, repeat } if target as usize == i => {
                        MissionItem::Jump { target: (target + 1) % items.len() as u32, repeat }
                    }
                    other => other,
                })
                .collect();
            let mission = Mission { time: Time::ZERO, items: items.clone(), cruise_speed_m_s: 5.0 };
            prop_assume!(mission.check_fields().is_ok());
            const MAX: usize = 200;
            let (want, ends) = reference(&items, MAX);
            let frame = LocalFrame::new(Geodetic { lat_deg: 6.8, lon_deg: 79.9, alt_m: 20.0 });
            let mut runner = MissionRunner::new(mission);
            let (pos, mut now, mut flown) = (Vector3::zeros(), Time::ZERO, Vec::new());
            // Each delay is done at its second update, 1 s after it started: one item a step.
            for _ in 0..(2 * MAX + 4) {
                let before = runner.progress().reached;
                runner.update(now, &pos, 0.0, &frame, &pos, None);
                let p = runner.progress();
                prop_assert!(p.reached - before <= 1);
                if p.reached > before {
                    flown.push(p.last_reached.unwrap() as usize);
                }
                if p.completed || flown.len() >= MAX {
                    break;
                }
                now = now + Duration::from_millis(500);
            }
            prop_assert_eq!(&flown, &want);
            prop_assert_eq!(runner.progress().completed, ends);
        }
    }
}
