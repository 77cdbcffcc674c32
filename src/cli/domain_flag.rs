//! `--domain x=LO:HI,v=LO:HI`: the grid solver's box, read with the model's state names and
//! checked against its walls before any work.

use anyhow::{bail, Result};
use fpsolve::grid::{Domain, GridSolver};
use fpsolve::model::BoundModel;
use fpsolve::solve::{MethodName, MethodSet};

use crate::flag;

/// The box `--domain` gives, checked: parsed ([`Domain::parse_named`]: finite ends, lower
/// below upper, 0 inside the velocity's range), the grid among `methods`, and the box fits
/// the model's walls ([`GridSolver::check`]: a reflecting wall's side ends on the wall, a
/// strip's ends stay inside it). `None` when the flag is not given.
pub(crate) fn grid_domain(
    text: Option<&str>,
    methods: &MethodSet,
    model: &BoundModel,
) -> Result<Option<Domain>> {
    let Some(text) = text else {
        return Ok(None);
    };
    if !methods.contains(MethodName::Grid) {
        bail!("--domain {text}: the grid solver is not among the methods ({methods})");
    }
    let [x, v] = model.states();
    let domain = Domain::parse_named(text, [x, v]).map_err(flag("--domain"))?;
    GridSolver::new(model)
        .domain(domain)
        .check()
        .map_err(flag("--domain"))?;
    Ok(Some(domain))
}
