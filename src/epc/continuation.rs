//! Pseudo-arclength continuation of the Galerkin solution in a model parameter: from a family
//! member λ = 0 whose degree-n system has a known real solution towards the target λ = 1,
//! reporting whether the branch arrives or turns back at a fold (where ∂R/∂a is singular and
//! λ stops increasing along the branch).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::galerkin::GalerkinSystem;
use super::EpcError;

/// One point of a followed branch.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BranchPoint {
    /// The family parameter.
    pub lambda: f64,
    /// ‖R‖ of the degree-n system at λ (scaled variables).
    pub residual: f64,
}

/// How a followed branch ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BranchEnd {
    /// The branch reached λ = 1: the target has a real Galerkin solution on it.
    Reached,
    /// λ turned back along the branch: a fold at about this λ, beyond which this branch has
    /// no real solution.
    Fold {
        /// λ at the fold (largest λ on the branch).
        lambda: f64,
    },
    /// The continuation could not proceed (step size underflow) at this λ.
    Stalled {
        /// The last λ reached.
        lambda: f64,
    },
}

/// The followed branch.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Branch {
    /// The degree n.
    pub degree: usize,
    /// Points along the branch, in order.
    pub points: Vec<BranchPoint>,
    /// How it ended.
    pub end: BranchEnd,
    /// Scaled coefficients at λ = 1 when [`BranchEnd::Reached`].
    pub target: Option<Vec<f64>>,
}

/// R, ∂R/∂a and ∂R/∂λ at one point.
type Linearised = (DVector<f64>, DMatrix<f64>, DVector<f64>);

/// Follows R(a, λ) = 0 from (a0, 0). `system(λ)` assembles the degree-n system at λ.
pub(crate) fn follow(
    system: &dyn Fn(f64) -> Result<GalerkinSystem, EpcError>,
    a0: DVector<f64>,
    degree: usize,
) -> Result<Branch, EpcError> {
    let np = a0.len();
    let dl = 1e-5;
    // R, ∂R/∂a and ∂R/∂λ (central differences: the systems are smooth in λ).
    let eval = |a: &DVector<f64>, l: f64| -> Result<Linearised, EpcError> {
        let (r, j) = system(l)?.residual_and_jacobian(a);
        let rp = system(l + dl)?.residual_and_jacobian(a).0;
        let rm = system(l - dl)?.residual_and_jacobian(a).0;
        Ok((r, j, (rp - rm) / (2.0 * dl)))
    };
    let tangent =
        |j: &DMatrix<f64>, rl: &DVector<f64>, prev: &DVector<f64>| -> Option<DVector<f64>> {
            let mut m = DMatrix::zeros(np + 1, np + 1);
            m.view_mut((0, 0), (np, np)).copy_from(j);
            m.view_mut((0, np), (np, 1)).copy_from(rl);
            m.view_mut((np, 0), (1, np + 1))
                .copy_from(&prev.transpose());
            let mut rhs = DVector::zeros(np + 1);
            rhs[np] = 1.0;
            m.lu().solve(&rhs).map(|t| t.normalize())
        };
    let mut y = a0.clone().insert_row(np, 0.0);
    let (r, j, rl) = eval(&a0, 0.0)?;
    let mut points = vec![BranchPoint {
        lambda: 0.0,
        residual: r.norm(),
    }];
    let mut prev = DVector::zeros(np + 1);
    prev[np] = 1.0;
    let Some(mut t) = tangent(&j, &rl, &prev) else {
        return Ok(Branch {
            degree,
            points,
            end: BranchEnd::Stalled { lambda: 0.0 },
            target: None,
        });
    };
    let mut ds = 0.02;
    let mut lambda_max: f64 = 0.0;
    for _ in 0..2000 {
        let yp = &y + ds * &t;
        // Newton on [R(a, λ); tᵀ(y − y_p)] = 0.
        let mut yc = yp.clone();
        let mut ok = false;
        for _ in 0..12 {
            let a = yc.rows(0, np).into_owned();
            let (r, j, rl) = eval(&a, yc[np])?;
            let mut f = r.clone().insert_row(np, t.dot(&(&yc - &yp)));
            if r.norm() < 1e-11 * (1.0 + a.norm()) {
                ok = true;
                break;
            }
            let mut m = DMatrix::zeros(np + 1, np + 1);
            m.view_mut((0, 0), (np, np)).copy_from(&j);
            m.view_mut((0, np), (np, 1)).copy_from(&rl);
            m.view_mut((np, 0), (1, np + 1)).copy_from(&t.transpose());
            f.neg_mut();
            match m.lu().solve(&f) {
                Some(d) if d.iter().all(|v| v.is_finite()) => yc += d,
                _ => break,
            }
        }
        if !ok || (&yc - &y).norm() > 2.0 * ds.abs() {
            ds *= 0.5;
            if ds < 1e-7 {
                return Ok(Branch {
                    degree,
                    points,
                    end: BranchEnd::Stalled { lambda: y[np] },
                    target: None,
                });
            }
            continue;
        }
        let a = yc.rows(0, np).into_owned();
        let (r, j, rl) = eval(&a, yc[np])?;
        let Some(tn) = tangent(&j, &rl, &t) else {
            return Ok(Branch {
                degree,
                points,
                end: BranchEnd::Stalled { lambda: yc[np] },
                target: None,
            });
        };
        if yc[np] >= 1.0 {
            // Land exactly on λ = 1 with Newton in a from the interpolated point.
            let s = (1.0 - y[np]) / (yc[np] - y[np]);
            let mut a1 = y.rows(0, np).into_owned() + s * (&a - y.rows(0, np));
            let sys = system(1.0)?;
            for _ in 0..30 {
                let (r, j) = sys.residual_and_jacobian(&a1);
                if r.norm() < 1e-12 {
                    break;
                }
                match j.lu().solve(&(-r)) {
                    Some(d) => a1 += d,
                    None => break,
                }
            }
            let res = sys.residual_and_jacobian(&a1).0.norm();
            points.push(BranchPoint {
                lambda: 1.0,
                residual: res,
            });
            return Ok(Branch {
                degree,
                points,
                end: BranchEnd::Reached,
                target: Some(a1.iter().copied().collect()),
            });
        }
        lambda_max = lambda_max.max(yc[np]);
        points.push(BranchPoint {
            lambda: yc[np],
            residual: r.norm(),
        });
        // λ's component of the tangent changes sign at a fold.
        if tn[np] < 0.0 && t[np] > 0.0 {
            return Ok(Branch {
                degree,
                points,
                end: BranchEnd::Fold { lambda: lambda_max },
                target: None,
            });
        }
        y = yc;
        t = tn;
        ds = (ds * 1.5).min(0.1);
    }
    Ok(Branch {
        degree,
        points,
        end: BranchEnd::Stalled { lambda: y[np] },
        target: None,
    })
}
