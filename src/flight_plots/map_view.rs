//! The top view's scale: one metre is as many pixels east as north, so trees stay round and
//! distances can be read off either axis.

use std::ops::Range;

/// Free space around the drawn content (share of its span, and at least this many metres), so
/// shapes do not touch the frame.
const PAD_SHARE: f64 = 0.06;
const PAD_MIN_M: f64 = 1.0;

/// Share of the north span added above the content for the legend.
const LEGEND_HEADROOM: f64 = 0.22;

/// Ranges of a top view (east across, north up) with equal metres per pixel on both axes, and
/// where they land in the image.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MapView {
    /// East range across the plotting area (m).
    pub east_m: (f64, f64),
    /// North range up the plotting area (m).
    pub north_m: (f64, f64),
    /// The plotting area's pixel columns and rows in the image, as plotters reports them.
    pub columns_px: Range<i32>,
    pub rows_px: Range<i32>,
}

impl MapView {
    /// The smallest equal-scale view of `points` (north, east; m) in a plotting area of
    /// `columns_px` × `rows_px`, centred on them, with padding and legend headroom.
    pub fn fit(
        points: impl Iterator<Item = (f64, f64)>,
        columns_px: Range<i32>,
        rows_px: Range<i32>,
    ) -> MapView {
        let (mut north, mut east) = ((f64::INFINITY, f64::NEG_INFINITY), (f64::INFINITY, f64::NEG_INFINITY));
        for (n, e) in points.filter(|(n, e)| n.is_finite() && e.is_finite()) {
            north = (north.0.min(n), north.1.max(n));
            east = (east.0.min(e), east.1.max(e));
        }
        if north.0 > north.1 {
            (north, east) = ((-1.0, 1.0), (-1.0, 1.0));
        }
        let pad = |(lo, hi): (f64, f64)| {
            let pad = ((hi - lo) * PAD_SHARE).max(PAD_MIN_M);
            (lo - pad, hi + pad)
        };
        let (north, east) = (pad(north), pad(east));
        let north = (north.0, north.1 + (north.1 - north.0) * LEGEND_HEADROOM);
        let (width_px, height_px) = (span_px(&columns_px), span_px(&rows_px));
        let m_per_px = ((east.1 - east.0) / width_px).max((north.1 - north.0) / height_px);
        let centred = |(lo, hi): (f64, f64), px: f64| {
            let mid = (lo + hi) / 2.0;
            (mid - m_per_px * px / 2.0, mid + m_per_px * px / 2.0)
        };
        MapView { east_m: centred(east, width_px), north_m: centred(north, height_px), columns_px, rows_px }
    }

    /// Metres per pixel, the same across and up.
    pub fn metres_per_px(&self) -> f64 {
        (self.east_m.1 - self.east_m.0) / span_px(&self.columns_px)
    }

    /// The image pixel (column, row) where plotters draws the point `north`, `east` (m): the
    /// east range's ends on the area's first and last column, north's on its last and first row.
    /// Drawing goes through plotters; tests use this to check where shapes landed.
    #[cfg(test)]
    pub fn pixel(&self, north_m: f64, east_m: f64) -> (f64, f64) {
        let across = (east_m - self.east_m.0) / (self.east_m.1 - self.east_m.0);
        let up = (north_m - self.north_m.0) / (self.north_m.1 - self.north_m.0);
        (
            f64::from(self.columns_px.start) + across * span_px(&self.columns_px),
            f64::from(self.rows_px.end - 1) - up * span_px(&self.rows_px),
        )
    }
}

/// Pixels between the first and the last pixel of `range` (plotters maps a coordinate range's
/// ends onto those two).
fn span_px(range: &Range<i32>) -> f64 {
    f64::from((range.end - range.start - 1).max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_has_one_scale_and_holds_every_point() {
        let points = [(0.0, 0.0), (60.0, 10.0), (30.0, -10.0)];
        let view = MapView::fit(points.into_iter(), 100..1101, 50..651);
        let across = (view.east_m.1 - view.east_m.0) / 1000.0;
        let up = (view.north_m.1 - view.north_m.0) / 600.0;
        assert!((across - up).abs() < 1e-12, "{across} m/px across, {up} up");
        assert!((view.metres_per_px() - across).abs() < 1e-12);
        for (n, e) in points {
            let (column, row) = view.pixel(n, e);
            assert!((100.0..=1100.0).contains(&column) && (50.0..=650.0).contains(&row), "{n}, {e}");
        }
        // The view is centred east; north is the tight axis: 60 m plus padding and headroom.
        assert!((view.east_m.0 + view.east_m.1).abs() < 1e-9);
        assert_eq!(view.pixel(view.north_m.1, view.east_m.0), (100.0, 50.0));
    }
}
