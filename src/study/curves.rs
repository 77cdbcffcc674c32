//! The PDF of each quantity under every solution of a study, on one grid per quantity, and
//! averaged over histogram bins for the comparisons.

use serde::Serialize;

use super::bin_means::bin_means;
use crate::density::JointDensity;
use crate::mc::Grid;
use crate::observe::{ObservableDensity, ObservableMap};
use crate::solve::{common_grid, printable, MethodName, Quantity, Solution};

/// Which solution a column holds: a method, and its degree for a ladder method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Source {
    /// The method.
    pub method: MethodName,
    /// The degree, for a method solved at degrees (`None` for the grid).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub degree: Option<usize>,
}

impl Source {
    /// The column name in CSV files: `epc_n4`, `epc_impact_n4`, `grid`.
    ///
    /// ```
    /// use fpsolve::solve::MethodName;
    /// use fpsolve::study::Source;
    /// assert_eq!(Source { method: MethodName::Epc, degree: Some(4) }.label(), "epc_n4");
    /// assert_eq!(Source { method: MethodName::EpcImpact, degree: Some(6) }.label(), "epc_impact_n6");
    /// assert_eq!(Source { method: MethodName::Grid, degree: None }.label(), "grid");
    /// ```
    pub fn label(&self) -> String {
        let name = self.method.as_str().replace('-', "_");
        match self.degree {
            Some(d) => format!("{name}_n{d}"),
            None => name,
        }
    }
}

impl std::fmt::Display for Source {
    /// As tables and legends say it: `EPC n = 4`, `EPC-impact n = 4`, `grid`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = self.method.method().title();
        match self.degree {
            Some(d) => write!(f, "{name} n = {d}"),
            None => f.write_str(name),
        }
    }
}

/// One solution's PDF column on a curve's grid.
#[derive(Clone, Debug, PartialEq)]
pub struct MethodColumn {
    /// The method (and degree) that produced it.
    pub source: Source,
    /// The PDF on the grid (NaN where it is infinite).
    pub pdf: Vec<f64>,
    /// The PDF averaged over each bin of [`PdfCurves::bins`] (4-point Gauss–Legendre on a
    /// smooth bin, an adaptive rule next to a value where the PDF is infinite), from the same
    /// prepared density as `pdf`; empty without bins.
    pub bin_means: Vec<f64>,
}

/// The histogram bins a study also averages each curve over (for comparing with Monte Carlo
/// or between methods), chosen from the quantity and its curve's grid; `None` for no bins.
pub type BinChoice<'a> = dyn Fn(&Quantity, &[f64]) -> Option<Grid> + Sync + 'a;

/// The PDF of one quantity on a grid, one column per solution.
#[derive(Clone, Debug, PartialEq)]
pub struct PdfCurves {
    /// The quantity's name.
    pub name: String,
    /// The grid.
    pub x: Vec<f64>,
    /// One column per solution, ladder methods first (in the order asked), the grid last.
    pub columns: Vec<MethodColumn>,
    /// The bins the columns' `bin_means` average over, if any were asked for.
    pub bins: Option<Grid>,
}

impl PdfCurves {
    /// The column of `source`, if that solution exists.
    pub fn column(&self, source: Source) -> Option<&MethodColumn> {
        self.columns.iter().find(|c| c.source == source)
    }
}

/// The curves of quantity `q` under every solution: one grid (the union of the windows where
/// each density is at least 1e−8 of its peak), each density prepared once for its grid values
/// and its bin means.
pub(super) fn curves(
    q: &Quantity,
    solved: &[(Source, &Solution)],
    bins: Option<&BinChoice>,
) -> PdfCurves {
    // Each solution maps `q` from its own states: EPC of an original-coordinates model
    // solves the Zhuravlev transform (y = |z| …), the grid and epc-impact the model as
    // written (y itself), so the same name has a different map under each.
    let densities: Vec<(Source, &dyn JointDensity, &ObservableMap, ObservableDensity)> = solved
        .iter()
        .map(|&(source, sol)| {
            let map = sol
                .quantities()
                .iter()
                .find(|own| own.name == q.name)
                .map_or(&q.map, |own| &own.map);
            (
                source,
                sol.joint(),
                map,
                ObservableDensity::new(sol.joint(), map),
            )
        })
        .collect();
    let windows: Vec<(&dyn JointDensity, &ObservableMap, &ObservableDensity)> =
        densities.iter().map(|(_, j, m, d)| (*j, *m, d)).collect();
    let x = common_grid(&windows);
    let bins = bins.and_then(|choose| choose(q, &x));
    let columns = if x.is_empty() && bins.is_none() {
        Vec::new()
    } else {
        densities
            .iter()
            .map(|(source, _, _, density)| MethodColumn {
                source: *source,
                pdf: if x.is_empty() {
                    Vec::new()
                } else {
                    printable(density.pdf(&x))
                },
                bin_means: bins
                    .as_ref()
                    .map_or_else(Vec::new, |g| bin_means(density, g)),
            })
            .collect()
    };
    PdfCurves {
        name: q.name.clone(),
        x,
        columns,
        bins,
    }
}
