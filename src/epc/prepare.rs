//! What every degree of one problem shares, prepared once: the operator's coefficients, the
//! weights' σ from the Gaussian closure (or the user's), and the moment tables at a
//! quadrature order good for the largest degree.

use std::time::Instant;

use super::closure::{self, GaussianClosure};
use super::coefficients::Coefficients;
use super::error::EpcError;
use super::galerkin::{GalerkinSystem, MomentTables};
use crate::fpk::FpkOperator;

/// What every degree's solve shares: coefficients, weights and the closure.
pub(super) struct Prepared {
    pub(super) coefs: Coefficients,
    pub(super) sigma: [f64; 2],
    pub(super) closure: Option<GaussianClosure>,
    pub(super) closure_ms: f64,
}

/// The moment tables of one problem and how their quadrature order was chosen.
pub(super) struct Quadrature {
    pub(super) tables: MomentTables,
    /// Gauss nodes per piece of each axis.
    pub(super) order: usize,
    /// Whether the order came from a convergence check (non-polynomial coefficients).
    pub(super) checked: bool,
}

impl Prepared {
    /// Checks the weights `given`, builds the coefficients of `fpk` and, unless both σ were
    /// given, solves the Gaussian closure for them.
    pub(super) fn new(fpk: &FpkOperator, given: [Option<f64>; 2]) -> Result<Prepared, EpcError> {
        for (i, s) in given.iter().enumerate() {
            if let Some(v) = s {
                if !(v.is_finite() && *v > 0.0) {
                    return Err(EpcError::Weight {
                        index: i + 1,
                        value: *v,
                    });
                }
            }
        }
        let coefs = Coefficients::new(fpk)?;
        let t0 = Instant::now();
        let (sigma, closure) = match given {
            [Some(a), Some(b)] => ([a, b], None),
            _ => {
                let (kinks, _) = coefs.kinks([50.0, 50.0])?;
                let order = coefs
                    .polynomial_degree()
                    .map_or(16, |d| (d as usize + 6).div_ceil(2) + 2)
                    .max(8);
                let c = closure::gaussian_closure(&coefs, &kinks, fpk.delta_treatment, order)?;
                let sd = c.std_devs();
                (
                    [given[0].unwrap_or(sd[0]), given[1].unwrap_or(sd[1])],
                    Some(c),
                )
            }
        };
        Ok(Prepared {
            coefs,
            sigma,
            closure,
            closure_ms: t0.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Moment tables good for degree `n` (δ terms treated as `fpk` says), with the
    /// quadrature order used: raised until the assembled system changes by less than
    /// `tolerance` where the coefficients are not piecewise polynomial.
    pub(super) fn moments(
        &self,
        n: usize,
        fpk: &FpkOperator,
        tolerance: f64,
    ) -> Result<Quadrature, EpcError> {
        let prep = self;
        let s = prep.sigma;
        let (kinks, mixed) = prep.coefs.kinks([16.0 * s[0], 16.0 * s[1]])?;
        let dmax = 3 * n - 2;
        let build = |order: usize| -> Result<MomentTables, EpcError> {
            let pts = prep
                .coefs
                .points([0.0, 0.0], s, &kinks, order, fpk.delta_treatment)?;
            Ok(MomentTables::new(&pts, s, dmax))
        };
        match prep.coefs.polynomial_degree() {
            Some(d) if !mixed => {
                let order = (dmax + d as usize + 1).div_ceil(2) + 1;
                Ok(Quadrature {
                    tables: build(order)?,
                    order,
                    checked: false,
                })
            }
            _ => {
                // Not piecewise polynomial along the axes: raise the order until the assembled
                // system settles.
                let mut order = (dmax + 5).div_ceil(2) + 1;
                let mut prev = GalerkinSystem::assemble(&build(order)?, n);
                let mut change = f64::INFINITY;
                while order < 120 {
                    let next_order = order + 8;
                    let mom = build(next_order)?;
                    let sys = GalerkinSystem::assemble(&mom, n);
                    change = sys.max_difference(&prev) / sys.scale().max(f64::MIN_POSITIVE);
                    order = next_order;
                    if change < tolerance {
                        return Ok(Quadrature {
                            tables: mom,
                            order,
                            checked: true,
                        });
                    }
                    prev = sys;
                }
                Err(EpcError::Quadrature { order, change })
            }
        }
    }
}
