//! Figures: a PDF comparison (linear and log panels side by side, like the comparison figures of
//! the EPC papers), the same two panels for any quantity with shaded bands (R(t) with its
//! confidence band), and a plain line chart for moments against a swept parameter. Part of the
//! report stage, drawn from plain data: each renders to PNG and SVG with the bundled font and
//! is written through [`OutputDir`].

use plotters::chart::SeriesAnno;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::font::{self, font_of};
use super::{OutputDir, ReportError};

/// A line: one method's density (or one moment) sampled at `x`. A NaN in `y` leaves a gap.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// Legend text.
    pub label: String,
    /// Abscissae, finite.
    pub x: Vec<f64>,
    /// Ordinates, as many as `x`; NaN marks a missing value, ±∞ is refused.
    pub y: Vec<f64>,
}

/// Markers with vertical error bars, e.g. a Monte Carlo histogram: bars span `y ± stderr`.
#[derive(Clone, Debug, PartialEq)]
pub struct Points {
    /// Legend text.
    pub label: String,
    /// Abscissae (bin centres), finite.
    pub x: Vec<f64>,
    /// Values, as many as `x`; NaN marks a missing value.
    pub y: Vec<f64>,
    /// Standard errors, as many as `x`, each ≥ 0; NaN draws no bar.
    pub stderr: Vec<f64>,
}

/// A comparison of densities of one variable: approximate solutions as lines, a reference
/// (Monte Carlo) as points with error bars. Rendered as two panels side by side: linear scale
/// (the bulk of the distribution) and log scale (the tails, down to 1e-8 of the peak).
///
/// ```no_run
/// use fpsolve::report::{Curve, OutputDir, PdfFigure, Points};
///
/// let x: Vec<f64> = (0..=200).map(|i| -4.0 + 0.04 * f64::from(i)).collect();
/// let gauss = |x: f64| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
/// let figure = PdfFigure {
///     title: "Duffing oscillator, PDF of displacement".into(),
///     subtitle: "c = 0.1, K = 0.1592".into(),
///     variable_label: "y".into(),
///     curves: vec![Curve { label: "exact".into(), x: x.clone(), y: x.iter().map(|&v| gauss(v)).collect() }],
///     points: Some(Points {
///         label: "Monte Carlo".into(),
///         x: vec![-1.0, 0.0, 1.0],
///         y: vec![0.24, 0.40, 0.24],
///         stderr: vec![0.01, 0.01, 0.01],
///     }),
/// };
/// let files = figure.write(&OutputDir::create("out")?, "pdf_y")?;
/// println!("{} {}", files.png.display(), files.svg.display());
/// # Ok::<(), fpsolve::report::ReportError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct PdfFigure {
    /// Title above both panels.
    pub title: String,
    /// A smaller line under the title (the model's parameters); none when empty.
    pub subtitle: String,
    /// Name of the variable on the horizontal axis, e.g. `y` or `dy/dt`.
    pub variable_label: String,
    /// Densities drawn as lines, each with its own colour and dash pattern.
    pub curves: Vec<Curve>,
    /// A reference drawn as markers with error bars.
    pub points: Option<Points>,
}

/// A line chart of several series against one parameter, e.g. moments of the response against
/// the noise intensity.
///
/// ```no_run
/// use fpsolve::report::{Curve, LineFigure, OutputDir};
///
/// let figure = LineFigure {
///     title: "Mean square displacement".into(),
///     x_label: "K".into(),
///     y_label: "E[y²]".into(),
///     series: vec![Curve { label: "EPC n=4".into(), x: vec![0.1, 0.2, 0.4], y: vec![0.05, 0.09, 0.15] }],
/// };
/// figure.write(&OutputDir::create("out")?, "msd_vs_k")?;
/// # Ok::<(), fpsolve::report::ReportError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct LineFigure {
    /// Title above the chart.
    pub title: String,
    /// Horizontal axis label.
    pub x_label: String,
    /// Vertical axis label.
    pub y_label: String,
    /// The series, each drawn with markers and a line in its own colour and dash pattern.
    pub series: Vec<Curve>,
}

/// Any quantity against one variable on two panels side by side, linear and log scale, as
/// [`PdfFigure`] draws a density: lines, shaded [`Band`]s under them (an interval, an
/// estimated error) and points with error bars. The log panel leaves out values at or below
/// zero.
///
/// ```no_run
/// use fpsolve::report::{Band, Curve, OutputDir, PanelFigure};
///
/// let t: Vec<f64> = (0..=50).map(|i| 0.2 * f64::from(i)).collect();
/// let r: Vec<f64> = t.iter().map(|t| (-0.5 * t).exp()).collect();
/// let figure = PanelFigure {
///     title: "Reliability".into(),
///     subtitle: String::new(),
///     x_label: "t".into(),
///     y_label: "R(t)".into(),
///     curves: vec![Curve { label: "R".into(), x: t.clone(), y: r.clone() }],
///     bands: vec![Band {
///         label: "R ± 5 %".into(),
///         x: t,
///         lo: r.iter().map(|r| 0.95 * r).collect(),
///         hi: r.iter().map(|r| 1.05 * r).collect(),
///         colour_of: 0,
///     }],
///     points: None,
///     y_bound: Some(1.0),
/// };
/// figure.write(&OutputDir::create("out")?, "reliability")?;
/// # Ok::<(), fpsolve::report::ReportError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct PanelFigure {
    /// Title above both panels.
    pub title: String,
    /// A smaller line under the title; none when empty.
    pub subtitle: String,
    /// The horizontal axis' label.
    pub x_label: String,
    /// The vertical axes' label.
    pub y_label: String,
    /// Lines, each with its own colour and dash pattern.
    pub curves: Vec<Curve>,
    /// Shaded bands, drawn under the lines.
    pub bands: Vec<Band>,
    /// Points with error bars.
    pub points: Option<Points>,
    /// The largest value the quantity can take, if it has one (1 for a probability): the
    /// log panel then ends at its decade rather than at the decade above the data.
    pub y_bound: Option<f64>,
}

/// What the two panels draw, borrowed from a [`PdfFigure`] or a [`PanelFigure`].
struct Panels<'a> {
    title: &'a str,
    subtitle: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    curves: &'a [Curve],
    bands: &'a [Band],
    points: Option<&'a Points>,
    y_bound: Option<f64>,
}

const PDF_SIZE: (u32, u32) = (1500, 620);
const LINE_SIZE: (u32, u32) = (900, 600);

/// Colour-blind-safe colours (Okabe & Ito), in the order curves get them.
const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
];

/// Dash patterns as (dash, gap) in pixels; `None` is solid. Cycled at a different period from
/// the palette so that curves stay distinguishable in greyscale print too.
const DASHES: [Option<(u32, u32)>; 4] = [None, Some((12, 6)), Some((3, 4)), Some((18, 5))];

const REFERENCE_COLOUR: RGBColor = RGBColor(20, 20, 20);
const STROKE: u32 = 2;

fn check_series(
    label: &str,
    x: &[f64],
    y: &[f64],
    stderr: Option<&[f64]>,
) -> Result<(), FigureError> {
    let length = |field, v: &[f64]| {
        if v.len() == x.len() {
            Ok(())
        } else {
            Err(FigureError::LengthMismatch {
                series: label.to_string(),
                field,
                expected: x.len(),
                found: v.len(),
            })
        }
    };
    length("y", y)?;
    if let Some(se) = stderr {
        length("stderr", se)?;
    }
    if let Some((index, &value)) = x.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(FigureError::NonFiniteX {
            series: label.to_string(),
            index,
            value,
        });
    }
    let bad =
        |field, v: &[f64], ok: fn(f64) -> bool| match v.iter().enumerate().find(|(_, &v)| !ok(v)) {
            Some((index, &value)) => Err(FigureError::BadValue {
                series: label.to_string(),
                field,
                index,
                value,
            }),
            None => Ok(()),
        };
    bad("y", y, |v| !v.is_infinite())?;
    if let Some(se) = stderr {
        bad("stderr", se, |v| v.is_nan() || (v >= 0.0 && v.is_finite()))?;
    }
    Ok(())
}

/// Splits a polyline into the runs that lie at or above `floor`, dropping NaN points. A segment
/// that crosses the floor is cut where the straight line between its ends meets it, so a curve
/// on the log panel ends exactly on the bottom axis instead of stopping short or leaking below.
fn visible_runs(x: &[f64], y: &[f64], floor: f64) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    let mut finish = |run: &mut Vec<(f64, f64)>| {
        if run.len() >= 2 {
            runs.push(std::mem::take(run));
        } else {
            run.clear();
        }
    };
    for i in 0..x.len() {
        let (xi, yi) = (x[i], y[i]);
        if yi.is_nan() {
            finish(&mut run);
            continue;
        }
        let above = yi >= floor;
        match (i.checked_sub(1).map(|j| (x[j], y[j])), above) {
            (Some((xp, yp)), _) if !yp.is_nan() && (yp >= floor) != above => {
                let t = (floor - yp) / (yi - yp);
                let cross = (xp + t * (xi - xp), floor);
                if above {
                    run.push(cross);
                    run.push((xi, yi));
                } else {
                    run.push(cross);
                    finish(&mut run);
                }
            }
            (_, true) => run.push((xi, yi)),
            (_, false) => {}
        }
    }
    finish(&mut run);
    runs
}

/// (min, max) of the finite values, if any.
fn finite_range<'a>(values: impl IntoIterator<Item = &'a f64>) -> Option<(f64, f64)> {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, &v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// `(lo, hi)` when an axis can run over it: a finite span (plotters' tick search never
/// ends on an infinite one).
fn spanned(axis: &'static str, (lo, hi): (f64, f64)) -> Result<(f64, f64), FigureError> {
    if (hi - lo).is_finite() {
        Ok((lo, hi))
    } else {
        Err(FigureError::Span { axis, lo, hi })
    }
}

/// Widens a degenerate range so that the axis has a span.
fn padded(lo: f64, hi: f64, fraction: f64) -> (f64, f64) {
    if hi > lo {
        let pad = fraction * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let pad = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        (lo - pad, hi + pad)
    }
}

/// How the `i`-th curve of a figure is drawn: its colour, dash pattern and line width.
///
/// Every curve of a figure gets its own (colour, dash) pair, up to the 24 pairs of 6 colours
/// and 4 dash patterns (13 is the most a density figure draws: 6 degrees of 2 ladder methods
/// and the grid); beyond that the line gets wider with each further round, so no two curves of
/// one figure are ever drawn alike.
///
/// ```
/// use fpsolve::report::CurveStyle;
/// let styles: Vec<CurveStyle> = (0..24).map(CurveStyle::of_curve).collect();
/// for (i, a) in styles.iter().enumerate() {
///     assert!(styles[..i].iter().all(|b| (a.colour, a.dash) != (b.colour, b.dash)));
/// }
/// assert_ne!(CurveStyle::of_curve(24), CurveStyle::of_curve(0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CurveStyle {
    /// The colour, as red, green, blue.
    pub colour: [u8; 3],
    /// The dash pattern as (dash, gap) in pixels; `None` is solid.
    pub dash: Option<(u32, u32)>,
    /// The line width in pixels.
    pub width: u32,
}

impl CurveStyle {
    /// The style of the `i`-th curve (from 0). The colour runs fastest; each round through
    /// the palette shifts the dash patterns by one more place (6 ≡ 2 mod 4, so shifting by
    /// the round alone would repeat a pair after 12 curves), and each round through all 24
    /// pairs widens the line.
    pub fn of_curve(i: usize) -> CurveStyle {
        let round = i / PALETTE.len();
        let RGBColor(r, g, b) = PALETTE[i % PALETTE.len()];
        CurveStyle {
            colour: [r, g, b],
            dash: DASHES[(i + round) % DASHES.len()],
            width: STROKE + (i / (PALETTE.len() * DASHES.len())) as u32,
        }
    }
}

/// Line style and legend glyph of the `i`-th curve.
#[derive(Clone, Copy)]
struct Pen {
    colour: RGBColor,
    dash: Option<(u32, u32)>,
    width: u32,
    /// Supersampling factor: every length in pixels is multiplied by it.
    k: u32,
}

impl Pen {
    fn nth(i: usize, k: u32) -> Self {
        let style = CurveStyle::of_curve(i);
        let [r, g, b] = style.colour;
        Self {
            colour: RGBColor(r, g, b),
            dash: style.dash,
            width: style.width,
            k,
        }
    }

    fn style(self) -> ShapeStyle {
        self.colour.stroke_width(self.width * self.k)
    }

    fn draw<'a, DB: DrawingBackend + 'a>(
        self,
        chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, impl Ranged<ValueType = f64>>>,
        run: Vec<(f64, f64)>,
    ) -> Result<(), FigureError> {
        match self.dash {
            None => chart
                .draw_series(LineSeries::new(run, self.style()))
                .map(|_| ()),
            Some((dash, gap)) => chart
                .draw_series(DashedLineSeries::new(
                    run,
                    dash * self.k,
                    gap * self.k,
                    self.style(),
                ))
                .map(|_| ()),
        }
        .map_err(drawing_error)
    }

    /// Gives `anno` this pen's legend glyph: a short line sample in the curve's style.
    fn legend<'a, DB: DrawingBackend + 'a>(self, anno: &mut SeriesAnno<'a, DB>) {
        let style = self.style();
        let (k, len) = (self.k, 28 * self.k as i32);
        match self.dash {
            None => anno.legend(move |(x, y)| PathElement::new(vec![(x, y), (x + len, y)], style)),
            // Shorter dashes in the legend so that a full period fits in the sample.
            Some((dash, gap)) => anno.legend(move |(x, y)| {
                DashedPathElement::new(
                    vec![(x, y), (x + len, y)],
                    dash.min(8) * k,
                    gap.min(4) * k,
                    style,
                )
            }),
        };
    }
}

/// Gives `anno` the reference's legend glyph: a marker with an error bar.
fn reference_legend<'a, DB: DrawingBackend + 'a>(anno: &mut SeriesAnno<'a, DB>, k: u32) {
    let ki = k as i32;
    anno.legend(move |(x, y)| {
        EmptyElement::at((x + 14 * ki, y))
            + Circle::new((0, 0), 3 * k, REFERENCE_COLOUR.filled())
            + PathElement::new(
                vec![(0, -7 * ki), (0, 7 * ki)],
                REFERENCE_COLOUR.stroke_width(k),
            )
    });
}

/// Draws markers with error bars; bars are cut at `[floor, ceiling]` (on the log panel a bar
/// reaching zero or below runs to the bottom axis, meaning "consistent with zero").
fn draw_points<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, impl Ranged<ValueType = f64>>>,
    points: &Points,
    floor: f64,
    ceiling: f64,
    k: u32,
) -> Result<(), FigureError> {
    let visible = || {
        points
            .x
            .iter()
            .zip(&points.y)
            .zip(&points.stderr)
            .filter(move |((_, &y), _)| y.is_finite() && y >= floor)
    };
    let bar_style = REFERENCE_COLOUR.mix(0.75).stroke_width(k);
    chart
        .draw_series(
            visible()
                .filter(|(_, se)| se.is_finite() && **se > 0.0)
                .map(|((&x, &y), &se)| {
                    let lo = (y - se).max(floor);
                    let hi = (y + se).min(ceiling);
                    PathElement::new(vec![(x, lo), (x, hi)], bar_style)
                }),
        )
        .map_err(drawing_error)?;
    chart
        .draw_series(
            visible().map(|((&x, &y), _)| Circle::new((x, y), 3 * k, REFERENCE_COLOUR.filled())),
        )
        .map_err(drawing_error)?;
    Ok(())
}

impl Panels<'_> {
    fn check(&self) -> Result<(), FigureError> {
        for c in self.curves {
            check_series(&c.label, &c.x, &c.y, None)?;
        }
        for b in self.bands {
            check_series(&b.label, &b.x, &b.lo, None)?;
            check_series(&b.label, &b.x, &b.hi, None)?;
        }
        if let Some(p) = self.points {
            check_series(&p.label, &p.x, &p.y, Some(&p.stderr))?;
        }
        Ok(())
    }

    fn all_x(&self) -> impl Iterator<Item = &f64> {
        self.curves
            .iter()
            .flat_map(|c| &c.x)
            .chain(self.bands.iter().flat_map(|b| &b.x))
            .chain(self.points.iter().flat_map(|p| &p.x))
    }

    /// Every value the y axes must show: curve values, band edges and the tops of error
    /// bars.
    fn all_y(&self) -> impl Iterator<Item = f64> + '_ {
        let tops = self.points.iter().flat_map(|p| {
            p.y.iter()
                .zip(&p.stderr)
                .map(|(&y, &se)| if se.is_finite() { y + se } else { y })
        });
        self.curves
            .iter()
            .flat_map(|c| c.y.iter().copied())
            .chain(
                self.bands
                    .iter()
                    .flat_map(|b| b.lo.iter().chain(&b.hi).copied()),
            )
            .chain(self.points.iter().flat_map(|p| p.y.iter().copied()))
            .chain(tops)
    }

    fn draw<'b, DB: DrawingBackend + 'b>(
        &self,
        root: DrawingArea<DB, Shift>,
        k: u32,
    ) -> Result<(), FigureError> {
        self.check()?;
        if !font::register() {
            return Err(FigureError::Font);
        }
        let (x_lo, x_hi) = finite_range(self.all_x()).ok_or(FigureError::NoData)?;
        let y_values: Vec<f64> = self.all_y().filter(|v| v.is_finite()).collect();
        let (y_min, y_max) = finite_range(&y_values).ok_or(FigureError::NoData)?;
        if y_max <= 0.0 {
            return Err(FigureError::NoPositiveValues);
        }
        let (x_lo, x_hi) = spanned(
            "x",
            if x_hi > x_lo {
                (x_lo, x_hi)
            } else {
                padded(x_lo, x_hi, 0.0)
            },
        )?;
        let lin_lo = y_min.min(0.0);
        // Log panel, whole decades: from above the peak down to the smallest positive value
        // shown, but not much below 1e-8 of the peak. Eight decades show every tail a Monte
        // Carlo run can resolve; more would squeeze the part where methods differ.
        let smallest = y_values
            .iter()
            .copied()
            .filter(|&v| v > 0.0)
            .fold(f64::INFINITY, f64::min);
        let log_bottom = 10f64.powf(smallest.max(y_max * 1e-8).log10().floor());
        // Up to the decade above the peak, or that of the quantity's bound if lower (R ≤ 1
        // reaches 1: the decade above it would be empty).
        let above_peak = 10f64.powf((y_max * 1.1).log10().ceil());
        let log_top = match self.y_bound.map(|b| 10f64.powf(b.log10().ceil())) {
            Some(top) if top > log_bottom => top.min(above_peak),
            _ => above_peak,
        };

        root.fill(&WHITE).map_err(drawing_error)?;
        // The title sits below a small top margin: plotters places glyphs from the font's
        // nominal height, which lets tall capitals touch the image edge.
        let body = root
            .margin(8 * k, 0, 0, 0)
            .titled(self.title, font_of(26, k).color(&BLACK))
            .map_err(drawing_error)?;
        let body = if self.subtitle.is_empty() {
            body
        } else {
            body.titled(self.subtitle, font_of(17, k).color(&BLACK))
                .map_err(drawing_error)?
        };
        let panels = body.split_evenly((1, 2));

        // Linear panel, with the legend where it covers no data: the plot's size from a
        // chart laid out on the panel (laying out draws nothing), then the y range grown
        // above the data if no corner is free.
        let lin_area = panels[0]
            .titled("linear scale", font_of(19, k))
            .map_err(drawing_error)?;
        let lin_chart = |top: f64| {
            ChartBuilder::on(&lin_area)
                .margin(12 * k)
                .margin_right(24 * k)
                .x_label_area_size(52 * k)
                .y_label_area_size(78 * k)
                .build_cartesian_2d(x_lo..x_hi, lin_lo..top)
                .map_err(drawing_error)
        };
        let top = spanned("y", (lin_lo, y_max * 1.08))?.1;
        let plot = lin_chart(top)?.plotting_area().dim_in_pixel();
        let mut labels: Vec<&str> = self.curves.iter().map(|c| c.label.as_str()).collect();
        labels.extend(self.band_labels().map(|(_, label)| label));
        labels.extend(self.points.iter().map(|p| p.label.as_str()));
        let scaled = |x: &[f64], y: &[f64]| place::scaled(x, y, (x_lo, x_hi), (lin_lo, top));
        let mut runs: Vec<Vec<(f64, f64)>> =
            self.curves.iter().map(|c| scaled(&c.x, &c.y)).collect();
        for b in self.bands {
            runs.push(scaled(&b.x, &b.hi));
            runs.push(scaled(&b.x, &b.lo));
        }
        // Monte Carlo's points and the tops of their error bars, each on its own.
        if let Some(p) = self.points {
            let tops: Vec<f64> =
                p.y.iter()
                    .zip(&p.stderr)
                    .map(|(y, se)| y + se.max(0.0))
                    .collect();
            runs.extend(scaled(&p.x, &p.y).into_iter().map(|q| vec![q]));
            runs.extend(scaled(&p.x, &tops).into_iter().map(|q| vec![q]));
        }
        let placement = place::place(&runs, place::legend_size(&labels, k), plot);
        let lin_y = spanned("y", (lin_lo, lin_lo + (top - lin_lo) * placement.grow))?;
        let mut lin = lin_chart(lin_y.1)?;
        mesh(&mut lin, self.x_label, self.y_label, false, k)?;
        // Bands under the lines; their legend entries after the lines'.
        for b in self.bands {
            band::draw(
                &mut lin,
                b,
                Pen::nth(b.colour_of, k).colour,
                (f64::NEG_INFINITY, f64::INFINITY),
            )?;
        }
        for (i, curve) in self.curves.iter().enumerate() {
            let pen = Pen::nth(i, k);
            for run in visible_runs(&curve.x, &curve.y, f64::NEG_INFINITY) {
                pen.draw(&mut lin, run)?;
            }
            let anno = lin
                .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
                .map_err(drawing_error)?
                .label(curve.label.as_str());
            pen.legend(anno);
        }
        for (colour_of, label) in self.band_labels() {
            let anno = lin
                .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
                .map_err(drawing_error)?
                .label(label);
            band::legend(anno, Pen::nth(colour_of, k).colour, k);
        }
        if let Some(points) = self.points {
            draw_points(&mut lin, points, f64::NEG_INFINITY, f64::INFINITY, k)?;
            let anno = lin
                .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
                .map_err(drawing_error)?
                .label(points.label.as_str());
            reference_legend(anno, k);
        }
        legend(&mut lin, placement.corner, k)?;

        // Log panel.
        let mut log = ChartBuilder::on(&panels[1])
            .caption("log scale", font_of(19, k))
            .margin(12 * k)
            .margin_right(24 * k)
            .x_label_area_size(52 * k)
            .y_label_area_size(78 * k)
            .build_cartesian_2d(x_lo..x_hi, (log_bottom..log_top).log_scale())
            .map_err(drawing_error)?;
        log_minor_grid(&mut log, (x_lo, x_hi), (log_bottom, log_top), k)?;
        mesh(&mut log, self.x_label, self.y_label, true, k)?;
        for b in self.bands {
            band::draw(
                &mut log,
                b,
                Pen::nth(b.colour_of, k).colour,
                (log_bottom, log_top),
            )?;
        }
        for (i, curve) in self.curves.iter().enumerate() {
            let pen = Pen::nth(i, k);
            // Values above a bound's decade (a rounding over R = 1) run along the top axis
            // rather than over it; NaN stays a gap.
            let y: Vec<f64> = curve
                .y
                .iter()
                .map(|&v| if v > log_top { log_top } else { v })
                .collect();
            for run in visible_runs(&curve.x, &y, log_bottom) {
                pen.draw(&mut log, run)?;
            }
        }
        if let Some(points) = self.points {
            draw_points(&mut log, points, log_bottom, log_top, k)?;
        }
        root.present().map_err(drawing_error)
    }

    /// The bands that have a legend entry: the curve whose colour each takes, its label.
    fn band_labels(&self) -> impl Iterator<Item = (usize, &str)> + '_ {
        self.bands
            .iter()
            .filter(|b| !b.label.is_empty())
            .map(|b| (b.colour_of, b.label.as_str()))
    }
}

impl PdfFigure {
    fn draw<'b, DB: DrawingBackend + 'b>(
        &self,
        root: DrawingArea<DB, Shift>,
        k: u32,
    ) -> Result<(), FigureError> {
        Panels {
            title: &self.title,
            subtitle: &self.subtitle,
            x_label: &self.variable_label,
            y_label: "probability density",
            curves: &self.curves,
            bands: &[],
            points: self.points.as_ref(),
            y_bound: None,
        }
        .draw(root, k)
    }

    /// The figure as PNG bytes.
    ///
    /// # Errors
    /// A [`FigureError`] for invalid data (mismatched lengths, non-finite abscissae, infinite
    /// values, negative standard errors, nothing positive to show) or a drawing failure.
    pub fn render_png(&self) -> Result<Vec<u8>, FigureError> {
        render_png(PDF_SIZE, |root, k| self.draw(root, k))
    }

    /// The figure as SVG text.
    ///
    /// # Errors
    /// As [`render_png`](Self::render_png).
    pub fn render_svg(&self) -> Result<String, FigureError> {
        render_svg(PDF_SIZE, |root, k| self.draw(root, k))
    }

    /// Writes `<stem>.png` and `<stem>.svg` into `dir`, each atomically.
    ///
    /// # Errors
    /// [`ReportError::Figure`] naming the file, or as [`OutputDir::write_atomic`].
    pub fn write(&self, dir: &OutputDir, stem: &str) -> Result<FigureFiles, ReportError> {
        write_both(dir, stem, || self.render_png(), || self.render_svg())
    }
}

impl PanelFigure {
    fn draw<'b, DB: DrawingBackend + 'b>(
        &self,
        root: DrawingArea<DB, Shift>,
        k: u32,
    ) -> Result<(), FigureError> {
        Panels {
            title: &self.title,
            subtitle: &self.subtitle,
            x_label: &self.x_label,
            y_label: &self.y_label,
            curves: &self.curves,
            bands: &self.bands,
            points: self.points.as_ref(),
            y_bound: self.y_bound,
        }
        .draw(root, k)
    }

    /// The figure as PNG bytes.
    ///
    /// # Errors
    /// As [`PdfFigure::render_png`]; a band's edges are checked as a curve's values.
    pub fn render_png(&self) -> Result<Vec<u8>, FigureError> {
        render_png(PDF_SIZE, |root, k| self.draw(root, k))
    }

    /// The figure as SVG text.
    ///
    /// # Errors
    /// As [`render_png`](Self::render_png).
    pub fn render_svg(&self) -> Result<String, FigureError> {
        render_svg(PDF_SIZE, |root, k| self.draw(root, k))
    }

    /// Writes `<stem>.png` and `<stem>.svg` into `dir`, each atomically.
    ///
    /// # Errors
    /// [`ReportError::Figure`] naming the file, or as [`OutputDir::write_atomic`].
    pub fn write(&self, dir: &OutputDir, stem: &str) -> Result<FigureFiles, ReportError> {
        write_both(dir, stem, || self.render_png(), || self.render_svg())
    }
}

impl LineFigure {
    fn draw<'b, DB: DrawingBackend + 'b>(
        &self,
        root: DrawingArea<DB, Shift>,
        k: u32,
    ) -> Result<(), FigureError> {
        for s in &self.series {
            check_series(&s.label, &s.x, &s.y, None)?;
        }
        if !font::register() {
            return Err(FigureError::Font);
        }
        let (x_lo, x_hi) =
            finite_range(self.series.iter().flat_map(|s| &s.x)).ok_or(FigureError::NoData)?;
        let (y_lo, y_hi) =
            finite_range(self.series.iter().flat_map(|s| &s.y)).ok_or(FigureError::NoData)?;
        let (x_lo, x_hi) = spanned("x", padded(x_lo, x_hi, 0.03))?;
        let (y_lo, y_hi) = spanned("y", padded(y_lo, y_hi, 0.06))?;

        root.fill(&WHITE).map_err(drawing_error)?;
        let area = root
            .titled(&self.title, font_of(24, k))
            .map_err(drawing_error)?;
        let chart_to = |top: f64| {
            ChartBuilder::on(&area)
                .margin(14 * k)
                .margin_right(28 * k)
                .x_label_area_size(52 * k)
                .y_label_area_size(86 * k)
                .build_cartesian_2d(x_lo..x_hi, y_lo..top)
                .map_err(drawing_error)
        };
        // The legend where it covers no data (see the PDF figure).
        let plot = chart_to(y_hi)?.plotting_area().dim_in_pixel();
        let labels: Vec<&str> = self.series.iter().map(|s| s.label.as_str()).collect();
        let runs: Vec<Vec<(f64, f64)>> = self
            .series
            .iter()
            .map(|s| place::scaled(&s.x, &s.y, (x_lo, x_hi), (y_lo, y_hi)))
            .collect();
        let placement = place::place(&runs, place::legend_size(&labels, k), plot);
        let (_, y_hi) = spanned("y", (y_lo, y_lo + (y_hi - y_lo) * placement.grow))?;
        let mut chart = chart_to(y_hi)?;
        mesh(&mut chart, &self.x_label, &self.y_label, false, k)?;
        for (i, s) in self.series.iter().enumerate() {
            let pen = Pen::nth(i, k);
            for run in visible_runs(&s.x, &s.y, f64::NEG_INFINITY) {
                pen.draw(&mut chart, run)?;
            }
            let anno = chart
                .draw_series(
                    s.x.iter()
                        .zip(&s.y)
                        .filter(|(_, y)| y.is_finite())
                        .map(|(&x, &y)| Circle::new((x, y), 4 * k, pen.colour.filled())),
                )
                .map_err(drawing_error)?
                .label(s.label.as_str());
            pen.legend(anno);
        }
        legend(&mut chart, placement.corner, k)?;
        root.present().map_err(drawing_error)
    }

    /// The chart as PNG bytes.
    ///
    /// # Errors
    /// A [`FigureError`] for invalid data (mismatched lengths, non-finite abscissae, infinite
    /// values, no finite value at all) or a drawing failure.
    pub fn render_png(&self) -> Result<Vec<u8>, FigureError> {
        render_png(LINE_SIZE, |root, k| self.draw(root, k))
    }

    /// The chart as SVG text.
    ///
    /// # Errors
    /// As [`render_png`](Self::render_png).
    pub fn render_svg(&self) -> Result<String, FigureError> {
        render_svg(LINE_SIZE, |root, k| self.draw(root, k))
    }

    /// Writes `<stem>.png` and `<stem>.svg` into `dir`, each atomically.
    ///
    /// # Errors
    /// [`ReportError::Figure`] naming the file, or as [`OutputDir::write_atomic`].
    pub fn write(&self, dir: &OutputDir, stem: &str) -> Result<FigureFiles, ReportError> {
        write_both(dir, stem, || self.render_png(), || self.render_svg())
    }
}

mod axes;
mod band;
pub(super) mod error;
mod place;
pub(super) mod render;
#[cfg(test)]
mod tests;

use axes::{legend, log_minor_grid, mesh};
pub use band::Band;
use error::{drawing_error, FigureError};
use render::{render_png, render_svg, write_both, FigureFiles};
