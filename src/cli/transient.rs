//! `fpsolve transient MODEL --times A:B:N [--method grid,mc]`: the density as it evolves
//! from the model's `initial` line (or `--initial`; rest without either), on the grid and/or
//! by a Monte Carlo ensemble. Every flag, the box and the start's fit in it are checked
//! before the output directory is touched; writes `moments_vs_t.csv`, one
//! `pdf_<state>_t.csv` per state, the figures `sigma_vs_t` and `pdf_<state>_at_t<T>`, and
//! `summary.json`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use clap::Args;
use fpsolve::grid::{Cells, Domain, GridTransient, Initial, TransientHistory, TRANSIENT_TOLERANCE};
use fpsolve::mc::{McTransient, McTransientHistory};
use fpsolve::model::{BoundModel, InitialState, Model};
use fpsolve::report::{write_json_flagging_undefined, Provenance};
use serde::Serialize;

/// The flags of `fpsolve transient`.
#[derive(Args, Debug)]
pub(crate) struct TransientArgs {
    /// Output times: FIRST:LAST:COUNT (COUNT >= 2, 0 <= FIRST < LAST).
    #[arg(long, value_name = "A:B:N")]
    times: String,
    /// Cells of the grid, position and velocity (default 200,400).
    #[arg(long, value_name = "NX,NV")]
    cells: Option<Cells>,
    /// The box, `STATE=LO:HI,STATE=LO:HI` (default: the stationary solver's box; required
    /// for a model whose coefficients depend on the time).
    #[arg(long, value_name = "BOX", allow_hyphen_values = true)]
    domain: Option<String>,
    /// The L1 error each step may make per unit time (default 1e-4).
    #[arg(long, value_name = "TOL")]
    tol: Option<f64>,
    /// Where the run starts, overriding the model's `initial` line: `rest`,
    /// `point z = 1, v = 0`, `gaussian mean z = 0, v = 0 cov 1, 0, 0, 1`.
    #[arg(long, value_name = "START", allow_hyphen_values = true)]
    initial: Option<String>,
    /// Methods: `grid`, `mc` or both (`grid,mc`).
    #[arg(long, value_name = "M,...", default_value = "grid")]
    method: String,
    /// Monte Carlo trajectories (rounded up to whole batches of 64).
    #[arg(long, value_name = "N", default_value = "10000")]
    trajectories: String,
    /// Monte Carlo: the largest time step.
    #[arg(long, value_name = "DT", default_value_t = 0.01)]
    dt: f64,
    /// Monte Carlo: the seed of the random streams.
    #[arg(long, value_name = "SEED", default_value_t = 1)]
    seed: u64,
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Output directory (default: out/<model name>_transient).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// A checked `transient` command.
pub(crate) struct TransientPlan {
    path: PathBuf,
    model: Model,
    bound: BoundModel,
    initial: Initial,
    initial_state: InitialState,
    grid: bool,
    mc: Option<McSettings>,
    times: Vec<f64>,
    cells: [usize; 2],
    domain: Option<Domain>,
    tolerance: f64,
    out: PathBuf,
}

/// The Monte Carlo settings of a plan.
#[derive(Clone, Copy, Debug, Serialize)]
struct McSettings {
    trajectories: u64,
    dt: f64,
    seed: u64,
}

/// Reads and checks everything before any step.
pub(crate) fn plan(path: PathBuf, args: TransientArgs) -> Result<TransientPlan> {
    let (mut grid, mut mc) = (false, false);
    for m in args.method.split(',').map(str::trim) {
        match m {
            "grid" => grid = true,
            "mc" => mc = true,
            other => {
                return Err(anyhow!(
                    "--method {other}: expected `grid`, `mc` or `grid,mc`"
                ))
            }
        }
    }
    let times = fpsolve::job::passage::parse_times(&args.times)
        .map_err(anyhow::Error::new)
        .context("--times")?;
    let (model, bound) = crate::load_amended(&path, &args.set, |model| match &args.initial {
        Some(text) => model.with_initial(text).map_err(crate::lib),
        None => Ok(model),
    })?;
    let initial_state = match model.initial() {
        None => InitialState::Rest,
        Some(spec) => spec
            .bind(&bound)
            .map_err(|e| anyhow::Error::new(e).context(path.display().to_string()))?,
    };
    let initial = Initial::from(initial_state);
    let cells = args.cells.unwrap_or_default().0;
    fpsolve::grid::check_cells(cells).map_err(|e| anyhow::Error::new(e).context("--cells"))?;
    let states = bound.states();
    let domain = args
        .domain
        .as_deref()
        .map(|d| Domain::parse_named(d, [&*states[0], &*states[1]]))
        .transpose()
        .map_err(|e| anyhow::Error::new(e).context("--domain"))?;
    if domain.is_none() && bound.time_dependent() {
        return Err(anyhow!(
            "--domain: required for a model whose coefficients depend on the time (the \
             automatic box is sized from a stationary law), e.g. --domain {}=-5:5,{}=-5:5",
            states[0],
            states[1]
        ));
    }
    let tolerance = args.tol.unwrap_or(TRANSIENT_TOLERANCE);
    if !(tolerance.is_finite() && tolerance > 0.0 && tolerance < 1.0) {
        return Err(anyhow!("--tol {tolerance}: expected a number in (0, 1)"));
    }
    let mut domain = domain;
    if grid {
        // The box and the start's fit in it, before the output directory is locked.
        let mut g = GridTransient::new(&bound)
            .cells(cells[0], cells[1])
            .initial(initial.clone())
            .tolerance(tolerance)
            .times(times.clone());
        if let Some(d) = domain {
            g = g.domain(d);
        }
        domain = Some(
            g.check()
                .map_err(|e| anyhow::Error::new(e).context(path.display().to_string()))?,
        );
    }
    let mc = if mc {
        if !grid && domain.is_none() {
            return Err(anyhow!(
                "--method mc: give --domain (the histograms' range; the bins are --cells), or \
                 run `--method grid,mc` to use the grid's box"
            ));
        }
        let trajectories = super::mc_flags::parse_count(&args.trajectories, "--trajectories")?;
        let settings = McSettings {
            trajectories,
            dt: args.dt,
            seed: args.seed,
        };
        mc_run(&bound, initial_state, &times, settings)
            .check()
            .map_err(|e| anyhow::Error::new(e).context(path.display().to_string()))?;
        Some(settings)
    } else {
        None
    };
    let out = args
        .out
        .unwrap_or_else(|| Path::new("out").join(format!("{}_transient", model.name())));
    Ok(TransientPlan {
        path,
        model,
        bound,
        initial,
        initial_state,
        grid,
        mc,
        times,
        cells,
        domain,
        tolerance,
        out,
    })
}

/// The Monte Carlo run of a plan (bins set by the caller).
fn mc_run<'a>(
    bound: &'a BoundModel,
    initial: InitialState,
    times: &[f64],
    s: McSettings,
) -> McTransient<'a> {
    McTransient::new(bound)
        .initial(initial)
        .times(times.to_vec())
        .trajectories(s.trajectories)
        .dt(s.dt)
        .seed(s.seed)
}

/// The start as `summary.json` writes it.
#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
enum InitialJson {
    Rest,
    Point {
        at: [f64; 2],
    },
    Gaussian {
        mean: [f64; 2],
        covariance: [[f64; 2]; 2],
    },
}

impl From<InitialState> for InitialJson {
    fn from(s: InitialState) -> Self {
        match s {
            InitialState::Rest => InitialJson::Rest,
            InitialState::Point(at) => InitialJson::Point { at },
            InitialState::Gaussian { mean, covariance } => {
                InitialJson::Gaussian { mean, covariance }
            }
        }
    }
}

#[derive(Serialize)]
struct Output<'a> {
    t: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    grid: Option<GridOutput<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mc: Option<McOutput>,
    /// (grid − MC)/MC's standard error of each state's mean, variance and kurtosis (null
    /// where the standard error is 0, as at a point start).
    #[serde(skip_serializing_if = "Option::is_none")]
    grid_vs_mc_in_se: Option<Vec<Distance>>,
}

#[derive(Serialize)]
struct GridOutput<'a> {
    mass: f64,
    negative_mass: f64,
    edge_mass: f64,
    /// The estimated errors of the output's numbers (from the run on half the cells).
    #[serde(skip_serializing_if = "Option::is_none")]
    estimate: Option<&'a fpsolve::grid::SnapshotErrors>,
}

#[derive(Serialize)]
struct McOutput {
    blown_up: u64,
    /// Each state's moments with standard errors and time-step bias.
    moments: Vec<fpsolve::mc::McStateMoments>,
    /// The fraction of each state's trajectories outside the histogram's bins.
    outside_bins: Vec<f64>,
}

#[derive(Serialize)]
struct Distance {
    state: String,
    mean: Option<f64>,
    variance: Option<f64>,
    kurtosis: Option<f64>,
    /// The largest |grid − MC|/se over the bins where MC's se is positive.
    pdf_worst: Option<f64>,
}

#[derive(Serialize)]
struct McSummary<'a> {
    settings: &'a fpsolve::mc::McTransientSettings,
}

#[derive(Serialize)]
struct Summary<'a> {
    provenance: Provenance,
    method: String,
    initial: InitialJson,
    times: usize,
    /// The run's settings and what it did (cells, box, tolerance, steps, factorisations).
    #[serde(skip_serializing_if = "Option::is_none")]
    grid: Option<&'a fpsolve::grid::TransientReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mc: Option<McSummary<'a>>,
    outputs: Vec<Output<'a>>,
}

/// The two methods' histories (either may be absent).
struct Histories {
    grid: Option<TransientHistory>,
    mc: Option<McTransientHistory>,
}

impl Histories {
    fn times(&self) -> Vec<f64> {
        match (&self.grid, &self.mc) {
            (Some(g), _) => g.snapshots.iter().map(|s| s.t).collect(),
            (None, Some(m)) => m.snapshots.iter().map(|s| s.t).collect(),
            (None, None) => Vec::new(),
        }
    }
}

/// The quantities reported, states then observables (grid), with their moments at each
/// output; the states' Monte Carlo moments and standard errors after them.
fn moments_csv(model: &BoundModel, h: &Histories) -> String {
    let states: Vec<String> = model.states().iter().map(|s| s.to_string()).collect();
    let mut names = states.clone();
    names.extend(model.observables().iter().map(|o| o.name.to_string()));
    let mut csv = String::from("t");
    let errors = h
        .grid
        .as_ref()
        .is_some_and(|g| g.report.estimate_cells.is_some());
    if h.grid.is_some() {
        for q in &names {
            let _ = write!(csv, ",{q}_mean,{q}_variance,{q}_kurtosis");
            if errors {
                let _ = write!(csv, ",{q}_mean_err,{q}_variance_err,{q}_kurtosis_err");
            }
        }
    }
    if h.mc.is_some() {
        for q in &states {
            for m in ["mean", "variance", "kurtosis"] {
                let _ = write!(csv, ",{q}_{m}_mc,{q}_{m}_mc_se");
            }
        }
    }
    csv.push('\n');
    for (k, t) in h.times().iter().enumerate() {
        let _ = write!(csv, "{t}");
        if let Some(g) = &h.grid {
            let s = &g.snapshots[k];
            let e = s.estimate.as_ref();
            let errs = e.map(|e| e.moments.iter().chain(&e.observables).collect::<Vec<_>>());
            for (i, m) in s.moments.iter().chain(&s.observables).enumerate() {
                let _ = write!(csv, ",{},{},{}", m.mean, m.variance, m.kurtosis);
                if let Some(e) = errs.as_ref().map(|e| e[i]) {
                    let _ = write!(csv, ",{},{},{}", e.mean, e.variance, e.kurtosis);
                }
            }
        }
        if let Some(mc) = &h.mc {
            for m in &mc.snapshots[k].moments {
                for e in [m.mean, m.variance, m.kurtosis] {
                    let _ = write!(csv, ",{},{}", e.value, e.stderr);
                }
            }
        }
        csv.push('\n');
    }
    csv
}

/// The marginal of state `axis` at every output, long format: the grid's cell averages and
/// the Monte Carlo histogram on the same bins with its standard error.
fn pdf_csv(h: &Histories, axis: usize) -> String {
    let mut csv = String::from("t,x");
    if h.grid.is_some() {
        csv.push_str(",grid");
    }
    if h.mc.is_some() {
        csv.push_str(",mc,mc_se");
    }
    csv.push('\n');
    for (k, t) in h.times().iter().enumerate() {
        let grid = h.grid.as_ref().map(|g| &g.snapshots[k].marginals[axis]);
        let mc =
            h.mc.as_ref()
                .and_then(|m| m.snapshots[k].densities.as_ref())
                .map(|d| &d[axis]);
        let centres = match (grid, mc) {
            (Some(g), _) => g.centres.clone(),
            (None, Some(m)) => m.grid.centers(),
            (None, None) => Vec::new(),
        };
        for (i, x) in centres.iter().enumerate() {
            let _ = write!(csv, "{t},{x}");
            if let Some(g) = grid {
                let _ = write!(csv, ",{}", g.density[i]);
            }
            if let Some(m) = mc {
                let _ = write!(csv, ",{},{}", m.density[i], m.stderr[i]);
            }
            csv.push('\n');
        }
    }
    csv
}

/// (a − b)/se, `None` where se is 0 or anything is not finite.
fn in_se(a: f64, b: f64, se: f64) -> Option<f64> {
    let d = (a - b) / se;
    (se > 0.0 && d.is_finite()).then_some(d)
}

/// Grid against MC at output `k`, per state.
fn distances(
    states: &[String],
    g: &TransientHistory,
    m: &McTransientHistory,
    k: usize,
) -> Vec<Distance> {
    let (gs, ms) = (&g.snapshots[k], &m.snapshots[k]);
    states
        .iter()
        .enumerate()
        .map(|(a, q)| {
            let (gm, mm) = (&gs.moments[a], &ms.moments[a]);
            let pdf_worst = ms.densities.as_ref().and_then(|d| {
                let d = &d[a];
                let worst = gs.marginals[a]
                    .density
                    .iter()
                    .zip(d.density.iter().zip(&d.stderr))
                    .filter_map(|(g, (m, se))| in_se(*g, *m, *se))
                    .map(f64::abs)
                    .fold(f64::NAN, f64::max);
                worst.is_finite().then_some(worst)
            });
            Distance {
                state: q.clone(),
                mean: in_se(gm.mean, mm.mean.value, mm.mean.stderr),
                variance: in_se(gm.variance, mm.variance.value, mm.variance.stderr),
                kurtosis: in_se(gm.kurtosis, mm.kurtosis.value, mm.kurtosis.stderr),
                pdf_worst,
            }
        })
        .collect()
}

/// Steps and writes the output directory.
/// Runs the plan and writes every output; returns what is flagged (exit 1 with the files
/// written), empty for a sound run.
pub(crate) fn run(plan: TransientPlan) -> Result<Vec<String>> {
    let run = crate::begin_output(&plan.out)?;
    let at = |e: anyhow::Error| e.context(plan.path.display().to_string());
    let grid = if plan.grid {
        let mut transient = GridTransient::new(&plan.bound)
            .cells(plan.cells[0], plan.cells[1])
            .initial(plan.initial.clone())
            .tolerance(plan.tolerance)
            .times(plan.times.clone());
        if let Some(d) = plan.domain {
            transient = transient.domain(d);
        }
        Some(transient.run().map_err(|e| at(anyhow::Error::new(e)))?)
    } else {
        None
    };
    let mc = match plan.mc {
        Some(settings) => {
            // The grid's bins (its cells on its box), so that the columns line up.
            let bins = match &grid {
                Some(g) => {
                    let m = &g.snapshots[0].marginals;
                    std::array::from_fn(|a| bins_of(&m[a]))
                }
                None => {
                    let d = plan.domain.expect("checked in plan");
                    [
                        fpsolve::mc::Grid::new(d.x[0], d.x[1], plan.cells[0]),
                        fpsolve::mc::Grid::new(d.v[0], d.v[1], plan.cells[1]),
                    ]
                }
            };
            let [bx, bv] = bins;
            let bins = [bx.map_err(crate::lib)?, bv.map_err(crate::lib)?];
            let h = mc_run(&plan.bound, plan.initial_state, &plan.times, settings)
                .bins(bins)
                .run()
                .map_err(|e| at(anyhow::Error::new(e)))?;
            Some(h)
        }
        None => None,
    };
    let flags: Vec<String> = mc.as_ref().and_then(stuck).into_iter().collect();
    let h = Histories { grid, mc };
    let write = |name: &str, text: String| {
        run.out()
            .write_atomic(name, text.as_bytes())
            .map_err(crate::lib)
    };
    write("moments_vs_t.csv", moments_csv(&plan.bound, &h))?;
    let states: Vec<String> = plan.bound.states().iter().map(|s| s.to_string()).collect();
    for (axis, q) in states.iter().enumerate() {
        write(&format!("pdf_{q}_t.csv"), pdf_csv(&h, axis))?;
    }
    let figures = super::transient_figures::write(run.out(), &plan.model, &states, &h.grid, &h.mc)?;
    let method = [(h.grid.is_some(), "grid"), (h.mc.is_some(), "mc")]
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, m)| *m)
        .collect::<Vec<_>>()
        .join(",");
    let outputs = h
        .times()
        .iter()
        .enumerate()
        .map(|(k, &t)| Output {
            t,
            grid: h.grid.as_ref().map(|g| {
                let s = &g.snapshots[k];
                GridOutput {
                    mass: s.mass,
                    negative_mass: s.negative_mass,
                    edge_mass: s.edge_mass,
                    estimate: s.estimate.as_ref(),
                }
            }),
            mc: h.mc.as_ref().map(|m| {
                let s = &m.snapshots[k];
                McOutput {
                    blown_up: s.blown_up,
                    moments: s.moments.to_vec(),
                    outside_bins: s
                        .densities
                        .as_ref()
                        .map(|d| d.iter().map(|d| d.outside).collect())
                        .unwrap_or_default(),
                }
            }),
            grid_vs_mc_in_se: match (&h.grid, &h.mc) {
                (Some(g), Some(m)) => Some(distances(&states, g, m, k)),
                _ => None,
            },
        })
        .collect();
    let summary = Summary {
        provenance: Provenance::now(Some(&plan.model)),
        method,
        initial: plan.initial_state.into(),
        times: plan.times.len(),
        grid: h.grid.as_ref().map(|g| &g.report),
        mc: h.mc.as_ref().map(|m| McSummary {
            settings: &m.settings,
        }),
        outputs,
    };
    // A moment that does not exist (the kurtosis of a point start, whose variance is 0) is
    // written as null and listed under `undefined`, never a lost run.
    let (_, undefined) =
        write_json_flagging_undefined(run.out(), "summary.json", &summary).map_err(crate::lib)?;
    if !undefined.is_empty() {
        crate::cli::console::sayln!(
            "note: {} numbers of summary.json have no finite value (null there, listed under `undefined`), e.g. {}",
            undefined.len(),
            undefined[0].field
        );
    }
    say(&h, &states[0]);
    if let Some(g) = &h.grid {
        for line in uncertain_variances(g, &states)
            .into_iter()
            .chain(unresolved_marginals(g, &states))
        {
            crate::cli::console::sayln!("{line}");
        }
    }
    crate::commit_output(run, 2 + states.len() + figures)?;
    Ok(flags)
}

/// The flag of a Monte Carlo ensemble stuck at its point start
/// ([`McTransientHistory::stuck_at_start`]).
fn stuck(h: &McTransientHistory) -> Option<String> {
    let t = h.stuck_at_start()?;
    Some(format!(
        "Monte Carlo: every trajectory is still at its start at t = {t} (both states' variances \
         are 0): the sampled drift and noise vanish there (e.g. sgn(0) = 0 in a Zhuravlev \
         form, whose noise is sgn(z)*xi); its numbers are not the law's. Start beside it, e.g. \
         --initial 'point z = 1e-6, v = 0'"
    ))
}

/// The bins of a grid marginal's cells.
fn bins_of(m: &fpsolve::grid::Marginal) -> Result<fpsolve::mc::Grid, fpsolve::mc::McError> {
    let lo = m.centres[0] - 0.5 * m.width;
    fpsolve::mc::Grid::new(lo, lo + m.width * m.centres.len() as f64, m.centres.len())
}

/// The relative error estimate of a state's variance above which the console warns (the
/// numbers and their errors are in `moments_vs_t.csv` whatever they are).
const UNCERTAIN_VARIANCE: f64 = 0.05;

/// A warning per state whose grid variance has an estimated error above
/// [`UNCERTAIN_VARIANCE`] of itself at some output after the start, at its worst output.
fn uncertain_variances(g: &TransientHistory, states: &[String]) -> Vec<String> {
    states
        .iter()
        .enumerate()
        .filter_map(|(a, q)| {
            let relative = |s: &fpsolve::grid::Snapshot| {
                let e = s.estimate.as_ref()?.moments[a].variance;
                let r = e / s.moments[a].variance.abs();
                (s.t > 0.0 && r.is_finite()).then_some(r)
            };
            let (worst, r) = g
                .snapshots
                .iter()
                .filter_map(|s| relative(s).map(|r| (s, r)))
                .max_by(|a, b| a.1.total_cmp(&b.1))?;
            (r > UNCERTAIN_VARIANCE).then(|| {
                format!(
                    "warning: the grid's variance of {q} at t = {} is {:.4} with an estimated \
                     error of {:.0} % (from the run on half the cells): the cells do not resolve \
                     the density yet (a point start is a Gaussian {} cells wide); finer --cells \
                     or a Gaussian --initial narrow it",
                    worst.t,
                    worst.moments[a].variance,
                    100.0 * r,
                    fpsolve::grid::POINT_CELLS
                )
            })
        })
        .collect()
}

/// A warning per state whose grid marginal is not resolved at some output after the start
/// (its L1 estimate at or above [`fpsolve::grid::UNRESOLVED_L1`]), naming the last such time.
fn unresolved_marginals(g: &TransientHistory, states: &[String]) -> Vec<String> {
    states
        .iter()
        .enumerate()
        .filter_map(|(a, q)| {
            let last = g.snapshots.iter().rev().find(|s| {
                s.t > 0.0
                    && s.estimate
                        .as_ref()
                        .is_some_and(|e| e.l1[a] >= fpsolve::grid::UNRESOLVED_L1)
            })?;
            Some(format!(
                "warning: the grid's marginal of {q} is not resolved by the cells up to t = {} \
                 (estimated L1 error {:.2} there: a number, not a bound); its curves before \
                 then are not the law's",
                last.t,
                last.estimate.as_ref().map_or(f64::NAN, |e| e.l1[a])
            ))
        })
        .collect()
}

/// One line per method on the console.
fn say(h: &Histories, state: &str) {
    if let Some(g) = &h.grid {
        let r = &g.report;
        let peak = g
            .snapshots
            .iter()
            .max_by(|a, b| a.moments[0].variance.total_cmp(&b.moments[0].variance));
        if let Some(p) = peak {
            crate::cli::console::sayln!(
                "grid transient {}x{}: {} steps ({} rejected), {} factorisations; peak sd of {} \
                 {:.6} at t = {}; worst |mass - 1| {:.1e}, negative mass {:.1e}",
                r.cells[0],
                r.cells[1],
                r.accepted,
                r.rejected,
                r.factorizations,
                state,
                p.moments[0].variance.sqrt(),
                p.t,
                r.mass_drift,
                r.negative_mass
            );
        }
    }
    if let Some(m) = &h.mc {
        let s = &m.settings;
        let blown = m.snapshots.iter().map(|s| s.blown_up).max().unwrap_or(0);
        crate::cli::console::sayln!(
            "mc transient: {} trajectories, dt {}, seed {}, {:?} (weak order {}), {} bias pairs \
             at 2dt; {} blown up; {:.0} ms",
            s.trajectories,
            s.dt,
            s.seed,
            s.scheme,
            s.weak_order,
            s.bias_pairs,
            blown,
            s.total_ms
        );
    }
}
