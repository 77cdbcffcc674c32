//! The model as the grid solves it: the mechanical form (its own path, with walls, the energy
//! box and a symmetric velocity range) or the general form (drift and correlated noise in
//! both equations, no walls), read once and dispatched to by the solver.

use super::assemble::{Discretise, Operator};
use super::error::GridError;
use super::general::General;
use super::mesh::{Domain, Mesh};
use super::problem::Mechanical;
use super::{domain, general_box, pilot};
use crate::dynamics::{Dynamics, Form};

/// A model the grid solves.
#[derive(Clone, Debug)]
pub(crate) enum Problem {
    /// x' = v, noise in the velocity equation only.
    Mechanical(Mechanical),
    /// Any other 2-D system without an impact law.
    General(General),
}

impl Problem {
    /// Takes the model `dynamics` read: its mechanical form, else its general form, else why
    /// the grid cannot solve it.
    pub(crate) fn read(dynamics: &Dynamics) -> Result<Problem, GridError> {
        let model = dynamics.model();
        let barriers = dynamics
            .barriers()
            .map_err(|e| super::problem::jump_map_error(model, e))?;
        match dynamics.form() {
            Form::Mechanical => Ok(Problem::Mechanical(Mechanical::with_barriers(
                model, dynamics, barriers,
            )?)),
            Form::General { why } => Ok(Problem::General(General::new(model, dynamics, why)?)),
        }
    }

    /// The order at which the operator's cell masses converge where the density is smooth:
    /// 3 with averaged fluxes, 2 with midpoint fluxes and on the general form (what a
    /// tolerance's first refinement aims by).
    pub(crate) fn scheme_order(&self) -> f64 {
        match self {
            Problem::Mechanical(m) if m.fluxes() == super::problem::Fluxes::Averaged => 3.0,
            _ => 2.0,
        }
    }

    /// The highest order the curves' L1 estimates may take from three solves: the mechanical
    /// operator's fluxes are third order, and its cell masses converge so unless a wall's law
    /// is not elastic (the density then jumps at the wall's v = 0, a singular corner, where its fluxes are
    /// taken at the faces' midpoints: [`super::problem::Fluxes`]); the
    /// general form's operator is second order (see [`super::CURVE_ORDERS`]).
    pub(crate) fn curve_order_cap(&self) -> f64 {
        match self {
            Problem::Mechanical(m) if m.fluxes() == super::problem::Fluxes::Averaged => {
                super::SMOOTH_CURVE_ORDER
            }
            _ => super::CURVE_ORDERS[1],
        }
    }

    /// The window of the first state when it is periodic (`domain x periodic L`).
    pub(crate) fn window(&self) -> Option<[f64; 2]> {
        match self {
            Problem::Mechanical(m) => m.window,
            Problem::General(g) => g.window,
        }
    }

    /// The cells on `domain` (`align`: see [`Mesh::new`]), wrapped around in x when the
    /// first state is periodic.
    pub(crate) fn mesh(&self, domain: Domain, nx: usize, nv: usize, align: usize) -> Mesh {
        let mesh = match self {
            Problem::Mechanical(m) => Mesh::new(domain, nx, nv, &m.barriers, align),
            Problem::General(_) => Mesh::general(domain, nx, nv),
        };
        if self.window().is_some() {
            mesh.wrapped()
        } else {
            mesh
        }
    }

    /// The box sized from the density, the coarse passes it took and the density's peak.
    pub(crate) fn size(&self) -> Result<(Domain, usize, [f64; 2]), GridError> {
        if let Some(window) = self.window() {
            let v = match self {
                Problem::Mechanical(m) => pilot::pilot_box(m)?.v,
                Problem::General(g) => general_box::pilot_box(g)?.0.v,
            };
            let cells = |d: Domain, nx: usize, nv: usize| self.mesh(d, nx, nv, 1);
            let start = Domain { x: window, v };
            let guess = [0.0, 0.5 * (v[0] + v[1])];
            return general_box::size_from(self, &cells, start, guess, true);
        }
        match self {
            Problem::Mechanical(m) => domain::size(m),
            Problem::General(g) => general_box::size(g),
        }
    }

    /// A main solve's box enlarged where it cuts the density; `None` when it does not.
    pub(crate) fn grow(&self, mesh: &Mesh, p: &[f64]) -> Option<Domain> {
        if self.window().is_some() {
            return general_box::grow(mesh, p, true);
        }
        match self {
            Problem::Mechanical(m) => domain::grow(mesh, p, m).map(|d| domain::symmetrised(d, m)),
            Problem::General(_) => general_box::grow(mesh, p, false),
        }
    }

    /// A main solve's box cut where its tails end far inside it; `None` when it need not be.
    pub(crate) fn recut(&self, mesh: &Mesh, p: &[f64]) -> Option<Domain> {
        if self.window().is_some() {
            return general_box::recut(mesh, p, true);
        }
        match self {
            Problem::Mechanical(m) => domain::recut(mesh, p, m),
            Problem::General(_) => general_box::recut(mesh, p, false),
        }
    }

    /// A box given explicitly for the general form, checked: finite, each range increasing
    /// (the mechanical form's own check, which fits it to the walls, is the solver's).
    pub(crate) fn check_general_domain(d: &Domain) -> Result<Domain, GridError> {
        let ok =
            d.x[0] < d.x[1] && d.v[0] < d.v[1] && d.x.iter().chain(&d.v).all(|u| u.is_finite());
        if ok {
            Ok(*d)
        } else {
            Err(GridError::Setting {
                setting: "domain",
                value: format!("{d:?}"),
                expected: "a finite box with x_lo < x_hi and y_lo < y_hi",
            })
        }
    }

    /// Where to pin the solve on a box given explicitly: its middle (at v = 0 in the
    /// mechanical form). A pin that falls where the density is negligible is moved to the
    /// peak ([`domain::solve_pinned`]).
    pub(crate) fn centre(&self, d: &Domain) -> [f64; 2] {
        match self {
            Problem::Mechanical(_) => [0.5 * (d.x[0] + d.x[1]), 0.0],
            Problem::General(_) => [0.5 * (d.x[0] + d.x[1]), 0.5 * (d.v[0] + d.v[1])],
        }
    }
}

impl Discretise for Problem {
    fn operator(&self, mesh: &Mesh) -> Result<Operator, GridError> {
        match self {
            Problem::Mechanical(m) => m.operator(mesh),
            Problem::General(g) => g.operator(mesh),
        }
    }
}
