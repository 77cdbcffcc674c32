//! First passage as `fpsolve reliability` (alias `fpsolve passage`) and Python's
//! `Model.reliability` (alias `Model.passage`) run it: the grid and Monte Carlo solved in one
//! order (R(t) at the times given, else at [`DEFAULT_TIMES`] to Monte Carlo's horizon or
//! [`DEFAULT_MEANS`] grid mean times; Monte Carlo on the grid's times, its horizon 20 grid
//! mean times unless given), the
//! stationary crossing and impact statistics beside them (`stationary`), and everything the
//! two front ends report from them — `reliability.csv`, `first_passage_pdf.csv`,
//! `crossings_<q>.csv`, `summary.json` with the methods' distances, the warnings — written
//! once, so the two give the same numbers and words; the command line also draws the figures
//! ([`PassageRun::write_figures`]) and writes the stationary tables
//! ([`PassageRun::write_stationary`]). Each front end checks its own flags or keywords before
//! calling [`PassageRun::solve`].

mod distance;
mod figures;
mod stationary;

use serde::Serialize;

use crate::grid::{Domain, GridPassage, PassageError, PassageSolution};
use crate::job::{ReliabilitySummary, Unwritten};
use crate::mc::{McError, McPassage, McPassageResult};
use crate::model::{BoundModel, BoundSafe, Provenance};
use crate::report::{short_number, OutputDir};

pub use distance::{Compared, MethodDistance, MethodDistances};
pub use figures::PassageFigures;
pub use stationary::{StationaryMc, StationaryReport, StationaryStatistics};

/// How many Monte Carlo standard errors, beyond the grid's estimated error, the grid's and
/// Monte Carlo's first-passage numbers (the mean time from the start, R(t) at each output
/// time) may be apart before a warning ([`MethodDistance::flagged`]).
pub const DISAGREE_SE: f64 = 3.0;

/// How many output times R(t) gets when none are given ([`PassageSettings::times`] empty).
pub const DEFAULT_TIMES: usize = 101;

/// Where R(t) ends when no output times and no Monte Carlo horizon are given: this many of
/// the grid's mean times from the start (R is then about e^{−5}, the first-passage PDF's
/// tail resolved; issue 35's reference horizon).
pub const DEFAULT_MEANS: f64 = 5.0;

/// Why a `X,V` or `FIRST:LAST:COUNT` text could not be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TextError {
    /// Not the shape asked.
    #[error("`{text}`: expected {expected}")]
    Shape {
        /// The text.
        text: String,
        /// The shape (`X,V`, `FIRST:LAST:COUNT`).
        expected: &'static str,
    },
    /// A part that is not a number.
    #[error("`{0}` is not a number")]
    NotNumber(String),
    /// A number that is not finite.
    #[error("`{0}` is not finite")]
    NotFinite(String),
    /// A count that is not a whole number.
    #[error("`{0}` is not a count")]
    NotCount(String),
    /// Times out of range.
    #[error("`{0}`: expected 0 <= FIRST < LAST, finite, and 2 <= COUNT <= 100000")]
    TimesRange(String),
}

/// A point `X,V` (`--start`).
///
/// # Errors
/// [`TextError`] for another shape or a part that is not a finite number.
///
/// ```
/// use fpsolve::job::passage::parse_pair;
/// assert_eq!(parse_pair("1e-6, 0").unwrap(), [1e-6, 0.0]);
/// assert!(parse_pair("1,2,3").is_err() && parse_pair("inf,0").is_err());
/// ```
pub fn parse_pair(s: &str) -> Result<[f64; 2], TextError> {
    let num = |t: &str| -> Result<f64, TextError> {
        let v: f64 = t
            .trim()
            .parse()
            .map_err(|_| TextError::NotNumber(t.to_string()))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(TextError::NotFinite(t.to_string()))
        }
    };
    match s.split(',').collect::<Vec<_>>().as_slice() {
        [x, v] => Ok([num(x)?, num(v)?]),
        _ => Err(TextError::Shape {
            text: s.to_string(),
            expected: "X,V",
        }),
    }
}

/// Times `FIRST:LAST:COUNT`, evenly spaced (`--times` of `reliability` and `transient`).
///
/// # Errors
/// [`TextError`] for another shape, parts that are not numbers, or times out of range.
///
/// ```
/// use fpsolve::job::passage::parse_times;
/// assert_eq!(parse_times("0:2:3").unwrap(), [0.0, 1.0, 2.0]);
/// assert!(parse_times("2:1:3").is_err() && parse_times("0:1").is_err());
/// ```
pub fn parse_times(s: &str) -> Result<Vec<f64>, TextError> {
    let parts: Vec<&str> = s.split(':').collect();
    let [a, b, n] = parts.as_slice() else {
        return Err(TextError::Shape {
            text: s.to_string(),
            expected: "FIRST:LAST:COUNT",
        });
    };
    let number = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| TextError::NotNumber(t.to_string()))
    };
    let (a, b) = (number(a)?, number(b)?);
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| TextError::NotCount(n.to_string()))?;
    if !(a.is_finite() && b.is_finite() && a >= 0.0 && a < b && (2..=100_000).contains(&n)) {
        return Err(TextError::TimesRange(s.to_string()));
    }
    Ok((0..n)
        .map(|k| a + (b - a) * k as f64 / (n - 1) as f64)
        .collect())
}

/// What a passage run computes ([`PassageSettings::scope`]; `scope` in `summary.json`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PassageScope {
    /// The mean times, R(t) with the first-passage-time density, the slowest decay and the
    /// stationary statistics (crossing rates, impacts).
    #[default]
    Full,
    /// The mean first-passage times only: E\[T\] and E\[T²\] from the start and from the
    /// stationary density in the set on the grid, with their estimated errors (the solve on
    /// half the cells); Monte Carlo's mean and variance of T. Everything else is listed in
    /// `not_computed` ([`PassageRun::not_computed`]).
    MeanTimes,
}

/// A part of a reliability run that was not computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PassagePart {
    /// R(t) at output times, by every method that ran, with the first-passage-time density
    /// (the grid's −R′(t), Monte Carlo's histogram) and their figures.
    Reliability,
    /// The grid's slowest decay (λ, the amplitude A) and the quasi-stationary density.
    Decay,
    /// The stationary crossing rates and impact statistics, with their stationary Monte
    /// Carlo.
    StationaryStatistics,
}

impl std::fmt::Display for PassagePart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PassagePart::Reliability => "R(t) and the first-passage-time density",
            PassagePart::Decay => "the slowest decay and the quasi-stationary density",
            PassagePart::StationaryStatistics => {
                "the stationary crossing rates and impact statistics"
            }
        })
    }
}

/// Why a part of a reliability run was not computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, thiserror::Error)]
#[serde(rename_all = "snake_case")]
pub enum NotComputedWhy {
    /// The run asked for the mean times only ([`PassageScope::MeanTimes`]).
    #[error("the run asked for the mean first-passage times only")]
    MeanTimesOnly,
}

/// A part of a reliability run not computed, and why (`not_computed` in `summary.json`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct NotComputed {
    /// The part.
    pub what: PassagePart,
    /// Why.
    pub why: NotComputedWhy,
}

/// The Monte Carlo's settings, checked by the front end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct McSettings {
    /// Paths.
    pub paths: u64,
    /// Time step.
    pub dt: f64,
    /// Horizon; `None`: 20 times the grid's mean time from the start.
    pub horizon: Option<f64>,
    /// Seed.
    pub seed: u64,
}

impl McSettings {
    /// Every setting checked before any work, for a run from `start` (a placeholder horizon
    /// when it is to come from the grid's mean time).
    ///
    /// # Errors
    /// The [`McError`] naming the setting.
    pub fn check(
        &self,
        bound: &BoundModel,
        safe: &BoundSafe,
        start: [f64; 2],
    ) -> Result<(), McError> {
        McPassage::new(bound, safe)
            .paths(self.paths)
            .dt(self.dt)
            .horizon(self.horizon.unwrap_or(1.0))
            .seed(self.seed)
            .start(start)
            .check()
    }
}

/// What [`PassageRun::solve`] solves, each setting checked by the front end.
#[derive(Clone, Debug, PartialEq)]
pub struct PassageSettings {
    /// The start (x, v).
    pub start: [f64; 2],
    /// The output times of R(t); empty: [`DEFAULT_TIMES`] evenly spaced times from 0 to
    /// Monte Carlo's horizon when it is given, else to [`DEFAULT_MEANS`] times the grid's
    /// mean time from the start ([`PassageSettings::output_times`]); none with
    /// [`PassageScope::MeanTimes`] (the front ends refuse times with it).
    pub times: Vec<f64>,
    /// The grid's cells (x, v).
    pub cells: [usize; 2],
    /// The grid's box; `None` sizes it from the stationary density (a model without one
    /// needs it).
    pub domain: Option<Domain>,
    /// Whether the grid runs.
    pub grid: bool,
    /// Monte Carlo's settings, when it runs.
    pub mc: Option<McSettings>,
    /// What the run computes.
    pub scope: PassageScope,
}

impl PassageSettings {
    /// The output times of R(t): [`PassageSettings::times`] when given, else
    /// [`DEFAULT_TIMES`] evenly spaced from 0 to Monte Carlo's horizon when given, else to
    /// [`DEFAULT_MEANS`] times `mean` (the grid's mean time from the start); `None` when
    /// neither is known (Monte Carlo alone without a horizon, which the front ends refuse).
    /// With [`PassageScope::MeanTimes`], none.
    ///
    /// ```
    /// use fpsolve::job::passage::{McSettings, PassageSettings};
    /// use fpsolve::job::passage::PassageScope;
    /// let mut s = PassageSettings {
    ///     start: [0.0, 0.0], times: vec![], cells: [20, 20], domain: None, grid: true, mc: None,
    ///     scope: PassageScope::Full,
    /// };
    /// let t = s.output_times(Some(2.0)).unwrap();
    /// assert_eq!((t.len(), t[0], t[100]), (101, 0.0, 10.0));
    /// s.mc = Some(McSettings { paths: 100, dt: 0.01, horizon: Some(4.0), seed: 1 });
    /// assert_eq!(s.output_times(Some(2.0)).unwrap()[100], 4.0);
    /// s.times = vec![1.0, 3.0];
    /// assert_eq!(s.output_times(None).unwrap(), [1.0, 3.0]);
    /// ```
    pub fn output_times(&self, mean: Option<f64>) -> Option<Vec<f64>> {
        if self.scope == PassageScope::MeanTimes {
            return Some(Vec::new());
        }
        if !self.times.is_empty() {
            return Some(self.times.clone());
        }
        let end = self
            .mc
            .and_then(|m| m.horizon)
            .or_else(|| mean.map(|m| DEFAULT_MEANS * m))?;
        crate::grid::evenly_spaced(end, DEFAULT_TIMES)
    }

    /// The grid's problem of `bound` and `safe` with these settings (without its output
    /// times; without the slowest decay for [`PassageScope::MeanTimes`]): what the front
    /// ends check before any work ([`GridPassage::check`]).
    pub fn grid_passage<'a>(&self, bound: &'a BoundModel, safe: &'a BoundSafe) -> GridPassage<'a> {
        let p = GridPassage::new(bound, safe)
            .cells(self.cells[0], self.cells[1])
            .start(self.start)
            .decay(self.scope == PassageScope::Full);
        match self.domain {
            Some(d) => p.domain(d),
            None => p,
        }
    }
}

/// Which solve failed.
#[derive(Debug, thiserror::Error)]
pub enum PassageRunError {
    /// The grid's.
    #[error(transparent)]
    Grid(#[from] PassageError),
    /// Monte Carlo's.
    #[error(transparent)]
    Mc(#[from] McError),
}

/// A warning about a finished run, as both front ends word it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PassageWarning {
    /// Monte Carlo paths that blew up.
    #[error("{0} Monte Carlo paths blew up and are left out")]
    Blowups(u64),
    /// A number (the mean time from the start, R(t) at an output time) by the grid and by
    /// Monte Carlo further apart than [`DISAGREE_SE`] of Monte Carlo's standard errors plus
    /// the grid's stated error.
    #[error(
        "the grid's {compared} is {gap:.3e} from Monte Carlo's, more than {DISAGREE_SE} \
         standard errors ({stderr:.2e}) plus the grid's estimated error ({stated:.2e}): \
         compare finer cells, and Monte Carlo at a smaller dt"
    )]
    Disagree {
        /// The number.
        compared: Compared,
        /// |MC − grid|.
        gap: f64,
        /// Monte Carlo's standard error.
        stderr: f64,
        /// The grid's stated error.
        stated: f64,
    },
    /// The stationary Monte Carlo beside the crossing tables gave no result, or one whose
    /// verdict fails.
    #[error("the stationary Monte Carlo (crossing counts, impacts): {0}")]
    StationaryMc(String),
}

/// The grid's and Monte Carlo's solutions of one first-passage problem, and the stationary
/// statistics beside them.
#[derive(Clone, Debug)]
pub struct PassageRun {
    /// The grid's, when it ran.
    pub grid: Option<PassageSolution>,
    /// Monte Carlo's, when it ran.
    pub mc: Option<McPassageResult>,
    /// The stationary crossing and impact statistics, or why they were not computed (the
    /// grid not run, a model without a stationary density, a failed solve, the mean times
    /// only); `None` only where a caller built the run by hand.
    pub stationary: Option<StationaryStatistics>,
    /// What the run computed.
    pub scope: PassageScope,
}

/// `summary.json` of a passage run.
#[derive(Serialize)]
pub struct PassageSummary<'a> {
    /// Where it came from (version, schema, time, threads, the model's name, file and text),
    /// first in the file as in every result file.
    pub provenance: Provenance,
    /// The version that wrote it.
    pub fpsolve: &'static str,
    /// The command (the CLI's command line, or the Python call).
    pub command: String,
    /// The model's name.
    pub model: &'a str,
    /// The model's file (empty for a model without one).
    pub model_file: String,
    /// The safe set as written.
    pub safe: &'a str,
    /// The start.
    pub start: [f64; 2],
    /// What the run computed: `full`, or `mean_times` (the mean first-passage times only).
    pub scope: PassageScope,
    /// The parts of the run not computed, each with why (`what`, `why`); absent when none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub not_computed: Vec<NotComputed>,
    /// The grid's solution.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid: Option<&'a PassageSolution>,
    /// Monte Carlo's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mc: Option<&'a McPassageResult>,
    /// (Monte Carlo mean − grid mean) / the Monte Carlo's standard error; null when paths were
    /// censored (the Monte Carlo mean is then only a lower bound); absent without both.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid_vs_mc_se: Option<Option<f64>>,
    /// |grid − MC| / (MC's standard error + the grid's stated error) of the mean time from
    /// the start and of R(t) at each output time, with the worst; absent without both.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub method_distances: Option<MethodDistances>,
    /// How the stationary statistics were computed, or why not; absent without the grid.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stationary: Option<&'a StationaryReport>,
    /// The crossing tables (`crossings`), the quantities without one (`no_crossings`) and
    /// the walls' impact statistics (`impacts`), as the main job lists them.
    #[serde(flatten)]
    pub reliability: ReliabilitySummary,
    /// The figures that could not be drawn, each with why (the command line's, from
    /// [`PassageRun::write_figures`]); absent from the file when there is none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub unwritten: Vec<Unwritten>,
}

impl PassageRun {
    /// Solves as `settings` say: on the grid (on its cells, in its box when given) and by
    /// Monte Carlo, from the start, R(t) at the output times; Monte Carlo on the grid's
    /// output times when the grid ran, to the horizon given or 20 grid mean times. With the
    /// grid, the stationary statistics too ([`StationaryStatistics`]: a grid study on the
    /// same cells and box, and the stationary Monte Carlo at the same dt and seed when Monte
    /// Carlo runs). Each solve runs on the current rayon pool.
    ///
    /// # Errors
    /// The failing first-passage solve's error (the stationary statistics' failure is kept in
    /// them).
    ///
    /// # Panics
    /// When Monte Carlo runs alone without a horizon (the front ends refuse that first).
    pub fn solve(
        bound: &BoundModel,
        safe: &BoundSafe,
        settings: &PassageSettings,
    ) -> Result<PassageRun, PassageRunError> {
        // The stationary statistics beside the first passage's grid solves (the two share
        // nothing; on two cores the passage's solve on half the cells leaves room).
        let mean_times_only = settings.scope == PassageScope::MeanTimes;
        let (grid, stationary) = rayon::join(
            || {
                settings.grid.then(|| {
                    let passage = settings.grid_passage(bound, safe);
                    match settings.output_times(None) {
                        Some(times) => passage.times(times),
                        // R(t) to DEFAULT_MEANS of the grid's mean time, which the passage's
                        // one solve of the mean times sets.
                        None => passage.times_in_means(DEFAULT_MEANS, DEFAULT_TIMES),
                    }
                    .run()
                })
            },
            || {
                Some(if settings.grid && mean_times_only {
                    StationaryStatistics::not_computed(NotComputedWhy::MeanTimesOnly.to_string())
                } else if settings.grid {
                    let mc = settings.mc.map(|m| (m.dt, m.seed));
                    StationaryStatistics::solve(bound, settings.domain, settings.cells, mc)
                } else {
                    // Said, not silently absent: Monte Carlo's counts go beside the grid's
                    // tables, on the levels of its curves.
                    StationaryStatistics::not_computed(
                        "the crossing rates and impact statistics are computed from a grid \
                         study, with Monte Carlo's counts beside it: run with --method grid,mc \
                         (or grid)",
                    )
                })
            },
        );
        let grid = grid.transpose()?;
        let mc = match settings.mc {
            None => None,
            Some(m) => {
                let times = match &grid {
                    Some(g) => g.times.clone(),
                    None => settings.output_times(None).unwrap_or_default(),
                };
                let horizon = m
                    .horizon
                    .or_else(|| grid.as_ref().map(|g| 20.0 * g.mean_at_start))
                    .expect("checked by the front end: a horizon, times or the grid");
                Some(
                    McPassage::new(bound, safe)
                        .paths(m.paths)
                        .dt(m.dt)
                        .horizon(horizon)
                        .seed(m.seed)
                        .start(settings.start)
                        .times(times)
                        .reliability(!mean_times_only)
                        .run()?,
                )
            }
        };
        Ok(PassageRun {
            grid,
            mc,
            stationary,
            scope: settings.scope,
        })
    }

    /// The parts the run's scope left out, for the methods that ran (`not_computed` in
    /// `summary.json`): with [`PassageScope::MeanTimes`], R(t) with the first-passage-time
    /// density, and with the grid the slowest decay and the stationary statistics.
    ///
    /// ```
    /// use fpsolve::job::passage::{NotComputedWhy, PassagePart, PassageRun, PassageScope};
    /// let none = PassageRun { grid: None, mc: None, stationary: None, scope: PassageScope::Full };
    /// assert!(none.not_computed().is_empty());
    /// let means = PassageRun { scope: PassageScope::MeanTimes, ..none };
    /// let parts = means.not_computed();
    /// assert_eq!(parts.len(), 1);
    /// assert_eq!((parts[0].what, parts[0].why), (PassagePart::Reliability, NotComputedWhy::MeanTimesOnly));
    /// ```
    pub fn not_computed(&self) -> Vec<NotComputed> {
        match self.scope {
            PassageScope::Full => Vec::new(),
            PassageScope::MeanTimes => {
                let mut parts = vec![PassagePart::Reliability];
                if self.grid.is_some() {
                    parts.extend([PassagePart::Decay, PassagePart::StationaryStatistics]);
                }
                parts
                    .into_iter()
                    .map(|what| NotComputed {
                        what,
                        why: NotComputedWhy::MeanTimesOnly,
                    })
                    .collect()
            }
        }
    }

    /// The distances between the grid's and Monte Carlo's mean time and R(t) ([`MethodDistances`]);
    /// `None` without both.
    pub fn distances(&self) -> Option<MethodDistances> {
        match (&self.grid, &self.mc) {
            (Some(g), Some(m)) => Some(MethodDistances::between(g, m)),
            _ => None,
        }
    }

    /// (Monte Carlo mean − grid mean) / Monte Carlo's standard error: `None` without both,
    /// `Some(None)` when paths were censored.
    pub fn grid_vs_mc_se(&self) -> Option<Option<f64>> {
        match (&self.grid, &self.mc) {
            (Some(g), Some(m)) => Some(m.mean.map(|e| (e.value - g.mean_at_start) / e.stderr)),
            _ => None,
        }
    }

    /// The warnings: blown-up paths, each number the methods give further apart than
    /// [`DISAGREE_SE`] standard errors plus the grid's stated error, a stationary Monte Carlo
    /// without a usable result.
    pub fn warnings(&self) -> Vec<PassageWarning> {
        let mut out = Vec::new();
        if let Some(m) = self.mc.as_ref().filter(|m| m.blowups > 0) {
            out.push(PassageWarning::Blowups(m.blowups));
        }
        if let Some(d) = self.distances() {
            for f in d.flagged() {
                out.push(PassageWarning::Disagree {
                    compared: f.compared,
                    gap: (f.mc - f.grid).abs(),
                    stderr: f.mc_stderr,
                    stated: f.grid_error,
                });
            }
        }
        if let Some(StationaryReport::Computed { mc: Some(m), .. }) =
            self.stationary.as_ref().map(|s| &s.report)
        {
            if let Some(e) = &m.error {
                out.push(PassageWarning::StationaryMc(e.clone()));
            }
        }
        out
    }

    /// `reliability.csv`: `t`, then `R_grid,pdf_grid[,R_grid_err]` and
    /// `R_mc,R_mc_lo95,R_mc_hi95` for the solves that ran, one row per output time.
    ///
    /// ```
    /// use fpsolve::job::passage::PassageRun;
    /// use fpsolve::job::passage::PassageScope;
    /// let none = PassageRun { grid: None, mc: None, stationary: None, scope: PassageScope::Full };
    /// assert_eq!(none.csv(), "t\n");
    /// ```
    pub fn csv(&self) -> String {
        let (grid, mc) = (&self.grid, &self.mc);
        let times = grid
            .as_ref()
            .map(|g| g.times.clone())
            .or_else(|| mc.as_ref().map(|m| m.times.clone()))
            .unwrap_or_default();
        let mut header = vec!["t"];
        let r_errors = grid
            .as_ref()
            .and_then(|g| g.errors.as_ref())
            .map(|e| &e.reliability);
        if grid.is_some() {
            header.extend(["R_grid", "pdf_grid"]);
            if r_errors.is_some() {
                header.push("R_grid_err");
            }
        }
        if mc.is_some() {
            header.extend(["R_mc", "R_mc_lo95", "R_mc_hi95"]);
        }
        let mut csv = header.join(",") + "\n";
        for (k, t) in times.iter().enumerate() {
            let mut row = vec![t.to_string()];
            if let Some(g) = grid {
                row.extend([g.reliability[k].to_string(), g.pdf[k].to_string()]);
                if let Some(e) = r_errors {
                    row.push(e[k].to_string());
                }
            }
            if let Some(m) = mc {
                row.extend([
                    m.reliability[k].to_string(),
                    m.reliability_lo[k].to_string(),
                    m.reliability_hi[k].to_string(),
                ]);
            }
            csv.push_str(&(row.join(",") + "\n"));
        }
        csv
    }

    /// `first_passage_pdf.csv`: Monte Carlo's first-passage-time density as a histogram on
    /// the output times, one row per bin (t_lo, t_hi]: `t_lo,t_hi,t_mid,pdf_mc,pdf_mc_se`
    /// ([`McPassageResult::pdf_binned`] and its standard errors). A table of its own because
    /// its rows are bins between the times of `reliability.csv`, not the times themselves.
    /// `None` without Monte Carlo or with fewer than two output times.
    ///
    /// ```
    /// use fpsolve::job::passage::PassageRun;
    /// use fpsolve::job::passage::PassageScope;
    /// let none = PassageRun { grid: None, mc: None, stationary: None, scope: PassageScope::Full };
    /// assert_eq!(none.pdf_csv(), None);
    /// ```
    pub fn pdf_csv(&self) -> Option<String> {
        let m = self.mc.as_ref().filter(|m| !m.pdf_binned.is_empty())?;
        let mut csv = String::from("t_lo,t_hi,t_mid,pdf_mc,pdf_mc_se\n");
        for (k, w) in m.times.windows(2).enumerate() {
            let row = [
                w[0],
                w[1],
                (w[0] + w[1]) / 2.0,
                m.pdf_binned[k],
                m.pdf_binned_stderr[k],
            ];
            let row: Vec<String> = row.iter().map(f64::to_string).collect();
            csv.push_str(&(row.join(",") + "\n"));
        }
        Some(csv)
    }

    /// Draws and writes into `dir` `reliability.png/.svg` (R(t) of each method that ran:
    /// the grid's line with its estimated error as a band, Monte Carlo's with its 95 %
    /// Wilson band) and `first_passage_pdf.png/.svg` (the grid's density, Monte Carlo's
    /// histogram with standard errors), each with a linear and a log panel. A figure that
    /// cannot be drawn (nothing positive to show, no output times) is listed in
    /// [`PassageFigures::unwritten`] with why; the numbers are not touched.
    ///
    /// ```no_run
    /// # use fpsolve::job::passage::{PassageRun, PassageSettings};
    /// # use fpsolve::model::{load_model, Override};
    /// # use fpsolve::report::OutputDir;
    /// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/linear.sde");
    /// let model = load_model(path.as_ref())?.with_safe("abs(z) < 1.2")?;
    /// let bound = model.bind(&[Override::number("c", 1.0)])?;
    /// let safe = model.safe().unwrap().bind(&bound)?;
    /// let settings = PassageSettings {
    ///     start: [0.0, 0.0],
    ///     times: (0..=10).map(f64::from).collect(),
    ///     cells: [40, 40],
    ///     domain: None,
    ///     grid: true,
    ///     mc: None,
    ///     scope: fpsolve::job::passage::PassageScope::Full,
    /// };
    /// let run = PassageRun::solve(&bound, &safe, &settings)?;
    /// let figures = run.write_figures(&OutputDir::create("out")?, &bound, &safe, [0.0, 0.0]);
    /// assert!(figures.unwritten.is_empty());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn write_figures(
        &self,
        dir: &OutputDir,
        bound: &BoundModel,
        safe: &BoundSafe,
        start: [f64; 2],
    ) -> PassageFigures {
        let mut subtitle = format!(
            "safe set {}, start ({}, {})",
            safe.text,
            short_number(start[0]),
            short_number(start[1])
        );
        for (p, v) in bound.params() {
            subtitle.push_str(&format!(", {p} = {}", short_number(*v)));
        }
        let caption = figures::Caption {
            title: bound.name().to_string(),
            subtitle,
        };
        figures::write(dir, &caption, self.grid.as_ref(), self.mc.as_ref())
    }

    /// Writes into `dir` the stationary tables the main job writes (`crossings_<q>.csv`
    /// with their figures `crossings_<q>.png/.svg`, `impact_speeds_<state>_<side>.csv`), when
    /// they were computed. A file that cannot be written is listed in
    /// [`PassageFigures::unwritten`] with why.
    pub fn write_stationary(&self, dir: &OutputDir, bound: &BoundModel) -> PassageFigures {
        let Some(tables) = self
            .stationary
            .as_ref()
            .and_then(StationaryStatistics::tables)
        else {
            return PassageFigures::default();
        };
        let subtitle = bound
            .params()
            .iter()
            .map(|(p, v)| format!("{p} = {}", short_number(*v)))
            .collect::<Vec<_>>()
            .join(", ");
        let written = tables.write(dir, Some((bound.name(), subtitle.as_str())));
        PassageFigures {
            files: written.files,
            unwritten: written.unwritten,
        }
    }

    /// `summary.json` of the run, opening with `provenance`.
    pub fn summary<'a>(
        &'a self,
        provenance: Provenance,
        command: String,
        model_file: String,
        bound: &'a BoundModel,
        safe: &'a BoundSafe,
        start: [f64; 2],
    ) -> PassageSummary<'a> {
        PassageSummary {
            provenance,
            fpsolve: env!("CARGO_PKG_VERSION"),
            command,
            model: bound.name(),
            model_file,
            safe: &safe.text,
            start,
            scope: self.scope,
            not_computed: self.not_computed(),
            grid: self.grid.as_ref(),
            mc: self.mc.as_ref(),
            grid_vs_mc_se: self.grid_vs_mc_se(),
            method_distances: self.distances(),
            stationary: self.stationary.as_ref().map(|s| &s.report),
            reliability: self
                .stationary
                .as_ref()
                .map(StationaryStatistics::summary)
                .unwrap_or_default(),
            unwritten: Vec::new(),
        }
    }
}
