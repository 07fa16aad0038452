//! Helpers shared by the test binaries: each binary declares `mod support;` and uses the
//! modules it needs, so the ones it leaves unused are allowed to be dead code there.
#![allow(dead_code, unused_imports)]

pub mod arducopter;
pub mod avoidance_flight;
pub mod avoidance_page;
pub mod flights;
pub mod forest_seeds;
pub mod hil_square;
pub mod merged_config;
pub mod qgc_plan;
pub mod results_page;
pub mod side_by_side;
pub mod sim_vehicle;
