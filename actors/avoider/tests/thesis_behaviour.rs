//! The thesis's avoider rule base behaves as table 3.1 says: with the centre blocked, an
//! obstacle in each off-centre region gives the table's signs; left and right mirror; an empty
//! view asks for no correction.

use kestrel_avoider::{Engine, Workspace, thesis_engine};
use proptest::prelude::*;

/// Input order of config/avoider/thesis.fll.
const REGIONS: [&str; 9] = ["D_lu", "D_u", "D_ru", "D_l", "D_c", "D_r", "D_ld", "D_d", "D_rd"];

fn engine() -> (Engine, Workspace) {
    let engine = thesis_engine().expect("the shipped rule base loads");
    let names: Vec<&str> = engine.inputs().iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names[..9], REGIONS, "input order changed");
    assert_eq!(names[9], "V_in");
    let outputs: Vec<&str> = engine.outputs().iter().map(|v| v.name.as_str()).collect();
    assert_eq!(outputs, ["Vx", "Vy", "Vz"]);
    let workspace = engine.workspace();
    (engine, workspace)
}

/// (region, Vx, Vy, Vz) signs of table 3.1 (last row corrected), centre blocked.
const TABLE: [(&str, i8, i8, i8); 8] = [
    ("D_lu", 1, -1, -1),
    ("D_l", 1, -1, 0),
    ("D_ld", 1, -1, 1),
    ("D_u", 0, -1, -1),
    ("D_d", 0, -1, 1),
    ("D_ru", -1, -1, -1),
    ("D_r", -1, -1, 0),
    ("D_rd", -1, -1, 1),
];

#[test]
fn each_off_centre_obstacle_with_the_centre_blocked_gives_the_tables_signs() {
    let (engine, mut workspace) = engine();
    for speed in [0.0, 1.0] {
        for (region, vx, vy, vz) in TABLE {
            let mut inputs = [0.0; 10];
            inputs[4] = 1.0;
            inputs[REGIONS.iter().position(|r| *r == region).expect("a region")] = 1.0;
            inputs[9] = speed;
            let out = engine.infer(&mut workspace, &inputs).expect("valid inputs");
            for (name, value, sign) in [("Vx", out[0], vx), ("Vy", out[1], vy), ("Vz", out[2], vz)] {
                let ok = match sign {
                    0 => value.abs() < 0.01,
                    s => value * f64::from(s) > 0.3,
                };
                assert!(ok, "{region} blocked at speed {speed}: {name} = {value}, table says {sign:+}");
            }
            if speed == 1.0 {
                let slow = {
                    inputs[9] = 0.0;
                    engine.infer(&mut workspace, &inputs).expect("valid")[1]
                };
                inputs[9] = 1.0;
                let fast = engine.infer(&mut workspace, &inputs).expect("valid")[1];
                assert!(fast < slow, "{region}: high speed brakes harder ({fast} vs {slow})");
            }
        }
    }
}

#[test]
fn nothing_near_asks_for_no_correction() {
    let (engine, mut workspace) = engine();
    for speed in [0.0, 0.25, 0.5, 0.75, 1.0] {
        let mut inputs = [0.0; 10];
        inputs[9] = speed;
        let out = engine.infer(&mut workspace, &inputs).expect("valid inputs");
        assert!(out.iter().all(|v| v.abs() < 1e-3), "speed {speed}: {out:?}");
    }
}

/// The same view seen in a mirror: left and right regions swap.
fn mirrored(inputs: &[f64; 10]) -> [f64; 10] {
    let mut m = *inputs;
    for (left, right) in [(0, 2), (3, 5), (6, 8)] {
        m.swap(left, right);
    }
    m
}

proptest! {
    #[test]
    fn left_and_right_mirror(inputs in prop::array::uniform10(0.0f64..=1.0)) {
        let (engine, mut workspace) = engine();
        let out = engine.infer(&mut workspace, &inputs).expect("valid inputs").to_vec();
        let mirror = engine.infer(&mut workspace, &mirrored(&inputs)).expect("valid inputs");
        prop_assert!((out[0] + mirror[0]).abs() < 1e-9, "Vx {} vs mirrored {}", out[0], mirror[0]);
        prop_assert!((out[1] - mirror[1]).abs() < 1e-9, "Vy {} vs mirrored {}", out[1], mirror[1]);
        prop_assert!((out[2] - mirror[2]).abs() < 1e-9, "Vz {} vs mirrored {}", out[2], mirror[2]);
    }
}
