//! The transient as `fpsolve transient` and Python's `Model.transient` run it: the settings
//! checked in one order before any work ([`TransientSettings::check`]), the grid's history
//! and the Monte Carlo ensemble on the grid's bins ([`CheckedTransient::run`]), and what the
//! two front ends report from them — `moments_vs_t.csv`, `pdf_<state>_t.csv`, the figures,
//! `summary.json`, the warnings — made once, so that the two give the same numbers and words.
//! Each front end reads its own flags or keywords (the methods, the times, the start, the
//! box) into [`TransientSettings`] first.

mod figures;
mod summary;
mod tables;
mod warnings;

use std::fmt;
use std::str::FromStr;

use crate::grid::{
    Domain, GridError, GridTransient, PeriodicReport, TransientError, TransientHistory,
};
use crate::mc::{McError, McPeriodicReport, McTransient, McTransientError, McTransientHistory};
use crate::model::{BoundModel, InitialError, InitialState, Model, PeriodError};

pub use tables::Columns;
pub use warnings::{TransientWarning, DISAGREE_SE};

/// Which methods run: the grid, Monte Carlo or both.
///
/// ```
/// use fpsolve::job::transient::Methods;
/// let both: Methods = "grid, mc".parse()?;
/// assert_eq!(both, Methods::GridAndMc);
/// assert!(both.grid() && both.mc() && both.to_string() == "grid,mc");
/// assert!("epc".parse::<Methods>().is_err());
/// # Ok::<(), fpsolve::job::transient::MethodError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Methods {
    /// The grid's time stepping alone.
    Grid,
    /// The Monte Carlo ensemble alone.
    Mc,
    /// Both, Monte Carlo on the grid's bins.
    GridAndMc,
}

impl Methods {
    /// Whether the grid runs.
    pub fn grid(self) -> bool {
        matches!(self, Methods::Grid | Methods::GridAndMc)
    }

    /// Whether Monte Carlo runs.
    pub fn mc(self) -> bool {
        matches!(self, Methods::Mc | Methods::GridAndMc)
    }
}

/// A method name that is neither `grid` nor `mc`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{0}`: expected `grid`, `mc` or `grid,mc`")]
pub struct MethodError(pub String);

impl FromStr for Methods {
    type Err = MethodError;

    /// `grid`, `mc` or both, comma-separated in any order.
    fn from_str(s: &str) -> Result<Methods, MethodError> {
        let (mut grid, mut mc) = (false, false);
        for m in s.split(',').map(str::trim) {
            match m {
                "grid" => grid = true,
                "mc" => mc = true,
                other => return Err(MethodError(other.to_string())),
            }
        }
        Ok(match (grid, mc) {
            (true, true) => Methods::GridAndMc,
            (false, true) => Methods::Mc,
            _ => Methods::Grid,
        })
    }
}

impl fmt::Display for Methods {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Methods::Grid => "grid",
            Methods::Mc => "mc",
            Methods::GridAndMc => "grid,mc",
        })
    }
}

/// The Monte Carlo's settings; [`McSettings::default`] is the front ends' default: 10 000
/// trajectories, dt = 0.01, seed 1.
///
/// ```
/// let s = fpsolve::job::transient::McSettings::default();
/// assert_eq!((s.trajectories, s.dt, s.seed), (10_000, 0.01, 1));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct McSettings {
    /// Trajectories (rounded up to whole batches by the run).
    pub trajectories: u64,
    /// The largest time step.
    pub dt: f64,
    /// The seed of the random streams.
    pub seed: u64,
}

impl Default for McSettings {
    fn default() -> McSettings {
        McSettings {
            trajectories: 10_000,
            dt: 0.01,
            seed: 1,
        }
    }
}

/// What a transient is asked to do, as a front end read it: [`TransientSettings::new`] then
/// the fields, then [`TransientSettings::check`].
#[derive(Clone, Debug, PartialEq)]
pub struct TransientSettings {
    /// The methods.
    pub methods: Methods,
    /// The output times (non-decreasing, non-negative).
    pub times: Vec<f64>,
    /// The start (the model's `initial` line bound, see [`initial_state`]).
    pub initial: InitialState,
    /// The grid's cells, position and velocity; Monte Carlo's bins without the grid.
    pub cells: [usize; 2],
    /// The box; `None`: the stationary solver's (a grid only, time-independent model).
    pub domain: Option<Domain>,
    /// The L1 error each grid step may make per unit time; `None`:
    /// [`crate::grid::TRANSIENT_TOLERANCE`].
    pub tolerance: Option<f64>,
    /// Monte Carlo's settings (used when [`Methods::mc`]).
    pub mc: McSettings,
    /// The coefficients' period: the periodic steady state instead of a history from the
    /// start (the grid's by the period map, [`crate::grid::GridPeriodic`]; Monte Carlo's
    /// after the periods its pilot discards, [`crate::mc::McPeriodic`]), `times` then phases
    /// in [0, period].
    pub period: Option<f64>,
}

/// Why a transient was refused before any work.
#[derive(Debug, thiserror::Error)]
pub enum TransientSetupError {
    /// Cells that are not even, too few, or of a stretched aspect.
    #[error(transparent)]
    Cells(GridError),
    /// No box for a model whose coefficients depend on the time.
    #[error(
        "required for a model whose coefficients depend on the time (the automatic box is \
         sized from a stationary law), e.g. {}=-5:5,{}=-5:5",
        states[0],
        states[1]
    )]
    DomainRequired {
        /// The states, to name in the example.
        states: [String; 2],
    },
    /// No box for Monte Carlo alone.
    #[error(
        "required for Monte Carlo alone (the histograms' range; the bins are the cells), or run \
         the grid too (grid,mc) to use the grid's box"
    )]
    McWithoutBox,
    /// A tolerance outside (0, 1).
    #[error("{0}: expected a number in (0, 1)")]
    Tolerance(f64),
    /// The grid's refusal (a setting, the model, the start outside the box).
    #[error(transparent)]
    Grid(TransientError),
    /// Monte Carlo's refusal (a setting, the model, a start beyond a wall, a period that is
    /// not the coefficients').
    #[error(transparent)]
    Mc(McTransientError),
}

impl TransientSetupError {
    /// The setting the error is about (`cells`, `domain`, `tol`), for the front end to
    /// name as its flag or keyword; `None` for a refusal about the model and the start.
    ///
    /// ```
    /// use fpsolve::job::transient::TransientSetupError;
    /// assert_eq!(TransientSetupError::Tolerance(0.0).setting(), Some("tol"));
    /// assert_eq!(TransientSetupError::McWithoutBox.setting(), Some("domain"));
    /// ```
    pub fn setting(&self) -> Option<&'static str> {
        match self {
            TransientSetupError::Cells(_) => Some("cells"),
            TransientSetupError::DomainRequired { .. } | TransientSetupError::McWithoutBox => {
                Some("domain")
            }
            TransientSetupError::Tolerance(_) => Some("tol"),
            TransientSetupError::Grid(TransientError::Setting {
                setting: "period", ..
            })
            | TransientSetupError::Mc(McTransientError::Period(PeriodError::NotPositive {
                ..
            })) => Some("period"),
            TransientSetupError::Grid(_) | TransientSetupError::Mc(_) => None,
        }
    }
}

/// Why a checked transient returned no history.
#[derive(Debug, thiserror::Error)]
pub enum TransientRunError {
    /// The grid's time stepping failed.
    #[error(transparent)]
    Grid(TransientError),
    /// Monte Carlo failed.
    #[error(transparent)]
    Mc(McTransientError),
    /// The grid's cells are not bins Monte Carlo can count in.
    #[error(transparent)]
    Bins(McError),
}

/// The start of `model` (its `initial` line, or rest without one) at the values of `bound`.
///
/// ```
/// use fpsolve::model::{parse_model, InitialState};
/// let model = parse_model("model m\nstate z, v\ndrift z: v\ndrift v: -v - z\n\
///     noise xi: intensity 2\ndiffusion v: xi\n", None)?.with_initial("point z = 1, v = 0")?;
/// let bound = model.bind(&[])?;
/// let start = fpsolve::job::transient::initial_state(&model, &bound)?;
/// assert_eq!(start, InitialState::Point([1.0, 0.0]));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// # Errors
/// [`InitialError`] for a value that is not finite or a covariance that is not positive
/// definite at these parameters.
pub fn initial_state(model: &Model, bound: &BoundModel) -> Result<InitialState, InitialError> {
    match model.initial() {
        None => Ok(InitialState::Rest),
        Some(spec) => spec.bind(bound),
    }
}

impl TransientSettings {
    /// The grid alone at `times`, from rest, on the default cells and box, tolerance
    /// [`crate::grid::TRANSIENT_TOLERANCE`], with [`McSettings::default`].
    ///
    /// ```
    /// let s = fpsolve::job::transient::TransientSettings::new(vec![0.0, 1.0]);
    /// assert_eq!(s.cells, fpsolve::grid::DEFAULT_CELLS);
    /// ```
    pub fn new(times: Vec<f64>) -> TransientSettings {
        TransientSettings {
            methods: Methods::Grid,
            times,
            initial: InitialState::Rest,
            cells: crate::grid::DEFAULT_CELLS,
            domain: None,
            tolerance: None,
            mc: McSettings::default(),
            period: None,
        }
    }

    /// Checks, in this order and before any step: the cells; a box for a model that depends
    /// on the time; the tolerance; with the grid, its settings, the model, the box and the
    /// start's fit in it (the box is then the grid's, so that Monte Carlo's bins are its
    /// cells); with Monte Carlo, a box and its settings.
    ///
    /// ```
    /// use fpsolve::job::transient::{TransientSettings, TransientSetupError};
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let mut s = TransientSettings::new(vec![0.0, 1.0]);
    /// s.tolerance = Some(0.0);
    /// assert!(matches!(s.clone().check(&bound), Err(TransientSetupError::Tolerance(_))));
    /// s.tolerance = None;
    /// s.cells = [32, 32];
    /// assert!(s.check(&bound)?.settings().domain.is_some());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// The [`TransientSetupError`] of the first check that fails.
    pub fn check(mut self, bound: &BoundModel) -> Result<CheckedTransient, TransientSetupError> {
        crate::grid::check_cells(self.cells).map_err(TransientSetupError::Cells)?;
        if self.domain.is_none() && bound.time_dependent() {
            let states = bound.states();
            return Err(TransientSetupError::DomainRequired {
                states: [states[0].to_string(), states[1].to_string()],
            });
        }
        let tolerance = self.tolerance.unwrap_or(crate::grid::TRANSIENT_TOLERANCE);
        if !(tolerance.is_finite() && tolerance > 0.0 && tolerance < 1.0) {
            return Err(TransientSetupError::Tolerance(tolerance));
        }
        self.tolerance = Some(tolerance);
        if let (Some(period), true) = (self.period, self.methods.grid()) {
            let domain = grid_run(bound, &self)
                .periodic(period)
                .check()
                .map_err(TransientSetupError::Grid)?;
            self.domain = Some(domain);
        } else if self.period.is_none() && self.methods.grid() {
            let domain = grid_run(bound, &self)
                .check()
                .map_err(TransientSetupError::Grid)?;
            self.domain = Some(domain);
        }
        if self.methods.mc() {
            if self.domain.is_none() {
                return Err(TransientSetupError::McWithoutBox);
            }
            let run = mc_run(bound, &self);
            match self.period {
                // The period is probed on the box the histograms will cover.
                Some(period) => match self.domain.map(|d| domain_bins(d, self.cells)) {
                    Some([Ok(x), Ok(v)]) => run.bins([x, v]),
                    _ => run,
                }
                .periodic(period)
                .check(),
                None => run.check(),
            }
            .map_err(TransientSetupError::Mc)?;
        }
        Ok(CheckedTransient { settings: self })
    }
}

/// Settings that passed [`TransientSettings::check`]: its box and tolerance are filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckedTransient {
    settings: TransientSettings,
}

/// The grid's run of `s` (its box, when given or checked).
fn grid_run<'a>(bound: &'a BoundModel, s: &TransientSettings) -> GridTransient<'a> {
    let run = GridTransient::new(bound)
        .cells(s.cells[0], s.cells[1])
        .initial(s.initial.into())
        .tolerance(s.tolerance.unwrap_or(crate::grid::TRANSIENT_TOLERANCE))
        .times(s.times.clone());
    match s.domain {
        Some(d) => run.domain(d),
        None => run,
    }
}

/// Monte Carlo's run of `s` (bins set by the caller).
fn mc_run<'a>(bound: &'a BoundModel, s: &TransientSettings) -> McTransient<'a> {
    McTransient::new(bound)
        .initial(s.initial)
        .times(s.times.clone())
        .trajectories(s.mc.trajectories)
        .dt(s.mc.dt)
        .seed(s.mc.seed)
}

impl CheckedTransient {
    /// The settings as checked.
    pub fn settings(&self) -> &TransientSettings {
        &self.settings
    }

    /// Runs the grid, then Monte Carlo on its cells as bins (on the box's `cells` without
    /// it), each on the current rayon pool; with a period, each method's periodic state.
    ///
    /// ```
    /// use fpsolve::grid::Domain;
    /// use fpsolve::job::transient::{Methods, TransientSettings};
    /// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
    /// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
    /// let mut s = TransientSettings::new(vec![0.0, 0.5]);
    /// s.methods = Methods::Mc;
    /// (s.cells, s.domain) = ([16, 16], Some(Domain { x: [-4.0, 4.0], v: [-4.0, 4.0] }));
    /// s.mc.trajectories = 256;
    /// let run = s.check(&bound)?.run(&bound)?;
    /// assert!(run.grid.is_none() && run.times() == [0.0, 0.5]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// The failing method's [`TransientRunError`].
    pub fn run(&self, bound: &BoundModel) -> Result<TransientRun, TransientRunError> {
        let s = &self.settings;
        let mut periodic = None;
        let grid = match s.period {
            Some(period) if s.methods.grid() => {
                let state = grid_run(bound, s)
                    .periodic(period)
                    .run()
                    .map_err(TransientRunError::Grid)?;
                periodic = Some(state.report);
                Some(state.history)
            }
            None if s.methods.grid() => {
                Some(grid_run(bound, s).run().map_err(TransientRunError::Grid)?)
            }
            _ => None,
        };
        let mut mc_periodic = None;
        let mc = if s.methods.mc() {
            // The grid's bins (its cells on its box), so that the columns line up.
            let [bx, bv] = match &grid {
                Some(g) => {
                    let m = &g.snapshots[0].marginals;
                    [bins_of(&m[0]), bins_of(&m[1])]
                }
                None => domain_bins(
                    s.domain.expect("checked: Monte Carlo alone has a box"),
                    s.cells,
                ),
            };
            let bins = [
                bx.map_err(TransientRunError::Bins)?,
                bv.map_err(TransientRunError::Bins)?,
            ];
            let run = mc_run(bound, s).bins(bins);
            Some(match s.period {
                Some(period) => {
                    let state = run.periodic(period).run().map_err(TransientRunError::Mc)?;
                    mc_periodic = Some(state.report);
                    state.history
                }
                None => run.run().map_err(TransientRunError::Mc)?,
            })
        } else {
            None
        };
        Ok(TransientRun {
            settings: s.clone(),
            grid,
            mc,
            periodic,
            mc_periodic,
        })
    }
}

/// The bins of `cells` on the box `d`.
fn domain_bins(d: Domain, cells: [usize; 2]) -> [Result<crate::mc::Grid, McError>; 2] {
    [
        crate::mc::Grid::new(d.x[0], d.x[1], cells[0]),
        crate::mc::Grid::new(d.v[0], d.v[1], cells[1]),
    ]
}

/// The bins of a grid marginal's cells.
fn bins_of(m: &crate::grid::Marginal) -> Result<crate::mc::Grid, McError> {
    let lo = m.centres[0] - 0.5 * m.width;
    crate::mc::Grid::new(lo, lo + m.width * m.centres.len() as f64, m.centres.len())
}

/// The histories of a finished transient (either method may be absent) with the settings
/// they ran with.
#[derive(Clone, Debug)]
pub struct TransientRun {
    /// The settings, as checked.
    pub settings: TransientSettings,
    /// The grid's history, when it ran.
    pub grid: Option<TransientHistory>,
    /// Monte Carlo's, when it ran.
    pub mc: Option<McTransientHistory>,
    /// How the grid's periodic state was found, when a period was given and the grid ran
    /// (its snapshots are then at phases).
    pub periodic: Option<PeriodicReport>,
    /// How Monte Carlo sampled the periodic state (the periods discarded and recorded), when
    /// a period was given and Monte Carlo ran (its snapshots are then at phases).
    pub mc_periodic: Option<McPeriodicReport>,
}

impl TransientRun {
    /// The output times.
    pub fn times(&self) -> Vec<f64> {
        match (&self.grid, &self.mc) {
            (Some(g), _) => g.snapshots.iter().map(|s| s.t).collect(),
            (None, Some(m)) => m.snapshots.iter().map(|s| s.t).collect(),
            (None, None) => Vec::new(),
        }
    }

    /// Writes `moments_vs_t.csv`, one `pdf_<state>_t.csv` per state, with `figures` the
    /// figures `sigma_vs_t` and `pdf_<state>_at_t<T>` (png and svg), and `summary` (the
    /// text of [`TransientRun::summary_json`]) as `summary.json`; returns how many files.
    ///
    /// # Errors
    /// A file or figure that could not be written.
    pub fn write(
        &self,
        dir: &crate::report::OutputDir,
        bound: &BoundModel,
        summary: &str,
        figures: bool,
    ) -> Result<usize, crate::report::ReportError> {
        dir.write_atomic("moments_vs_t.csv", self.moments(bound).csv().as_bytes())?;
        let states = bound.states();
        for (axis, q) in states.iter().enumerate() {
            dir.write_atomic(&format!("pdf_{q}_t.csv"), self.pdf(axis).csv().as_bytes())?;
        }
        let mut files = 2 + states.len();
        if figures {
            files += figures::write(dir, bound, &self.grid, &self.mc)?;
        }
        dir.write_atomic("summary.json", summary.as_bytes())?;
        Ok(files)
    }
}

#[cfg(test)]
mod tests;
