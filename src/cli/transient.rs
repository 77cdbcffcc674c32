//! `fpsolve transient MODEL --times A:B:N [--method grid,mc]`: the density as it evolves
//! from the model's `initial` line (or `--initial`; rest without either), on the grid and/or
//! by a Monte Carlo ensemble. Every flag, the box and the start's fit in it are checked
//! before the output directory is touched; writes `moments_vs_t.csv`, one
//! `pdf_<state>_t.csv` per state, the figures `sigma_vs_t` and `pdf_<state>_at_t<T>`, and
//! `summary.json`. The checks, the runs and the files are [`fpsolve::job::transient`]'s,
//! shared with Python's `Model.transient`; this reads the flags and prints.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use fpsolve::grid::{Cells, Domain};
use fpsolve::job::transient::{
    initial_state, CheckedTransient, McSettings, Methods, TransientRun, TransientRunError,
    TransientSettings,
};
use fpsolve::model::{BoundModel, Model};
use fpsolve::report::Provenance;

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
    /// The coefficients' period P: the periodic steady state instead of a history from the
    /// start (the grid's by the period map, Monte Carlo's over the periods after those its
    /// pilot discards); --times are then phases in [0, P], and the start is the grid's
    /// first guess (rest: a broad Gaussian at the box's centre) and Monte Carlo's start.
    #[arg(long, value_name = "P")]
    period: Option<f64>,
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
    checked: CheckedTransient,
    out: PathBuf,
}

/// Reads and checks everything before any step: the methods, the times, the model with its
/// `--initial`, the box, the trajectories, then the library's checks in its order.
pub(crate) fn plan(path: PathBuf, args: TransientArgs) -> Result<TransientPlan> {
    let methods: Methods = args.method.parse().context("--method")?;
    let times = fpsolve::job::passage::parse_times(&args.times)
        .map_err(anyhow::Error::new)
        .context("--times")?;
    let (model, bound) = crate::load_amended(&path, &args.set, |model| match &args.initial {
        Some(text) => model.with_initial(text).map_err(crate::lib),
        None => Ok(model),
    })?;
    let at = |e: anyhow::Error| e.context(path.display().to_string());
    let initial = initial_state(&model, &bound).map_err(|e| at(anyhow::Error::new(e)))?;
    let states = bound.states();
    let domain = args
        .domain
        .as_deref()
        .map(|d| Domain::parse_named(d, [&*states[0], &*states[1]]))
        .transpose()
        .map_err(|e| anyhow::Error::new(e).context("--domain"))?;
    let trajectories = if methods.mc() {
        super::mc_flags::parse_count(&args.trajectories, "--trajectories")?
    } else {
        McSettings::default().trajectories
    };
    let settings = TransientSettings {
        methods,
        times,
        initial,
        cells: args.cells.unwrap_or_default().0,
        domain,
        tolerance: args.tol,
        mc: McSettings {
            trajectories,
            dt: args.dt,
            seed: args.seed,
        },
        period: args.period,
    };
    let checked = settings.check(&bound).map_err(|e| match e.setting() {
        Some(flag) => anyhow::Error::new(e).context(format!("--{flag}")),
        None => at(anyhow::Error::new(e)),
    })?;
    let out = args
        .out
        .unwrap_or_else(|| Path::new("out").join(format!("{}_transient", model.name())));
    Ok(TransientPlan {
        path,
        model,
        bound,
        checked,
        out,
    })
}

/// Steps, writes the output directory and prints; returns what is flagged (exit 1 with the
/// files written), empty for a sound run.
pub(crate) fn run(plan: TransientPlan) -> Result<Vec<String>> {
    let run = crate::begin_output(&plan.out)?;
    let solved = plan.checked.run(&plan.bound).map_err(|e| match e {
        TransientRunError::Bins(e) => crate::lib(e),
        e => anyhow::Error::new(e).context(plan.path.display().to_string()),
    })?;
    let (summary, undefined) = solved
        .summary_json(&plan.bound, Provenance::now(Some(&plan.model)))
        .map_err(|e| anyhow::Error::new(e).context("summary.json"))?;
    let files = solved
        .write(run.out(), &plan.bound, &summary, true)
        .map_err(crate::lib)?;
    // A moment that does not exist (the kurtosis of a point start, whose variance is 0) is
    // written as null and listed under `undefined`, never a lost run.
    if let Some(first) = undefined.first() {
        crate::cli::console::sayln!(
            "note: {} numbers of summary.json have no finite value (null there, listed under `undefined`), e.g. {}",
            undefined.len(),
            first.field
        );
    }
    say(&solved, &plan.bound.states()[0]);
    let (flags, warnings): (Vec<_>, Vec<_>) = solved
        .warnings(&plan.bound)
        .into_iter()
        .partition(|w| w.flags());
    for w in warnings {
        crate::cli::console::sayln!("warning: {w}");
    }
    crate::commit_output(run, files)?;
    Ok(flags.iter().map(ToString::to_string).collect())
}

/// One line per method on the console.
fn say(h: &TransientRun, state: &str) {
    if let Some(p) = &h.periodic {
        crate::cli::console::sayln!(
            "grid periodic state, period {}: {} ({} steps per period, {} of {} stage \
             factorisations kept)",
            p.period,
            p.outcome,
            p.steps_per_period,
            p.cached_stages,
            5 * p.steps_per_period
        );
    }
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
    if let Some(p) = &h.mc_periodic {
        crate::cli::console::sayln!(
            "mc periodic state, period {}: {} periods discarded (pilot of {} trajectories over \
             {} periods: settled after {:.1}, decay time {:.2} periods), {} recorded at each phase",
            p.period,
            p.discarded_periods,
            p.pilot.trajectories,
            p.pilot.periods,
            p.pilot.settled_periods,
            p.pilot.decay_periods,
            p.recorded_periods
        );
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
