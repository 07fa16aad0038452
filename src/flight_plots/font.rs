//! The plots' font, embedded so text renders the same on any machine, with or without system
//! fonts: DejaVu Sans (Bitstream Vera licence, `assets/fonts/LICENSE-DejaVu.txt`).

use std::sync::OnceLock;

use plotters::style::{FontStyle, register_font};

use super::PlotError;

/// The family name plots ask for; registered as DejaVu Sans.
pub(crate) const FAMILY: &str = "sans-serif";

static DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Registers DejaVu Sans as [`FAMILY`] with plotters, once per process.
pub(crate) fn register() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS).is_ok());
    if ok { Ok(()) } else { Err(PlotError::Font) }
}
