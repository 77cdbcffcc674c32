//! Shaded bands between two edges (a 95 % interval, an estimated error): the band's data, the
//! polygons a panel shows of it, and its legend glyph.

use plotters::chart::SeriesAnno;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::error::{drawing_error, FigureError};

/// The opacity of a band's shade: light enough that the lines over it stay readable.
const SHADE: f64 = 0.22;

/// A shaded band between `lo` and `hi` over `x`, e.g. Monte Carlo's 95 % interval of a
/// curve. Drawn under the lines, in a light shade of the colour of curve `colour_of`.
///
/// ```
/// use fpsolve::report::{Band, Curve, PanelFigure};
///
/// let x = vec![0.0, 1.0, 2.0];
/// let r = vec![1.0, 0.6, 0.3];
/// let figure = PanelFigure {
///     title: "R(t)".into(),
///     subtitle: String::new(),
///     x_label: "t".into(),
///     y_label: "R(t)".into(),
///     curves: vec![Curve { label: "R".into(), x: x.clone(), y: r }],
///     // The band takes curve 0's colour; a NaN edge leaves a gap.
///     bands: vec![Band {
///         label: "95 %".into(),
///         x,
///         lo: vec![1.0, 0.5, f64::NAN],
///         hi: vec![1.0, 0.7, 0.4],
///         colour_of: 0,
///     }],
///     points: None,
///     y_bound: Some(1.0),
/// };
/// assert!(figure.render_svg()?.starts_with("<svg"));
/// # Ok::<(), fpsolve::report::FigureError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    /// Legend text; the band has no legend entry when it is empty.
    pub label: String,
    /// Abscissae, finite.
    pub x: Vec<f64>,
    /// The lower edge, as many as `x`; NaN leaves a gap, ±∞ is refused.
    pub lo: Vec<f64>,
    /// The upper edge, as many as `x`; NaN leaves a gap, ±∞ is refused.
    pub hi: Vec<f64>,
    /// The curve (its index among the figure's curves, see [`super::CurveStyle::of_curve`])
    /// whose colour the band takes.
    pub colour_of: usize,
}

/// The band's polygons within `[floor, ceiling]`: one per run of consecutive points where
/// both edges are numbers and the upper one reaches the floor, the edges clamped into the
/// range (on a log panel a band down to zero or below runs to the bottom axis, as an error
/// bar does), the upper edge forwards and the lower one back.
pub(super) fn polygons(band: &Band, floor: f64, ceiling: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut run: Vec<usize> = Vec::new();
    let mut finish = |run: &mut Vec<usize>| {
        if run.len() >= 2 {
            let upper = run.iter().map(|&i| (band.x[i], band.hi[i].min(ceiling)));
            let lower = run
                .iter()
                .rev()
                .map(|&i| (band.x[i], band.lo[i].max(floor)));
            out.push(upper.chain(lower).collect());
        }
        run.clear();
    };
    for i in 0..band.x.len() {
        let (lo, hi) = (band.lo[i], band.hi[i]);
        if lo.is_nan() || hi.is_nan() || hi < floor {
            finish(&mut run);
        } else {
            run.push(i);
        }
    }
    finish(&mut run);
    out
}

/// Draws the band's polygons within `[floor, ceiling]` in `colour`, lighter.
pub(super) fn draw<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, impl Ranged<ValueType = f64>>>,
    band: &Band,
    colour: RGBColor,
    (floor, ceiling): (f64, f64),
) -> Result<(), FigureError> {
    let style = colour.mix(SHADE).filled();
    chart
        .draw_series(
            polygons(band, floor, ceiling)
                .into_iter()
                .map(|p| Polygon::new(p, style)),
        )
        .map_err(drawing_error)?;
    Ok(())
}

/// Gives `anno` a band's legend glyph: a short shaded box in `colour`.
pub(super) fn legend<'a, DB: DrawingBackend + 'a>(
    anno: &mut SeriesAnno<'a, DB>,
    colour: RGBColor,
    k: u32,
) {
    let (k, style) = (k as i32, colour.mix(SHADE).filled());
    anno.legend(move |(x, y)| Rectangle::new([(x, y - 6 * k), (x + 28 * k, y + 6 * k)], style));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn band(lo: Vec<f64>, hi: Vec<f64>) -> Band {
        Band {
            label: String::new(),
            x: (0..lo.len()).map(|i| i as f64).collect(),
            lo,
            hi,
            colour_of: 0,
        }
    }

    #[test]
    fn a_band_is_cut_at_gaps_and_below_the_floor_and_clamped() {
        let nan = f64::NAN;
        let b = band(
            vec![0.5, 0.0, 0.2, nan, 0.1, 1e-9, 1e-9],
            vec![1.5, 0.8, 0.6, 0.5, 0.4, 0.3, 1e-6],
        );
        // Linear panel: only the NaN splits; the lone point after it makes no polygon.
        let lin = polygons(&b, f64::NEG_INFINITY, f64::INFINITY);
        assert_eq!(
            lin,
            vec![
                vec![
                    (0.0, 1.5),
                    (1.0, 0.8),
                    (2.0, 0.6),
                    (2.0, 0.2),
                    (1.0, 0.0),
                    (0.0, 0.5)
                ],
                vec![
                    (4.0, 0.4),
                    (5.0, 0.3),
                    (6.0, 1e-6),
                    (6.0, 1e-9),
                    (5.0, 1e-9),
                    (4.0, 0.1)
                ],
            ]
        );
        // Log panel from 1e-3 to 1: the edges clamped, the last point (its top below the
        // floor) left out.
        let log = polygons(&b, 1e-3, 1.0);
        assert_eq!(log[0][0], (0.0, 1.0));
        assert_eq!(log[0][4], (1.0, 1e-3));
        assert_eq!(
            log[1],
            vec![(4.0, 0.4), (5.0, 0.3), (5.0, 1e-3), (4.0, 0.1)]
        );
    }
}
