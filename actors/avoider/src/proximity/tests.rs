use kestrel_proto::Time;
use kestrel_proto::messages::{DepthGrid, NavState, OBSTACLE_SECTORS, SECTOR_UNKNOWN};
use proptest::prelude::*;

use super::*;
use crate::avoidance::error::GridError;

/// The sector layout the stereo actor sends: 72 × 5° from straight ahead, 0.3–20 m.
const MAX_CM: u16 = 2000;
const FREE: u16 = MAX_CM + 1;

/// A grid captured at `seconds` from a 110° camera (sectors −11..=11 in view) reading free
/// but for `readings` (sector, m; a negative sector counts anticlockwise from forward).
fn grid(seconds: f64, readings: &[(i32, f64)]) -> DepthGrid {
    let index = |s: i32| s.rem_euclid(OBSTACLE_SECTORS as i32) as usize;
    let free = (-11i32..=11).map(|s| (index(s), FREE));
    let read = readings.iter().map(|&(s, m)| (index(s), (m * 100.0).round() as u16));
    let time = Time::from_secs_f64(seconds);
    DepthGrid {
        time,
        frame_sequence: (seconds * 15.0).round() as u64,
        threshold_m: 5.0,
        regions: Default::default(),
        sectors: crate::avoidance::test_sectors(free.chain(read)),
    }
}

/// The vehicle level at `(north, east)` 5 m up, heading `yaw_deg`, exactly known.
fn nav(seconds: f64, north_m: f64, east_m: f64, yaw_deg: f64) -> NavState {
    let half = yaw_deg.to_radians() / 2.0;
    NavState::exact(
        Time::from_secs_f64(seconds),
        [half.cos(), 0.0, 0.0, half.sin()],
        [0.0; 3],
        [0.0; 3],
        [north_m, east_m, -5.0],
    )
}

fn core() -> SurroundSectors {
    SurroundSectors::new(&ProximityParams::default()).unwrap()
}

/// Looks at `readings` from `at`, then updates (same time) with `grid` from `now`.
fn seen_then(
    readings: &[(i32, f64)],
    at: (f64, f64, f64),
    now: (f64, f64, f64, f64),
    later: &DepthGrid,
) -> Proximity {
    let mut core = core();
    core.set_pose(&nav(0.0, at.0, at.1, at.2));
    core.update(Time::from_secs_f64(0.0), &grid(0.0, readings)).unwrap();
    core.set_pose(&nav(now.0, now.1, now.2, now.3));
    core.update(later.time, later).unwrap()
}

#[test]
fn without_a_pose_the_sectors_are_the_cameras_alone() {
    let mut core = core();
    let g = grid(1.0, &[(0, 4.0), (-5, 2.5)]);
    let out = core.update(g.time, &g).unwrap();
    assert_eq!(out.sectors, g.sectors);
    assert_eq!(out.remembered_sectors, 0);
    assert_eq!(out.time, g.time);
    assert_eq!(out.frame_sequence, g.frame_sequence);
    assert_eq!(core.remembered(), 0);
}

#[test]
fn a_trunk_seen_ahead_is_reported_abeam_once_passed_and_out_of_view() {
    // Seen 3 m straight ahead from (0 N, 1.5 E) heading north: the trunk stands at (3 N, 1.5 E).
    // Passed at (3 N, 0 E), still heading north, it is abeam right at 1.5 m: sector 18 (90°).
    let later = grid(1.0, &[]);
    let out = seen_then(&[(0, 3.0)], (0.0, 1.5, 0.0), (1.0, 3.0, 0.0, 0.0), &later);
    assert_eq!(out.sectors.distances_cm[18], 150, "{:?}", out.sectors.distances_cm);
    assert_eq!(out.remembered_sectors, 1);
    // Everything else out of view stays unknown; the view reads free.
    for (i, &cm) in out.sectors.distances_cm.iter().enumerate() {
        if i != 18 {
            assert_eq!(cm, later.sectors.distances_cm[i], "sector {i}");
        }
    }
}

#[test]
fn a_turn_rotates_what_is_remembered_into_the_new_body_frame() {
    // 4 m ahead, then a turn of 90° right on the spot: the point is abeam left (−90°, sector 54).
    let out = seen_then(&[(0, 4.0)], (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 90.0), &grid(1.0, &[]));
    assert_eq!(out.sectors.distances_cm[54], 400);
    assert_eq!(out.sectors.obstacle_m(54), Some(4.0));
    assert!((out.sectors.bearing_deg(54) + 90.0).abs() < 1e-9);
}

#[test]
fn a_nearer_camera_reading_wins_and_a_remembered_point_hidden_behind_it_is_not_reported() {
    // Remembered 4 m ahead; now the camera reads 2 m in the same sector: 2 m goes out.
    let out = seen_then(&[(3, 4.0)], (0.0, 0.0, 0.0), (0.5, 0.0, 0.0, 0.0), &grid(0.5, &[(3, 2.0)]));
    assert_eq!(out.sectors.distances_cm[3], 200);
    assert_eq!(out.remembered_sectors, 0);
}

#[test]
fn a_point_nearer_than_the_minimum_is_reported_at_the_minimum() {
    // Seen 2.5 m ahead-right (sector 6, 30°); the vehicle then moves to within 0.2 m of it.
    let (sin, cos) = 30f64.to_radians().sin_cos();
    let (n, e) = (2.5 * cos - 0.2, 2.5 * sin);
    let out = seen_then(&[(6, 2.5)], (0.0, 0.0, 0.0), (1.0, n, e, 180.0), &grid(1.0, &[]));
    // Heading south, the point is straight behind (0.2 m north of the vehicle): sector 36.
    assert_eq!(out.sectors.distances_cm[36], 30, "ArduPilot drops readings below min_distance");
}

#[test]
fn the_camera_seeing_through_a_remembered_point_drops_it() {
    let mut core = core();
    core.set_pose(&nav(0.0, 0.0, 0.0, 0.0));
    core.update(Time::from_secs_f64(0.0), &grid(0.0, &[(0, 3.0)])).unwrap();
    assert_eq!(core.remembered(), 1);
    core.set_pose(&nav(0.1, 0.0, 0.0, 0.0));
    let out = core.update(Time::from_secs_f64(0.1), &grid(0.1, &[])).unwrap();
    assert_eq!(core.remembered(), 0);
    assert_eq!(out.sectors.distances_cm[0], FREE);
}

#[test]
fn an_invalid_pose_or_a_pose_far_from_the_capture_empties_the_memory() {
    let mut core = core();
    core.set_pose(&nav(0.0, 0.0, 0.0, 0.0));
    core.update(Time::from_secs_f64(0.0), &grid(0.0, &[(0, 3.0)])).unwrap();
    assert_eq!(core.remembered(), 1);
    let mut lost = nav(0.1, 0.0, 0.0, 0.0);
    lost.valid.horizontal_position = false;
    core.set_pose(&lost);
    assert_eq!(core.remembered(), 0);
    // A pose, but 0.5 s before the capture: the grid cannot be placed.
    core.set_pose(&nav(0.2, 0.0, 0.0, 0.0));
    core.update(Time::from_secs_f64(0.2), &grid(0.2, &[(0, 3.0)])).unwrap();
    assert_eq!(core.remembered(), 1);
    let out = core.update(Time::from_secs_f64(0.7), &grid(0.7, &[(9, 3.0)])).unwrap();
    assert_eq!(core.remembered(), 0);
    assert_eq!(out.remembered_sectors, 0);
}

#[test]
fn with_the_memory_off_nothing_is_remembered() {
    let params = ProximityParams { memory_time_s: 0.0, ..ProximityParams::default() };
    let mut core = SurroundSectors::new(&params).unwrap();
    core.set_pose(&nav(0.0, 0.0, 0.0, 0.0));
    core.update(Time::from_secs_f64(0.0), &grid(0.0, &[(0, 3.0)])).unwrap();
    assert_eq!(core.remembered(), 0);
}

#[test]
fn bad_grids_are_refused_with_what_was_wrong_and_counted() {
    let mut core = core();
    let now = Time::from_secs_f64(1.0);
    let mut short = grid(1.0, &[]);
    short.sectors.distances_cm.truncate(36);
    assert_eq!(core.update(now, &short), Err(GridError::SectorCount { got: 36, expected: 72 }));
    let mut wide = grid(1.0, &[]);
    wide.sectors.increment_deg = 10.0;
    assert!(matches!(core.update(now, &wide), Err(GridError::BadSectors { field: "increment_deg", .. })));
    let mut nan = grid(1.0, &[]);
    nan.sectors.angle_offset_deg = f32::NAN;
    assert!(matches!(core.update(now, &nan), Err(GridError::BadSectors { field: "angle_offset_deg", .. })));
    let mut range = grid(1.0, &[]);
    range.sectors.max_distance_cm = SECTOR_UNKNOWN;
    assert!(matches!(core.update(now, &range), Err(GridError::SectorRange { .. })));
    assert!(matches!(core.update(Time::from_secs_f64(1.6), &grid(1.0, &[])), Err(GridError::TooOld { .. })));
    assert_eq!(core.rejected(), 5);
    core.update(now, &grid(1.0, &[])).unwrap();
    assert!(matches!(core.update(now, &grid(1.0, &[])), Err(GridError::OutOfOrder { .. })));
    assert_eq!(core.rejected(), 6);
    assert!(
        SurroundSectors::new(&ProximityParams { memory_range_m: f64::NAN, ..ProximityParams::default() })
            .is_err()
    );
}

/// The body-frame sector and range (cm) of the NED point `(n, e)` from `(pn, pe)` heading
/// `yaw_deg`, computed with a rotation matrix and degrees, apart from the core's bearing
/// arithmetic; `None` near a sector boundary or a half centimetre, where rounding may go
/// either way.
fn expected_sector(n: f64, e: f64, pn: f64, pe: f64, yaw_deg: f64) -> Option<(usize, u16)> {
    let (s, c) = yaw_deg.to_radians().sin_cos();
    let (dn, de) = (n - pn, e - pe);
    let (x, y) = (c * dn + s * de, -s * dn + c * de);
    let deg = y.atan2(x).to_degrees().rem_euclid(360.0);
    let shifted = (deg + 2.5) / 5.0;
    let cm = (x * x + y * y).sqrt() * 100.0;
    let near_edge = (shifted - shifted.round()).abs() < 1e-6 || (cm - cm.floor() - 0.5).abs() < 1e-6;
    (!near_edge).then(|| ((shifted.floor() as usize) % 72, cm.round().clamp(30.0, f64::from(MAX_CM)) as u16))
}

proptest! {
    #[test]
    fn a_remembered_points_sector_and_range_match_an_independent_computation(
        sector in -11i32..=11,
        range_m in 0.5f64..6.0,
        yaw_a in -180.0f64..180.0,
        yaw_b in -180.0f64..180.0,
        dn in -3.0f64..3.0,
        de in -3.0f64..3.0,
    ) {
        // Seen from the origin heading `yaw_a` in `sector` at `range_m` (whole centimetres, as
        // the sectors carry it): the point is at the sector's centre bearing, by construction.
        let range_m = (range_m * 100.0).round() / 100.0;
        let bearing = (yaw_a + f64::from(sector) * 5.0).to_radians();
        let (n, e) = (range_m * bearing.cos(), range_m * bearing.sin());
        let expected = expected_sector(n, e, dn, de, yaw_b);
        prop_assume!(expected.is_some());
        let (index, cm) = expected.unwrap();
        // The later grid reads nothing at all, so only the memory speaks.
        let mut blank = grid(1.0, &[]);
        blank.sectors.distances_cm = vec![SECTOR_UNKNOWN; OBSTACLE_SECTORS];
        let out = seen_then(&[(sector, range_m)], (0.0, 0.0, yaw_a), (1.0, dn, de, yaw_b), &blank);
        let known: Vec<(usize, u16)> = out.sectors.distances_cm.iter().copied().enumerate()
            .filter(|&(_, cm)| cm != SECTOR_UNKNOWN).collect();
        prop_assert_eq!(known, vec![(index, cm)]);
        prop_assert_eq!(out.remembered_sectors, 1);
    }

    #[test]
    fn the_sectors_do_not_depend_on_where_the_scene_stands_or_which_way_it_faces(
        readings in proptest::collection::vec((-11i32..=11, 0.5f64..9.0), 1..8),
        turn_deg in -180.0f64..180.0,
        shift_n in -50.0f64..50.0,
        shift_e in -50.0f64..50.0,
        later in (-2.0f64..2.0, -2.0f64..2.0, -120.0f64..120.0),
    ) {
        // The same flight (a look, then a move) with the whole scene turned about the origin
        // by `turn_deg` and moved: the body-frame sectors are the same.
        let fly = |turn: f64, sn: f64, se: f64| {
            let (s, c) = turn.to_radians().sin_cos();
            let place = |n: f64, e: f64| (sn + c * n - s * e, se + s * n + c * e);
            let (an, ae) = place(0.0, 0.0);
            let (bn, be) = place(later.0, later.1);
            seen_then(&readings, (an, ae, turn), (1.0, bn, be, turn + later.2), &grid(1.0, &[]))
        };
        let reference = fly(0.0, 0.0, 0.0);
        let moved = fly(turn_deg, shift_n, shift_e);
        // Rounding may move a reading across a centimetre or a sector edge; away from
        // edges (the overwhelming case) they agree exactly.
        let differ = reference.sectors.distances_cm.iter().zip(&moved.sectors.distances_cm)
            .filter(|(a, b)| a.abs_diff(**b) > 1).count();
        prop_assert!(differ == 0, "{:?}\n{:?}", reference.sectors.distances_cm, moved.sectors.distances_cm);
    }
}
