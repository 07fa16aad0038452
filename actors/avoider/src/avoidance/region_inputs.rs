//! The one place where the depth grid's layout meets the rule base's input names.

use crate::avoidance::error::AvoiderError;
use crate::engine::Engine;

/// The rule base's input for each region, `[row][column]` as in `DepthGrid::regions` (row 0 the
/// top of the image, column 0 its left). The thesis names them `D_lu D_cu D_ru / D_lc D_cc D_rc
/// / D_ld D_cd D_rd` (table 3.1); `config/avoider/thesis.fll` drops the `c` of the centre row
/// and column.
pub const REGION_INPUTS: [[&str; 3]; 3] =
    [["D_lu", "D_u", "D_ru"], ["D_l", "D_c", "D_r"], ["D_ld", "D_d", "D_rd"]];

/// The rule base's desired-speed input.
pub const SPEED_INPUT: &str = "V_in";

/// Inputs the avoider feeds: nine regions and the speed.
pub const INPUT_COUNT: usize = 10;

/// The rule base's outputs in the thesis's axes: lateral (right), forward, vertical (up).
pub const OUTPUTS: [&str; 3] = ["Vx", "Vy", "Vz"];

/// Where each value the avoider feeds or reads sits in a rule base's variable lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputMap {
    regions: [[usize; 3]; 3],
    speed: usize,
    outputs: [usize; 3],
}

impl InputMap {
    /// Resolves the names against `engine`, which must have exactly these ten inputs.
    pub fn new(engine: &Engine) -> Result<InputMap, AvoiderError> {
        let rule_base = || engine.name().to_string();
        if engine.inputs().len() != INPUT_COUNT {
            return Err(AvoiderError::InputCount {
                rule_base: rule_base(),
                expected: INPUT_COUNT,
                got: engine.inputs().len(),
            });
        }
        let input = |name: &'static str| {
            engine.input_index(name).ok_or_else(|| AvoiderError::MissingVariable {
                rule_base: rule_base(),
                role: "input",
                name,
            })
        };
        let output = |name: &'static str| {
            engine.output_index(name).ok_or_else(|| AvoiderError::MissingVariable {
                rule_base: rule_base(),
                role: "output",
                name,
            })
        };
        let mut regions = [[0; 3]; 3];
        for (names, indices) in REGION_INPUTS.iter().zip(&mut regions) {
            for (name, index) in names.iter().zip(indices) {
                *index = input(name)?;
            }
        }
        Ok(InputMap {
            regions,
            speed: input(SPEED_INPUT)?,
            outputs: [output(OUTPUTS[0])?, output(OUTPUTS[1])?, output(OUTPUTS[2])?],
        })
    }

    /// The rule base's input vector for these region values (`[row][column]`) and `V_in`.
    pub fn inputs(&self, near_shares: &[[f64; 3]; 3], speed_input: f64) -> [f64; INPUT_COUNT] {
        let mut inputs = [0.0; INPUT_COUNT];
        for (values, indices) in near_shares.iter().zip(&self.regions) {
            for (&value, &index) in values.iter().zip(indices) {
                inputs[index] = value;
            }
        }
        inputs[self.speed] = speed_input;
        inputs
    }

    /// `Vx`, `Vy`, `Vz` from the rule base's outputs.
    pub fn outputs(&self, values: &[f64]) -> [f64; 3] {
        self.outputs.map(|index| values.get(index).copied().unwrap_or(f64::NAN))
    }
}
