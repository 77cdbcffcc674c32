//! `--domain x=LO:HI,v=LO:HI`: the grid solver's box, read with the model's state names and
//! checked against its walls before any work; `--tol L1`: its accuracy, checked likewise.

use anyhow::{bail, Result};
use fpsolve::dynamics::Dynamics;
use fpsolve::grid::{check_tolerance, Cells, Domain, GridSolver};
use fpsolve::model::Model;
use fpsolve::solve::{MethodName, MethodSet};

use crate::flag;

/// The box `--domain` gives, checked: parsed ([`Domain::parse_named`]: finite ends, lower
/// below upper, 0 inside the velocity's range), the grid among `methods`, and the box fits
/// the model's walls ([`GridSolver::check`]: a reflecting wall's side ends on the wall, a
/// strip's ends stay inside it). `None` when the flag is not given.
pub(crate) fn grid_domain(
    text: Option<&str>,
    methods: &MethodSet,
    dynamics: &Dynamics,
) -> Result<Option<Domain>> {
    let Some(domain) = parsed(text, methods, dynamics.states())? else {
        return Ok(None);
    };
    GridSolver::reading(dynamics)
        .domain(domain)
        .check()
        .map_err(flag("--domain"))?;
    Ok(Some(domain))
}

/// The L1 tolerance `--tol` asks of the grid solver, checked before any work: within
/// (0, 0.5] ([`check_tolerance`]), not with `--cells` (which fix what the tolerance
/// chooses), the grid among `methods`. `None` when the flag is not given.
pub(crate) fn grid_tolerance(
    tol: Option<f64>,
    cells: Option<Cells>,
    methods: &MethodSet,
) -> Result<Option<f64>> {
    let Some(tol) = tol else {
        return Ok(None);
    };
    check_tolerance(tol).map_err(flag("--tol"))?;
    if let Some(c) = cells {
        bail!("--tol {tol} with --cells {c}: give one (the tolerance chooses the cells)");
    }
    if !methods.contains(MethodName::Grid) {
        bail!("--tol {tol}: the grid solver is not among the methods ({methods})");
    }
    Ok(Some(tol))
}

/// The box `fpsolve sweep --domain` gives, parsed as `solve`'s (the model's state names) with
/// the grid among `methods`; whether it fits the walls is checked at every point by
/// [`fpsolve::sweep::Sweep::check`]. `None` when the flag is not given.
pub(crate) fn sweep_domain(
    text: Option<&str>,
    methods: &MethodSet,
    model: &Model,
) -> Result<Option<Domain>> {
    parsed(text, methods, model.states())
}

/// `--domain`'s text read with the model's state names, the grid among `methods`.
fn parsed(
    text: Option<&str>,
    methods: &MethodSet,
    [x, v]: &[std::sync::Arc<str>; 2],
) -> Result<Option<Domain>> {
    let Some(text) = text else {
        return Ok(None);
    };
    if !methods.contains(MethodName::Grid) {
        bail!("--domain {text}: the grid solver is not among the methods ({methods})");
    }
    Ok(Some(
        Domain::parse_named(text, [x, v]).map_err(flag("--domain"))?,
    ))
}
