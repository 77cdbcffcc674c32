//! The figure of one crossing table, `crossings_<q>.png/.svg`: the mean up-crossing rate
//! ν⁺(u) over the levels on a linear and a log panel, each method's curve as a line (the
//! grid's estimated error as a band in its colour, absent where the table states no bound),
//! Monte Carlo's counts as points with their standard errors.

use super::CrossingTable;
use crate::report::{Band, Curve, PanelFigure, Points};

/// The figure of `table`, titled with the model's name `model`, `subtitle` under it.
pub(super) fn crossing_figure(model: &str, subtitle: &str, table: &CrossingTable) -> PanelFigure {
    let (mut curves, mut bands) = (Vec::new(), Vec::new());
    for (label, curve) in &table.curves {
        if let Some(errors) = curve.error() {
            let edge = |sign: f64| -> Vec<f64> {
                curve
                    .rate
                    .iter()
                    .zip(&errors)
                    .map(|(r, e)| r + sign * e)
                    .collect()
            };
            bands.push(Band {
                label: format!("{label} ± estimated error"),
                x: curve.levels.clone(),
                lo: edge(-1.0),
                hi: edge(1.0),
                colour_of: curves.len(),
            });
        }
        curves.push(Curve {
            label: label.clone(),
            x: curve.levels.clone(),
            y: curve.rate.clone(),
        });
    }
    let points = table.mc.as_ref().map(|m| Points {
        label: "Monte Carlo (± 1 standard error)".into(),
        x: m.levels.clone(),
        y: m.rate.iter().map(|e| e.value).collect(),
        stderr: m.rate.iter().map(|e| e.stderr).collect(),
    });
    PanelFigure {
        title: format!(
            "{model}: mean up-crossing rate of {} (Rice)",
            table.quantity
        ),
        subtitle: subtitle.to_string(),
        x_label: format!("level u of {}", table.quantity),
        y_label: "ν⁺(u), crossings per unit time".into(),
        curves,
        bands,
        points,
        y_bound: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::CrossingCurve;

    /// The grid's error becomes a band in its curve's colour; a level without a bound leaves
    /// a gap; the figure renders.
    #[test]
    fn a_crossing_figure_draws_the_error_as_a_band() {
        let curve = CrossingCurve {
            quantity: "z".into(),
            levels: vec![-1.0, 0.0, 1.0],
            rate: vec![0.1, 0.2, 0.1],
            accuracy: 0.0,
            discretisation: None,
        }
        .with_discretisation(vec![0.01, 0.02, f64::NAN]);
        let table = CrossingTable {
            quantity: "z".into(),
            text: String::new(),
            curves: vec![("grid".into(), curve)],
            mc: None,
        };
        let f = crossing_figure("m", "", &table);
        assert_eq!(f.bands.len(), 1);
        assert_eq!(f.bands[0].colour_of, 0);
        assert!((f.bands[0].hi[1] - 0.22).abs() < 1e-12 && f.bands[0].lo[2].is_nan());
        assert!(f.render_svg().unwrap().starts_with("<svg"));
    }
}
