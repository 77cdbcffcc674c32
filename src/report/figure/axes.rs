//! Axes, tick labels, grids and legends of the figures.

use super::error::{drawing_error, FigureError};
use crate::report::font::font_of;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// Axes, tick labels and grid. On a log axis the minor grid is drawn by [`log_minor_grid`]
/// instead, because plotters spaces light lines evenly in pixels, not at 2·10ᵏ … 9·10ᵏ.
pub(super) fn mesh<
    'a,
    DB: DrawingBackend + 'a,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
    x_label: &str,
    y_label: &str,
    log_y: bool,
    k: u32,
) -> Result<(), FigureError> {
    let decades = |v: &f64| decade_label(*v);
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_label)
        .y_desc(y_label)
        .label_style(font_of(15, k))
        .axis_desc_style(font_of(18, k))
        .bold_line_style(RGBColor(205, 205, 205))
        .light_line_style(RGBColor(240, 240, 240))
        .axis_style(BLACK.stroke_width(k))
        .x_labels(9)
        .y_labels(10)
        .x_max_light_lines(2)
        .y_max_light_lines(if log_y { 0 } else { 2 });
    mesh.x_label_formatter(&linear_tick);
    if log_y {
        mesh.y_label_formatter(&decades);
    } else {
        mesh.y_label_formatter(&linear_tick);
    }
    mesh.draw().map_err(drawing_error)
}

/// A linear-axis tick label: rounded to 9 decimals so that a tick computed as −1e−17 reads
/// `0`, not `-0.0`, and 0.30000000000000004 reads `0.3`.
pub(super) fn linear_tick(v: &f64) -> String {
    let r = (v * 1e9).round() / 1e9;
    if r == 0.0 {
        "0".to_string()
    } else {
        format!("{r}")
    }
}

/// Light horizontal lines at m·10ᵏ, m = 2…9, inside `[bottom, top]`.
pub(super) fn log_minor_grid<'a, DB: DrawingBackend + 'a, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
    (x_lo, x_hi): (f64, f64),
    (bottom, top): (f64, f64),
    k: u32,
) -> Result<(), FigureError> {
    let first = bottom.log10().floor() as i32;
    let last = top.log10().ceil() as i32;
    let levels = (first..last)
        .flat_map(|k| (2..10).map(move |m| f64::from(m) * 10f64.powi(k)))
        .filter(|&v| v > bottom && v < top);
    chart
        .draw_series(levels.map(|v| {
            PathElement::new(
                vec![(x_lo, v), (x_hi, v)],
                RGBColor(242, 242, 242).stroke_width(k),
            )
        }))
        .map_err(drawing_error)?;
    Ok(())
}

pub(super) fn legend<'a, DB: DrawingBackend + 'a, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
    position: SeriesLabelPosition,
    k: u32,
) -> Result<(), FigureError> {
    chart
        .configure_series_labels()
        .position(position)
        .margin(12 * k)
        .legend_area_size(40 * k)
        .label_font(font_of(16, k))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.5))
        .draw()
        .map_err(drawing_error)
}

/// `10⁻³` for exact decades, scientific notation otherwise.
pub(super) fn decade_label(v: f64) -> String {
    let e = v.log10();
    if (e - e.round()).abs() > 1e-6 {
        return format!("{v:.0e}");
    }
    let digits: String = format!("{}", e.round() as i64)
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹']
                [d.to_digit(10).unwrap_or(0) as usize],
        })
        .collect();
    format!("10{digits}")
}
