//! Distances between two densities of one quantity on histogram bins: a method against Monte
//! Carlo, or a method against the grid solver. One routine for every pair.

use serde::Serialize;

use crate::mc::Grid;
use crate::study::{GridRun, PdfCurves, Source};

/// What a method is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Reference {
    /// The Monte Carlo histogram (run by the job or read with `--mc-from`).
    Mc,
    /// The grid solver's density averaged over the same bins.
    Grid,
}

impl std::fmt::Display for Reference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Reference::Mc => "MC",
            Reference::Grid => "grid",
        })
    }
}

/// The distance between one method (at one degree) and a reference for one quantity, on the
/// histogram's bins: both densities are averaged over each bin (as a histogram is), never
/// taken at the bin centre.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    /// The quantity.
    pub quantity: String,
    /// The method and its degree.
    #[serde(flatten)]
    pub source: Source,
    /// What it is compared with.
    pub reference: Reference,
    /// The bins' range [lo, hi]: the distances say nothing about values outside it.
    pub range: [f64; 2],
    /// L1 = Σ_bins |p̄_method − p̄_reference|·width.
    pub l1: f64,
    /// The worst log-ratio where the reference exceeds 1e−3 of its peak.
    pub ratio_1e3: LogRatio,
    /// The worst log-ratio where the reference exceeds 1e−5 of its peak.
    pub ratio_1e5: LogRatio,
}

/// max |log10(p̄_method / p̄_reference)| over the bins where the reference exceeds a level,
/// and the bins there where the method's density is exactly 0 (EPC cut beyond its ridge, the
/// grid outside its domain), where the ratio has no finite value and is not counted in the
/// maximum.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LogRatio {
    /// The maximum over the bins where p̄_method > 0 (`None` if there is no such bin).
    pub max_abs_log10: Option<f64>,
    /// Bins above the level (where the reference is positive).
    pub bins: usize,
    /// Bins above the level where p̄_method = 0.
    pub bins_epc_zero: usize,
}

impl std::fmt::Display for LogRatio {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.max_abs_log10 {
            Some(m) => write!(f, "{m:.3}")?,
            None => f.write_str("undefined")?,
        }
        if self.bins_epc_zero > 0 {
            write!(
                f,
                " (EPC is 0 in {} of {} bins: beyond its ridge)",
                self.bins_epc_zero, self.bins
            )?;
        }
        Ok(())
    }
}

/// L1 distance and the worst log-ratios between a method's bin averages and a reference's,
/// on `grid`'s bins.
pub(crate) fn compare(
    quantity: &str,
    source: Source,
    reference: Reference,
    method: &[f64],
    against: &[f64],
    grid: &Grid,
) -> Comparison {
    let l1 = method
        .iter()
        .zip(against)
        .map(|(a, b)| (a - b).abs())
        .sum::<f64>()
        * grid.width();
    let peak = against.iter().copied().fold(0.0, f64::max);
    let worst = |level: f64| {
        let mut r = LogRatio {
            max_abs_log10: None,
            bins: 0,
            bins_epc_zero: 0,
        };
        for (e, m) in method.iter().zip(against) {
            if !(*m > level * peak && *m > 0.0) {
                continue;
            }
            r.bins += 1;
            if *e > 0.0 {
                let v = (e / m).log10().abs();
                r.max_abs_log10 = Some(r.max_abs_log10.map_or(v, |w: f64| w.max(v)));
            } else {
                r.bins_epc_zero += 1;
            }
        }
        r
    };
    Comparison {
        quantity: quantity.to_string(),
        source,
        reference,
        range: [grid.lo, grid.hi],
        l1,
        ratio_1e3: worst(1e-3),
        ratio_1e5: worst(1e-5),
    }
}

/// The L1 distance two methods that both claim success may be apart beyond their stated
/// errors. L1 = 1 means that the two densities share only half their probability mass
/// (∫ min(p, q) = 1 − L1/2): no approximation that converged explains that. At the default
/// settings the converged EPC degrees of the bundled models are at most 0.68 from the grid
/// (degree 2, a Gaussian, against the two wells of `bistable_duffing`; degree 4 there: 3.4e−3);
/// the δ-term EPC with a barrier far from the bulk is 1.96 from it.
pub const DISAGREEMENT_L1: f64 = 1.0;

/// Two methods that both claim success and whose densities of one quantity are further apart
/// than [`DISAGREEMENT_L1`] plus the reference's own estimated error: at least one of them is
/// wrong, and the run is flagged.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Disagreement {
    /// The quantity.
    pub quantity: String,
    /// The method and its degree.
    #[serde(flatten)]
    pub source: Source,
    /// What it was compared with.
    pub reference: Reference,
    /// Their L1 distance on the comparison's bins.
    pub l1: f64,
    /// The reference's own estimated L1 error: the grid's discretisation estimate (the larger
    /// of its position and velocity marginals'), Monte Carlo's Σ stderr·width over the bins.
    pub reference_error: f64,
    /// The largest distance their errors allow: [`DISAGREEMENT_L1`] + `reference_error`.
    pub allowed: f64,
}

impl std::fmt::Display for Disagreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} and {} disagree on {}: L1 = {:.4}, more than the {:.4} their errors allow \
             ({DISAGREEMENT_L1} + the {}'s estimated error {:.1e}); both claim success, so one \
             of them is wrong",
            self.source,
            self.reference,
            self.quantity,
            self.l1,
            self.allowed,
            self.reference,
            self.reference_error
        )
    }
}

/// The comparisons that are disagreements. `reference_error` gives the reference's own
/// estimated L1 error on a comparison's bins, `None` when the reference does not claim
/// success (a Monte Carlo run whose verdict failed): then nothing is judged against it. A
/// distance that is not a number is a disagreement too.
pub(crate) fn disagreements(
    comparisons: &[Comparison],
    reference_error: impl Fn(&Comparison) -> Option<f64>,
) -> Vec<Disagreement> {
    comparisons
        .iter()
        .filter_map(|c| {
            let error = reference_error(c)?;
            let allowed = DISAGREEMENT_L1 + error;
            (c.l1.is_nan() || c.l1 > allowed).then(|| Disagreement {
                quantity: c.quantity.clone(),
                source: c.source,
                reference: c.reference,
                l1: c.l1,
                reference_error: error,
                allowed,
            })
        })
        .collect()
}

/// Every method of a curve against the grid's column on the curve's bins (none without bins
/// or without a grid column).
pub(crate) fn against_grid(curve: &PdfCurves) -> Vec<Comparison> {
    let (Some(bins), Some(grid)) = (curve.bins.as_ref(), curve.column(GridRun::SOURCE)) else {
        return Vec::new();
    };
    if grid.bin_means.len() != bins.bins {
        return Vec::new();
    }
    curve
        .columns
        .iter()
        .filter(|c| c.source != GridRun::SOURCE && c.bin_means.len() == bins.bins)
        .map(|c| {
            compare(
                &curve.name,
                c.source,
                Reference::Grid,
                &c.bin_means,
                &grid.bin_means,
                bins,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::MethodName;

    #[test]
    fn distances_of_two_step_densities() {
        let grid = Grid::new(0.0, 4.0, 4).unwrap();
        let source = Source {
            method: MethodName::Grid,
            degree: None,
        };
        // Reference 0.4, 0.3, 0.2, 0.1; method 0.4, 0.15, 0.2, 0 (0 where the reference is
        // positive: counted apart).
        let c = compare(
            "y",
            source,
            Reference::Mc,
            &[0.4, 0.15, 0.2, 0.0],
            &[0.4, 0.3, 0.2, 0.1],
            &grid,
        );
        assert!((c.l1 - 0.25).abs() < 1e-15);
        assert_eq!(c.range, [0.0, 4.0]);
        let r = c.ratio_1e3;
        assert_eq!((r.bins, r.bins_epc_zero), (4, 1));
        assert!((r.max_abs_log10.unwrap() - 2f64.log10()).abs() < 1e-15);
    }

    #[test]
    fn a_distance_beyond_the_tolerance_and_the_references_error_disagrees() {
        let grid = Grid::new(0.0, 4.0, 4).unwrap();
        let source = Source {
            method: MethodName::Epc,
            degree: Some(4),
        };
        // Disjoint supports: L1 = 2 (the largest possible); half the mass moved: L1 = 1.
        let apart = compare(
            "y",
            source,
            Reference::Grid,
            &[0.5, 0.5, 0.0, 0.0],
            &[0.0, 0.0, 0.5, 0.5],
            &grid,
        );
        let half = compare(
            "y",
            source,
            Reference::Grid,
            &[0.5, 0.0, 0.0, 0.5],
            &[0.0, 0.0, 0.5, 0.5],
            &grid,
        );
        let near = compare(
            "y",
            source,
            Reference::Mc,
            &[0.0, 0.1, 0.4, 0.5],
            &[0.0, 0.0, 0.5, 0.5],
            &grid,
        );
        let all = [apart.clone(), half.clone(), near];
        let found = disagreements(&all, |_| Some(0.01));
        assert_eq!(found.len(), 1);
        assert_eq!((found[0].l1, found[0].allowed), (2.0, 1.01));
        assert_eq!(found[0].reference, Reference::Grid);
        // Half the mass moved, with an exact reference: at the tolerance, not beyond it.
        assert_eq!(
            disagreements(std::slice::from_ref(&half), |_| Some(0.0)).len(),
            0
        );
        // A reference that does not claim success judges nothing.
        assert!(disagreements(&all, |_| None).is_empty());
        // A distance that is not a number is flagged.
        let nan = Comparison {
            l1: f64::NAN,
            ..half
        };
        assert_eq!(disagreements(&[nan], |_| Some(0.0)).len(), 1);
    }
}
