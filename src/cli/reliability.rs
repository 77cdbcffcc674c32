//! `fpsolve reliability MODEL` (alias `fpsolve passage`): first passage out of the safe set
//! on the grid and by Monte Carlo. Flags are read and checked (the model, `--safe`, the start
//! inside the set, the times, the cells, the box, the methods and the Monte Carlo's paths,
//! dt, horizon and seed) before any solve; writes `reliability.csv`, `first_passage_pdf.csv`
//! (with Monte Carlo), `quasi_stationary_<state>.csv` (when the grid found the decay), the
//! stationary crossing tables `crossings_<q>.csv` and impact-speed tables (with the grid, for
//! a model with a stationary density), the figures `reliability`, `first_passage_pdf` and
//! `crossings_<q>` (PNG and SVG) and `summary.json`; with `--mean-only`, the mean
//! first-passage times alone, in `summary.json` (which lists what was not computed and why).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use clap::Args;
use fpsolve::grid::{Cells, Domain};
use fpsolve::job::passage::{
    parse_pair, parse_times, McSettings, PassageRun, PassageRunError, PassageScope,
    PassageSettings, StationaryReport,
};
use fpsolve::model::{BoundModel, BoundSafe};
use fpsolve::report::write_json;

/// The flags of `fpsolve reliability`.
#[derive(Args, Debug)]
pub(crate) struct ReliabilityArgs {
    /// The safe set, overriding the model's `safe` line (`abs(z) < 2.5`, `-2 < z < 3`).
    #[arg(long, value_name = "SET", allow_hyphen_values = true)]
    safe: Option<String>,
    /// The start (position, velocity); default rest, 0,0.
    #[arg(long, value_name = "X,V", allow_hyphen_values = true)]
    start: Option<String>,
    /// Output times of R(t): FIRST:LAST:COUNT (COUNT >= 2, 0 <= FIRST < LAST); default 101
    /// times to --horizon, else to 5 of the grid's mean times from the start.
    #[arg(long, value_name = "A:B:N")]
    times: Option<String>,
    /// Only the mean first-passage times: E[T] and E[T²] from the start and from the
    /// stationary density in the set, with their estimated errors (Monte Carlo's mean and
    /// variance with `mc`), in summary.json; no R(t), decay, figures or stationary crossing
    /// tables (listed under `not_computed`). Not with --times.
    #[arg(long = "mean-only", conflicts_with = "times")]
    mean_only: bool,
    /// Cells of the grid, position and velocity (default 200,400).
    #[arg(long, value_name = "NX,NV")]
    cells: Option<Cells>,
    /// The grid's box, x=LO:HI,v=LO:HI (or the model's state names), instead of one sized
    /// from the stationary density; a model without one (no damping) needs it, with the safe
    /// set ending inside it along the position.
    #[arg(long, value_name = "x=LO:HI,v=LO:HI", allow_hyphen_values = true)]
    domain: Option<String>,
    /// Methods: `grid`, `mc` or both (default `grid,mc`).
    #[arg(long, value_name = "M,...", default_value = "grid,mc")]
    method: String,
    /// Monte Carlo paths (default 10000).
    #[arg(long, value_name = "N", default_value_t = 10_000)]
    paths: u64,
    /// Monte Carlo time step (default 0.01; the bias estimate runs again at 2·dt).
    #[arg(long, value_name = "DT", default_value_t = 0.01)]
    dt: f64,
    /// Monte Carlo horizon, paths still inside then are censored (default: the last of
    /// --times, else 20 times the grid's mean time).
    #[arg(long, value_name = "T")]
    horizon: Option<f64>,
    /// Monte Carlo seed (default 1).
    #[arg(long, value_name = "N", default_value_t = 1)]
    seed: u64,
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Output directory (default: out/<model name>_reliability).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// A checked `reliability` command.
pub(crate) struct ReliabilityPlan {
    path: PathBuf,
    bound: BoundModel,
    safe: BoundSafe,
    settings: PassageSettings,
    out: PathBuf,
}

/// Reads and checks everything before any solve.
pub(crate) fn plan(path: PathBuf, args: ReliabilityArgs) -> Result<ReliabilityPlan> {
    let methods: Vec<&str> = args.method.split(',').map(str::trim).collect();
    if methods.is_empty() || methods.iter().any(|m| !matches!(*m, "grid" | "mc")) {
        return Err(anyhow!(
            "--method {}: expected `grid`, `mc` or `grid,mc`",
            args.method
        ));
    }
    let grid = methods.contains(&"grid");
    let (model, bound) = crate::load_amended(&path, &args.set, |model| match &args.safe {
        Some(text) => model.with_safe(text).map_err(crate::lib),
        None => Ok(model),
    })?;
    let safe = model
        .safe()
        .ok_or_else(|| {
            anyhow!(
                "{}: no safe set: add a `safe` line to the model or give --safe",
                path.display()
            )
        })?
        .bind(&bound)
        .map_err(|e| anyhow::Error::new(e).context(path.display().to_string()))?;
    let start = match &args.start {
        None => [0.0, 0.0],
        Some(s) => parse_pair(s)
            .map_err(anyhow::Error::new)
            .context("--start")?,
    };
    if !safe.contains(start) {
        return Err(anyhow!(
            "--start {},{}: not inside the safe set `{}`",
            start[0],
            start[1],
            safe.text
        ));
    }
    let times = match &args.times {
        None => Vec::new(),
        Some(s) => parse_times(s)
            .map_err(anyhow::Error::new)
            .context("--times")?,
    };
    let cells = args.cells.unwrap_or_default().0;
    fpsolve::grid::check_cells(cells).map_err(|e| anyhow::Error::new(e).context("--cells"))?;
    let states = bound.states();
    let domain = match &args.domain {
        None => None,
        Some(_) if !grid => {
            return Err(anyhow!(
                "--domain: only the grid uses a box (--method grid or grid,mc)"
            ))
        }
        Some(text) => Some(
            Domain::parse_named(text, [&*states[0], &*states[1]])
                .map_err(|e| anyhow::Error::new(e).context("--domain"))?,
        ),
    };
    let mc = methods.contains(&"mc").then_some(McSettings {
        paths: args.paths,
        dt: args.dt,
        horizon: args.horizon.or_else(|| times.last().copied()),
        seed: args.seed,
    });
    if let Some(m) = &mc {
        if m.horizon.is_none() && !grid {
            return Err(if args.mean_only {
                anyhow!(
                    "--method mc --mean-only: give --horizon (without the grid there is no \
                     mean time to set the horizon from)"
                )
            } else {
                anyhow!(
                    "--method mc: give --horizon or --times (without the grid there is no \
                     mean time to set the horizon from)"
                )
            });
        }
        // Every setting checked now, before any work (a placeholder horizon when it comes
        // from the grid's mean time).
        m.check(&bound, &safe, start).map_err(|e| {
            let flag = match &e {
                fpsolve::mc::McError::BadSetting { name, .. } => format!("--{name}"),
                _ => "--method mc".into(),
            };
            crate::lib(e).context(flag)
        })?;
    } else if args.horizon.is_some() {
        return Err(anyhow!(
            "--horizon: only the Monte Carlo uses it (--method mc)"
        ));
    }
    let settings = PassageSettings {
        start,
        times,
        cells,
        domain,
        grid,
        mc,
        scope: if args.mean_only {
            PassageScope::MeanTimes
        } else {
            PassageScope::Full
        },
    };
    if grid {
        // The box against the walls and the start, and a model without a stationary density
        // without a box: refused now, before any solve.
        settings.grid_passage(&bound, &safe).check().map_err(|e| {
            let e = anyhow::Error::new(e);
            match domain {
                Some(_) => e.context("--domain"),
                None => e.context(path.display().to_string()),
            }
        })?;
    }
    let out = args
        .out
        .unwrap_or_else(|| Path::new("out").join(format!("{}_reliability", model.name())));
    Ok(ReliabilityPlan {
        path,
        bound,
        safe,
        settings,
        out,
    })
}

/// Solves and writes the output directory.
pub(crate) fn run(plan: ReliabilityPlan) -> Result<()> {
    let run = crate::begin_output(&plan.out)?;
    let solved = PassageRun::solve(&plan.bound, &plan.safe, &plan.settings)
        .map_err(|e| match e {
            PassageRunError::Grid(e) => anyhow::Error::new(e),
            PassageRunError::Mc(e) => crate::lib(e),
        })
        .with_context(|| plan.path.display().to_string())?;
    let start = plan.settings.start;
    let mut summary = solved.summary(
        fpsolve::report::Provenance::now_bound(&plan.bound),
        crate::command_line(),
        plan.path.display().to_string(),
        &plan.bound,
        &plan.safe,
        start,
    );
    let mut files = 1;
    if plan.settings.scope == PassageScope::Full {
        files += write_tables(&plan, &solved, run.out(), &mut summary)?;
    }
    write_json(run.out(), "summary.json", &summary).map_err(crate::lib)?;
    say(&plan, &solved, &summary);
    crate::commit_output(run, files)
}

/// Writes the tables and figures of a full run (R(t), the first-passage-time density, the
/// quasi-stationary density, the stationary crossing and impact tables), noting in `summary`
/// those that could not be written; returns the count written.
fn write_tables(
    plan: &ReliabilityPlan,
    solved: &PassageRun,
    out: &fpsolve::report::OutputDir,
    summary: &mut fpsolve::job::passage::PassageSummary<'_>,
) -> Result<usize> {
    out.write_atomic("reliability.csv", solved.csv().as_bytes())
        .map_err(crate::lib)?;
    let mut files = 1;
    if let Some(csv) = solved.pdf_csv() {
        out.write_atomic("first_passage_pdf.csv", csv.as_bytes())
            .map_err(crate::lib)?;
        files += 1;
    }
    if let Some([qx, qv]) = solved
        .grid
        .as_ref()
        .and_then(|g| g.quasi_stationary.as_ref())
    {
        let states = plan.bound.states();
        for (q, name) in [(qx, &states[0]), (qv, &states[1])] {
            let mut csv = format!("{name},quasi_stationary\n");
            for (x, p) in q.centres.iter().zip(&q.density) {
                csv.push_str(&format!("{x},{p}\n"));
            }
            out.write_atomic(&format!("quasi_stationary_{name}.csv"), csv.as_bytes())
                .map_err(crate::lib)?;
            files += 1;
        }
    }
    // The figures and the stationary tables before summary.json, which lists those not
    // written.
    let mut figures = solved.write_figures(out, &plan.bound, &plan.safe, plan.settings.start);
    let stationary = solved.write_stationary(out, &plan.bound);
    figures.files.extend(stationary.files);
    figures.unwritten.extend(stationary.unwritten);
    files += figures.files.len();
    summary.unwritten = figures.unwritten;
    Ok(files)
}

/// The console's report of a finished run.
fn say(
    plan: &ReliabilityPlan,
    solved: &PassageRun,
    summary: &fpsolve::job::passage::PassageSummary<'_>,
) {
    let start = plan.settings.start;
    let (grid, mc) = (&solved.grid, &solved.mc);
    if let Some(g) = &grid {
        let pm = |e: Option<f64>| e.map_or(String::new(), |e| format!(" ± {e:.2e}"));
        let e = g.errors.as_ref();
        let stationary = match g.mean_stationary {
            Some(m) => format!("{m:.6}{}", pm(e.and_then(|e| e.mean_stationary))),
            None => "none (no stationary density)".into(),
        };
        crate::cli::console::sayln!(
            "mean first-passage time from ({}, {}): {:.6}{} (grid {}x{}{}); stationary start: {}",
            start[0],
            start[1],
            g.mean_at_start,
            pm(e.map(|e| e.mean_at_start)),
            plan.settings.cells[0],
            plan.settings.cells[1],
            g.report.estimate_cells.map_or(String::new(), |c| format!(
                ", errors from {}x{}",
                c[0], c[1]
            )),
            stationary
        );
        match &g.decay {
            fpsolve::grid::DecayOutcome::Found(d) => crate::cli::console::sayln!(
                "slowest decay: R(t) ~ {:.6} exp(-{:.6e} t) beyond the transients (1/lambda \
                 {:.6}; quasi-stationary density in quasi_stationary_*.csv)",
                d.amplitude,
                d.rate,
                1.0 / d.rate
            ),
            fpsolve::grid::DecayOutcome::NotFound { reason } => {
                crate::cli::console::sayln!("slowest decay: not found ({reason})")
            }
            // Said once below, with the other parts not computed.
            fpsolve::grid::DecayOutcome::NotComputed => {}
        }
    }
    if let Some(m) = &mc {
        match m.mean {
            Some(e) => crate::cli::console::sayln!(
                "Monte Carlo: mean {:.6} ± {:.6} (SE, {} paths, dt {}; time-step bias {:.2e} ± {:.1e})",
                e.value,
                e.stderr,
                m.paths,
                m.dt,
                m.bias.value,
                m.bias.stderr
            ),
            None => crate::cli::console::sayln!(
                "Monte Carlo: {:.1} % of paths censored at the horizon {}: the mean is at least \
                 {:.6} ± {:.6} (a lower bound, not the mean)",
                100.0 * m.censored_fraction,
                m.horizon,
                m.mean_lower_bound.value,
                m.mean_lower_bound.stderr
            ),
        }
    }
    if let Some(s) = &solved.stationary {
        match &s.report {
            StationaryReport::Computed { .. } => {
                let files: Vec<&str> = summary
                    .reliability
                    .crossings
                    .iter()
                    .map(|c| c.file.as_str())
                    .collect();
                if !files.is_empty() {
                    crate::cli::console::sayln!("stationary crossing rates: {}", files.join(", "));
                }
                for w in &summary.reliability.impacts {
                    let pm = |e: Option<f64>, se: Option<f64>| match (e, se) {
                        (Some(e), _) => format!(" ± {e:.2e}"),
                        (None, Some(se)) => format!(" ± {se:.2e} (SE)"),
                        _ => String::new(),
                    };
                    let se = w.stderr.map(|s| s[0]);
                    let se_speed = w.stderr.map(|s| s[1]);
                    crate::cli::console::sayln!(
                        "impacts at {} = {} ({}): rate {:.6}{}, mean speed {:.6}{}",
                        w.state,
                        w.at,
                        w.method,
                        w.rate,
                        pm(w.rate_error, se),
                        w.mean_speed,
                        pm(w.mean_speed_error, se_speed)
                    );
                }
            }
            StationaryReport::NotComputed { why } => {
                crate::cli::console::sayln!(
                    "stationary crossing rates and impacts: not computed ({why})"
                )
            }
        }
    }
    if let Some(d) = &summary.method_distances {
        if let Some(worst) = d.worst {
            let flagged = d.flagged().count();
            crate::cli::console::sayln!(
                "method distance |grid - MC| / (MC SE + grid error): worst {:.2} ({}){}",
                worst.distance.unwrap_or(f64::NAN),
                worst.compared,
                match flagged {
                    0 => String::new(),
                    n => format!(
                        "; {n} flagged (more than {} SE plus the grid's error apart)",
                        fpsolve::job::passage::DISAGREE_SE
                    ),
                }
            );
        }
    }
    for warning in solved.warnings() {
        crate::cli::console::sayln!("warning: {warning}");
    }
    for u in &summary.unwritten {
        crate::cli::console::sayln!("warning: {} was not written: {}", u.file, u.error);
    }
    if let Some(first) = summary.not_computed.first() {
        let parts: Vec<String> = summary
            .not_computed
            .iter()
            .map(|n| n.what.to_string())
            .collect();
        crate::cli::console::sayln!("not computed ({}): {}", first.why, parts.join("; "));
    }
}
