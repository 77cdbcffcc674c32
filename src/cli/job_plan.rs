//! The main job's and `solve`'s plan: the model, the methods that run (each checked against
//! the model), the grid's cells, the Monte Carlo reference (run or read), all before any work.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use fpsolve::base::limits::memory_limit_bytes;
use fpsolve::grid::Cells;
use fpsolve::grid::{front_end_tolerance, DEFAULT_CELLS};
use fpsolve::job::{JobSpec, McFrom, Target};
use fpsolve::mc::McConfig;
use fpsolve::solve::{MethodName, MethodSet, Problem};
use fpsolve::study::MethodPlan;

use crate::cli::domain_flag::{grid_domain, grid_tolerance};
use crate::{at_error, default_out, flag, lib, load, read_input, Plan, SolveArgs};

/// The methods when `--method` is not given: the main job's ([`fpsolve::job::default_methods`],
/// each run where it applies), EPC for `solve`.
fn default_methods(target: Target, problem: &Problem) -> Result<MethodSet> {
    match target {
        Target::Observables => fpsolve::job::default_methods(problem).map_err(lib),
        Target::States => Ok(MethodSet::new(vec![MethodName::Epc]).expect("one method")),
    }
}

pub(crate) fn plan_job(
    path: PathBuf,
    args: &SolveArgs,
    mc: Option<McConfig>,
    mc_from: Option<&Path>,
    target: Target,
) -> Result<Plan> {
    let (model, overrides, bound) = load(&path, &args.set.set)?;
    // A model without a stationary density, or with methods that do not apply to it, is
    // refused here, before any work.
    // Kept for the run, which would otherwise derive it again.
    let problem = Problem::owning(bound).map_err(at_error(&path))?;
    let (methods, named) = match &args.method {
        Some(m) => (m.clone(), true),
        None => (default_methods(target, &problem)?, false),
    };
    let domain = grid_domain(args.domain.as_deref(), &methods, problem.dynamics())?;
    let tol = grid_tolerance(args.tol, args.cells, &methods)?;
    let plan = MethodPlan::new(&problem, &methods, named).map_err(|e| {
        anyhow::Error::new(fpsolve::job::JobError::from(e)).context(path.display().to_string())
    })?;
    let cells = match args.cells {
        Some(c) if !methods.contains(MethodName::Grid) => {
            bail!("--cells {c}: the grid solver is not among the methods ({methods})")
        }
        Some(c) => c,
        None => Cells(DEFAULT_CELLS),
    };
    // The main job skips a grid that does not apply; a tolerance asked of it is refused.
    if let (Some(tol), false) = (tol, plan.run.contains(&MethodName::Grid)) {
        let why = plan.skipped.iter().find(|s| s.method == MethodName::Grid);
        match why {
            Some(s) => bail!("--tol {tol}: the grid solver does not apply: {}", s.why),
            None => bail!("--tol {tol}: the grid solver does not run"),
        }
    }
    // Without --cells or --tol the grid is solved to the default tolerance.
    let grid_runs = plan.run.contains(&MethodName::Grid);
    let tol = if grid_runs {
        front_end_tolerance(tol, args.cells.is_some())
    } else {
        tol
    };
    if grid_runs && tol.is_none() {
        cells
            .within(memory_limit_bytes())
            .map_err(flag("--cells"))?;
    }
    let problem = problem.with_grid_domain(domain).with_grid_tolerance(tol);
    let bound = problem.model();
    if let Some(config) = &mc {
        config.preflight_of(problem.dynamics()).map_err(lib)?;
    }
    let mc_from = match mc_from {
        Some(dir) => {
            read_input(dir);
            Some(Box::new(
                McFrom::read(dir, bound).map_err(flag("--mc-from"))?,
            ))
        }
        None => None,
    };
    Ok(Plan::Job {
        out: default_out(args.out.clone(), &model),
        problem: Box::new(problem),
        spec: JobSpec {
            degrees: args.degree.as_slice().to_vec(),
            overrides,
            target,
            methods,
            methods_named: named,
            cells: cells.0,
            mc,
            mc_from,
            mc_bins: 100,
            figures: target == Target::Observables,
        },
        path,
        model,
        quiet: args.quiet.quiet,
    })
}
