//! Where a figure's legend goes so that it covers no data: the legend's box measured as
//! plotters lays it out, the plot's corners tested against every curve (points and the
//! segments between them), and, when every corner holds data, room made above the data.

use plotters::element::MultiLineText;
use plotters::prelude::*;

use super::font::font_of;

/// The gap plotters leaves between a legend box and the plot's edge, in pixels.
const EDGE: f64 = 5.0;
/// Slack around the box, as a fraction of the plot: the data's own line width and markers.
const SLACK: f64 = 0.015;
/// Points tested on each segment between two consecutive data points.
const ON_SEGMENT: usize = 8;

/// The size in pixels of the legend box of `labels` (the label lines, the glyph area, the
/// margin on both sides), as [`super::axes::legend`] draws it at scale `k`.
pub(super) fn legend_size(labels: &[&str], k: u32) -> (f64, f64) {
    let font = font_of(16, k);
    let mut text = MultiLineText::<_, &str>::new((0, 0), font);
    for label in labels {
        text.push_line(*label);
    }
    let (w, h) = text.estimate_dimension().unwrap_or((0, 0));
    let margin = 12.0 * f64::from(k);
    (
        f64::from(w) + 40.0 * f64::from(k) + 2.0 * margin,
        f64::from(h) + 2.0 * margin,
    )
}

/// The finite points of (`x`, `y`) scaled to [0, 1]² by the axes' ranges `xr` and `yr`: a
/// run [`place`] tests.
pub(super) fn scaled(x: &[f64], y: &[f64], xr: (f64, f64), yr: (f64, f64)) -> Vec<(f64, f64)> {
    x.iter()
        .zip(y)
        .filter(|(_, y)| y.is_finite())
        .map(|(&x, &y)| ((x - xr.0) / (xr.1 - xr.0), (y - yr.0) / (yr.1 - yr.0)))
        .collect()
}

/// Where the legend goes, and by what factor the y range's span must grow for it.
#[derive(Clone, Debug)]
pub(super) struct Placement {
    /// The corner.
    pub(super) corner: SeriesLabelPosition,
    /// The factor (≥ 1) by which the span of the y axis grows upwards: 1 when a corner is
    /// free of data as the axes stand.
    pub(super) grow: f64,
}

/// A corner of the plot whose legend box (`size` in pixels, on a plot of `plot` pixels)
/// covers none of `curves` (each a run of points scaled to [0, 1]², joined in order), in the
/// order upper right, upper left, lower right, lower left; when every corner holds data, the
/// upper right with the y span grown until the band under the top edge is empty.
pub(super) fn place(curves: &[Vec<(f64, f64)>], size: (f64, f64), plot: (u32, u32)) -> Placement {
    let w = (size.0 + EDGE) / f64::from(plot.0.max(1)) + SLACK;
    let h = (size.1 + EDGE) / f64::from(plot.1.max(1)) + SLACK;
    let points = || {
        curves.iter().flat_map(|run| {
            let joined = run.windows(2).flat_map(|p| {
                let ((u0, v0), (u1, v1)) = (p[0], p[1]);
                (1..ON_SEGMENT).map(move |i| {
                    let t = i as f64 / ON_SEGMENT as f64;
                    (u0 + t * (u1 - u0), v0 + t * (v1 - v0))
                })
            });
            run.iter().copied().chain(joined)
        })
    };
    let corners = [
        (SeriesLabelPosition::UpperRight, true, true),
        (SeriesLabelPosition::UpperLeft, false, true),
        (SeriesLabelPosition::LowerRight, true, false),
        (SeriesLabelPosition::LowerLeft, false, false),
    ];
    for (corner, right, top) in corners {
        let inside = |(u, v): (f64, f64)| {
            let across = if right { u >= 1.0 - w } else { u <= w };
            let up = if top { v >= 1.0 - h } else { v <= h };
            across && up
        };
        if !points().any(inside) {
            return Placement { corner, grow: 1.0 };
        }
    }
    let highest = points().map(|(_, v)| v).fold(0.0, f64::max);
    Placement {
        corner: SeriesLabelPosition::UpperRight,
        grow: (highest / (1.0 - h - 0.01).max(0.2)).max(1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(f: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
        (0..50)
            .map(|i| {
                let u = f64::from(i) / 49.0;
                (u, f(u))
            })
            .collect()
    }

    #[test]
    fn a_free_corner_is_taken_as_the_axes_stand() {
        // A density peaked at the left edge: the upper right is free.
        let p = place(&[curve(|u| (-5.0 * u).exp())], (200.0, 100.0), (800, 600));
        assert!(matches!(p.corner, SeriesLabelPosition::UpperRight));
        assert_eq!(p.grow, 1.0);
        // A rising line: the upper left.
        let p = place(&[curve(|u| u)], (200.0, 100.0), (800, 600));
        assert!(matches!(p.corner, SeriesLabelPosition::UpperLeft));
    }

    #[test]
    fn a_segment_through_a_corner_occupies_it() {
        // Two points only, their segment crossing the upper-right box.
        let line = vec![(0.0, 0.0), (1.0, 1.0)];
        let p = place(&[line], (200.0, 100.0), (800, 600));
        assert!(matches!(p.corner, SeriesLabelPosition::UpperLeft));
    }

    #[test]
    fn a_peak_wide_enough_to_reach_every_corner_gets_room_above() {
        // A broad density on a zero baseline: both upper corners hold its shoulders, both
        // lower ones its tails.
        let broad = curve(|u| 0.98 * (-((u - 0.5) / 0.35).powi(2)).exp());
        let size = (300.0, 150.0);
        let p = place(std::slice::from_ref(&broad), size, (800, 600));
        assert!(matches!(p.corner, SeriesLabelPosition::UpperRight));
        assert!(p.grow > 1.0);
        // After growing, the upper right is free.
        let grown: Vec<(f64, f64)> = broad.iter().map(|&(u, v)| (u, v / p.grow)).collect();
        let again = place(&[grown], size, (800, 600));
        assert!(matches!(again.corner, SeriesLabelPosition::UpperRight));
        assert_eq!(again.grow, 1.0);
    }
}
