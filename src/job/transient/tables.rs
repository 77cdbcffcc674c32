//! The transient's tables: the moments of every quantity at each output
//! (`moments_vs_t.csv`) and each state's marginal in long format (`pdf_<state>_t.csv`), as
//! named columns, so that a front end that wants arrays gets the numbers the files hold.

use std::fmt::Write as _;

use super::TransientRun;
use crate::model::BoundModel;

/// Named columns of equal length: one CSV file, a row per line.
///
/// ```
/// use fpsolve::job::transient::Columns;
/// let c = Columns { names: vec!["t".into(), "x".into()], values: vec![vec![0.0, 0.5], vec![1.0, -2.0]] };
/// assert_eq!(c.csv(), "t,x\n0,1\n0.5,-2\n");
/// assert_eq!(c.column("x"), Some(&[1.0, -2.0][..]));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Columns {
    /// The header.
    pub names: Vec<String>,
    /// One vector per name, each as long as the others.
    pub values: Vec<Vec<f64>>,
}

impl Columns {
    fn new() -> Columns {
        Columns {
            names: Vec::new(),
            values: Vec::new(),
        }
    }

    fn push(&mut self, name: String, values: Vec<f64>) {
        self.names.push(name);
        self.values.push(values);
    }

    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let k = self.names.iter().position(|n| n == name)?;
        Some(&self.values[k])
    }

    /// The CSV text: the names, then each row, numbers in Rust's shortest round-trip form.
    pub fn csv(&self) -> String {
        let mut csv = self.names.join(",");
        csv.push('\n');
        let rows = self.values.first().map_or(0, Vec::len);
        for r in 0..rows {
            for (k, column) in self.values.iter().enumerate() {
                if k > 0 {
                    csv.push(',');
                }
                let _ = write!(csv, "{}", column[r]);
            }
            csv.push('\n');
        }
        csv
    }
}

impl TransientRun {
    /// `moments_vs_t.csv`: `t`; with the grid, each state's then each observable's
    /// `_mean`, `_variance`, `_kurtosis` (and their estimated errors `_mean_err`, … when the
    /// grid estimated them); with Monte Carlo, each state's `_mean_mc`, `_mean_mc_se`,
    /// `_variance_mc`, … (value and standard error).
    pub fn moments(&self, model: &BoundModel) -> Columns {
        let mut out = Columns::new();
        out.push("t".into(), self.times());
        if let Some(g) = &self.grid {
            let names = model
                .states()
                .iter()
                .map(|s| s.to_string())
                .chain(model.observables().iter().map(|o| o.name.to_string()));
            let errors = g.report.estimate_cells.is_some();
            for (q, name) in names.enumerate() {
                let at = |s: &crate::grid::Snapshot| {
                    let m = s.moments.iter().chain(&s.observables).nth(q);
                    m.map_or([f64::NAN; 3], |m| [m.mean, m.variance, m.kurtosis])
                };
                let err = |s: &crate::grid::Snapshot| {
                    let e = s.estimate.as_ref();
                    let m = e.and_then(|e| e.moments.iter().chain(&e.observables).nth(q));
                    m.map_or([f64::NAN; 3], |m| [m.mean, m.variance, m.kurtosis])
                };
                let values: Vec<[f64; 3]> = g.snapshots.iter().map(at).collect();
                let errs: Vec<[f64; 3]> = g.snapshots.iter().map(err).collect();
                for (i, m) in MOMENTS.iter().enumerate() {
                    out.push(format!("{name}_{m}"), values.iter().map(|v| v[i]).collect());
                }
                if errors {
                    for (i, m) in MOMENTS.iter().enumerate() {
                        out.push(
                            format!("{name}_{m}_err"),
                            errs.iter().map(|v| v[i]).collect(),
                        );
                    }
                }
            }
        }
        if let Some(mc) = &self.mc {
            for (a, q) in model.states().iter().enumerate() {
                for (i, m) in MOMENTS.iter().enumerate() {
                    let e = |s: &crate::mc::McSnapshot| {
                        let m = &s.moments[a];
                        [m.mean, m.variance, m.kurtosis][i]
                    };
                    out.push(
                        format!("{q}_{m}_mc"),
                        mc.snapshots.iter().map(|s| e(s).value).collect(),
                    );
                    out.push(
                        format!("{q}_{m}_mc_se"),
                        mc.snapshots.iter().map(|s| e(s).stderr).collect(),
                    );
                }
            }
        }
        out
    }

    /// `pdf_<state>_t.csv` of state `axis` (0 or 1), long format: `t`, `x` (the cell
    /// centres at each output time in turn), the grid's cell averages `grid`, Monte Carlo's
    /// histogram on the same bins `mc` with its standard error `mc_se`.
    pub fn pdf(&self, axis: usize) -> Columns {
        let mut t = Vec::new();
        let mut x = Vec::new();
        let (mut grid, mut mc, mut mc_se) = (Vec::new(), Vec::new(), Vec::new());
        for (k, time) in self.times().iter().enumerate() {
            let g = self.grid.as_ref().map(|g| &g.snapshots[k].marginals[axis]);
            let m = self
                .mc
                .as_ref()
                .and_then(|m| m.snapshots[k].densities.as_ref())
                .map(|d| &d[axis]);
            let centres = match (g, m) {
                (Some(g), _) => g.centres.clone(),
                (None, Some(m)) => m.grid.centers(),
                (None, None) => Vec::new(),
            };
            t.extend(std::iter::repeat_n(*time, centres.len()));
            if let Some(g) = g {
                grid.extend_from_slice(&g.density);
            }
            if let Some(m) = m {
                mc.extend_from_slice(&m.density);
                mc_se.extend_from_slice(&m.stderr);
            }
            x.extend(centres);
        }
        let mut out = Columns::new();
        out.push("t".into(), t);
        out.push("x".into(), x);
        if self.grid.is_some() {
            out.push("grid".into(), grid);
        }
        if self.mc.is_some() {
            out.push("mc".into(), mc);
            out.push("mc_se".into(), mc_se);
        }
        out
    }
}

/// The moments of every column, in their order.
const MOMENTS: [&str; 3] = ["mean", "variance", "kurtosis"];
