//! Pseudo-arclength continuation of the Galerkin solution in a model parameter: from a family
//! member λ = 0 whose degree-n system has a known real solution towards the target λ = 1,
//! reporting whether the branch arrives or turns back at a fold (where ∂R/∂a is singular and
//! λ stops increasing along the branch).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::galerkin::GalerkinSystem;
use super::EpcError;

/// One point of a followed branch.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let family = |l: f64| {
///     FpkOperator::derive(&model.bind(&[fpsolve::model::Override::number("c", 0.1 + 0.1 * l)])
///         .unwrap()).map_err(|e| e.to_string())
/// };
/// let branch = Epc::new(&fpk).degree(2).branch(&family).unwrap();
/// // Every point of the branch solves its system.
/// assert!(branch.points.iter().all(|p: &BranchPoint| p.residual < 1e-9));
/// ```
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BranchPoint {
    /// The family parameter.
    pub lambda: f64,
    /// ‖R‖ of the degree-n system at λ (scaled variables).
    pub residual: f64,
}

/// How a followed branch ended.
///
/// ```
/// use fpsolve::epc::BranchEnd;
/// let end = BranchEnd::Fold { lambda: 0.257 };
/// assert!(matches!(end, BranchEnd::Fold { lambda } if lambda < 1.0));
/// ```
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
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let family = |l: f64| {
///     FpkOperator::derive(&model.bind(&[fpsolve::model::Override::number("c", 0.1 + 0.1 * l)])
///         .unwrap()).map_err(|e| e.to_string())
/// };
/// let branch: Branch = Epc::new(&fpk).degree(2).branch(&family).unwrap();
/// assert_eq!((branch.degree, branch.end), (2, BranchEnd::Reached));
/// assert_eq!(branch.target.map(|a| a.len()), Some(5));
/// ```
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
pub(crate) type Linearised = (DVector<f64>, DMatrix<f64>, DVector<f64>);

/// A homotopy H(a, λ) with its derivatives: `eval(a, λ)` gives H, ∂H/∂a and ∂H/∂λ.
pub(crate) type Homotopy<'a> = dyn Fn(&DVector<f64>, f64) -> Result<Linearised, EpcError> + 'a;

/// How a traced path ended (internal form of [`BranchEnd`], with the root when reached).
#[derive(Clone, Debug)]
pub(crate) enum PathEnd {
    /// λ reached 1; the corrected root there.
    Reached(DVector<f64>),
    /// λ turned back (only reported when the trace stops at folds).
    Fold { lambda: f64 },
    /// The step size underflowed or the augmented system became singular at this λ.
    Stalled { lambda: f64 },
    /// The path left every bounded region (‖a‖ beyond the limit) or λ fell below the limit.
    Escaped { lambda: f64 },
    /// The step budget ran out at this λ.
    Budget { lambda: f64 },
}

/// A traced path: its points and how it ended.
pub(crate) struct Path {
    pub points: Vec<BranchPoint>,
    pub end: PathEnd,
    /// The largest λ the path reached.
    pub lambda_max: f64,
    /// λ at each fold where the path turned from increasing to decreasing λ.
    pub folds: Vec<f64>,
}

/// Options of [`trace`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct TraceOptions {
    /// Stop at the first fold (λ turning back) instead of following the path through it.
    pub stop_at_fold: bool,
    /// Most predictor–corrector steps.
    pub max_steps: usize,
    /// First arclength step.
    pub first_step: f64,
    /// Largest arclength step.
    pub max_step: f64,
    /// ‖a‖ beyond which the path counts as escaped.
    pub max_norm: f64,
    /// λ below which the path counts as escaped (it turned back towards λ < 0).
    pub min_lambda: f64,
}

/// Follows H(a, λ) = 0 from (a0, 0), where `eval(a, λ)` gives H, ∂H/∂a and ∂H/∂λ, by
/// pseudo-arclength continuation (predictor along the tangent, Newton corrector on
/// [H; tᵀ(y − y_pred)] = 0) until λ reaches 1, where the root is polished by Newton in a with
/// λ = 1 held fixed.
pub(crate) fn trace(
    eval: &Homotopy,
    a0: DVector<f64>,
    opts: TraceOptions,
) -> Result<Path, EpcError> {
    let np = a0.len();
    // The augmented matrix [∂H/∂a ∂H/∂λ; cᵀ], nonsingular at regular points and simple folds.
    let augmented = |j: &DMatrix<f64>, hl: &DVector<f64>, c: &DVector<f64>| {
        let mut m = DMatrix::zeros(np + 1, np + 1);
        m.view_mut((0, 0), (np, np)).copy_from(j);
        m.view_mut((0, np), (np, 1)).copy_from(hl);
        m.view_mut((np, 0), (1, np + 1)).copy_from(&c.transpose());
        m
    };
    // The unit tangent oriented like `prev` (the kernel of [∂H/∂a ∂H/∂λ]).
    let tangent = |j: &DMatrix<f64>, hl: &DVector<f64>, prev: &DVector<f64>| {
        let mut rhs = DVector::zeros(np + 1);
        rhs[np] = 1.0;
        augmented(j, hl, prev)
            .lu()
            .solve(&rhs)
            .filter(|t| t.iter().all(|v| v.is_finite()))
            .map(|t| t.normalize())
    };
    let mut y = a0.clone().insert_row(np, 0.0);
    let (h, j, hl) = eval(&a0, 0.0)?;
    let mut points = vec![BranchPoint {
        lambda: 0.0,
        residual: h.norm(),
    }];
    let mut lambda_max: f64 = 0.0;
    let mut folds = Vec::new();
    let done = |points, end, lambda_max, folds| {
        Ok(Path {
            points,
            end,
            lambda_max,
            folds,
        })
    };
    let mut prev = DVector::zeros(np + 1);
    prev[np] = 1.0;
    let Some(mut t) = tangent(&j, &hl, &prev) else {
        return done(points, PathEnd::Stalled { lambda: 0.0 }, 0.0, folds);
    };
    let scale = 1.0 + a0.norm();
    let mut ds = opts.first_step;
    for _ in 0..opts.max_steps {
        let yp = &y + ds * &t;
        // Newton on [H(a, λ); tᵀ(y − y_p)] = 0.
        let mut yc = yp.clone();
        let mut ok = false;
        let mut lin = None;
        let mut last_step = f64::INFINITY;
        for _ in 0..12 {
            let a = yc.rows(0, np).into_owned();
            let (h, j, hl) = eval(&a, yc[np])?;
            if h.norm() < 1e-11 * (1.0 + a.norm()) {
                ok = true;
                lin = Some((h.norm(), j, hl));
                break;
            }
            let mut f = h.insert_row(np, t.dot(&(&yc - &yp)));
            f.neg_mut();
            match augmented(&j, &hl, &t).lu().solve(&f) {
                // Near the path Newton contracts fast; a correction that does not at least
                // halve means the predictor went too far: give up and shorten the step.
                Some(d) if d.iter().all(|v| v.is_finite()) && d.norm() < 0.5 * last_step => {
                    last_step = d.norm();
                    yc += d;
                }
                _ => break,
            }
        }
        // Reject corrections that jump far from the predictor (possibly onto another branch).
        if !ok || (&yc - &yp).norm() > ds {
            ds *= 0.5;
            if ds < 1e-9 * scale {
                return done(
                    points,
                    PathEnd::Stalled { lambda: y[np] },
                    lambda_max,
                    folds,
                );
            }
            continue;
        }
        let (residual, j, hl) = lin.expect("set with ok");
        let Some(tn) = tangent(&j, &hl, &t) else {
            return done(
                points,
                PathEnd::Stalled { lambda: yc[np] },
                lambda_max,
                folds,
            );
        };
        let a = yc.rows(0, np).into_owned();
        if yc[np] >= 1.0 {
            // Land on λ = 1: interpolate, then Newton in a with λ fixed.
            let s = (1.0 - y[np]) / (yc[np] - y[np]);
            let mut a1 = y.rows(0, np).into_owned() + s * (&a - y.rows(0, np));
            for _ in 0..30 {
                let (h, j, _) = eval(&a1, 1.0)?;
                if h.norm() < 1e-13 * (1.0 + a1.norm()) {
                    break;
                }
                match j.lu().solve(&(-h)) {
                    Some(d) if d.iter().all(|v| v.is_finite()) => a1 += d,
                    _ => break,
                }
            }
            let res = eval(&a1, 1.0)?.0.norm();
            points.push(BranchPoint {
                lambda: 1.0,
                residual: res,
            });
            return done(points, PathEnd::Reached(a1), 1.0, folds);
        }
        lambda_max = lambda_max.max(yc[np]);
        points.push(BranchPoint {
            lambda: yc[np],
            residual,
        });
        // λ's component of the tangent changes sign at a fold.
        if tn[np] < 0.0 && t[np] > 0.0 {
            folds.push(yc[np]);
        }
        if opts.stop_at_fold && !folds.is_empty() {
            return done(
                points,
                PathEnd::Fold { lambda: lambda_max },
                lambda_max,
                folds,
            );
        }
        if a.norm() > opts.max_norm || yc[np] < opts.min_lambda {
            return done(
                points,
                PathEnd::Escaped { lambda: yc[np] },
                lambda_max,
                folds,
            );
        }
        y = yc;
        t = tn;
        ds = (ds * 2.0).min(opts.max_step);
    }
    done(points, PathEnd::Budget { lambda: y[np] }, lambda_max, folds)
}

/// Follows R(a, λ) = 0 from (a0, 0) up to the first fold. `system(λ)` assembles the degree-n
/// system at λ.
pub(crate) fn follow(
    system: &dyn Fn(f64) -> Result<GalerkinSystem, EpcError>,
    a0: DVector<f64>,
    degree: usize,
) -> Result<Branch, EpcError> {
    let dl = 1e-5;
    // ∂R/∂λ by central differences: the systems are smooth in λ.
    let eval = |a: &DVector<f64>, l: f64| -> Result<Linearised, EpcError> {
        let (r, j) = system(l)?.residual_and_jacobian(a);
        let rp = system(l + dl)?.residual_and_jacobian(a).0;
        let rm = system(l - dl)?.residual_and_jacobian(a).0;
        Ok((r, j, (rp - rm) / (2.0 * dl)))
    };
    let opts = TraceOptions {
        stop_at_fold: true,
        max_steps: 2000,
        first_step: 0.02,
        max_step: 0.1,
        max_norm: f64::INFINITY,
        min_lambda: f64::NEG_INFINITY,
    };
    let path = trace(&eval, a0, opts)?;
    let (end, target) = match path.end {
        PathEnd::Reached(a) => (BranchEnd::Reached, Some(a.iter().copied().collect())),
        PathEnd::Fold { lambda } => (BranchEnd::Fold { lambda }, None),
        PathEnd::Stalled { lambda } | PathEnd::Escaped { lambda } | PathEnd::Budget { lambda } => {
            (BranchEnd::Stalled { lambda }, None)
        }
    };
    Ok(Branch {
        degree,
        points: path.points,
        end,
        target,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// H(a, λ) = (a³ − 3a)/8 + 1/2 − λ: an S-shaped path from a ≈ −2.196 at λ = 0 that folds at
    /// λ = 3/4 (a = −1) and λ = 1/4 (a = 1) before reaching λ = 1 at a ≈ 2.196.
    fn s_curve(a: &DVector<f64>, l: f64) -> Result<Linearised, EpcError> {
        let x = a[0];
        Ok((
            DVector::from_element(1, (x * x * x - 3.0 * x) / 8.0 + 0.5 - l),
            DMatrix::from_element(1, 1, (3.0 * x * x - 3.0) / 8.0),
            DVector::from_element(1, -1.0),
        ))
    }

    /// The real root of a³ − 3a = c for |c| > 2.
    fn cubic_root(c: f64) -> f64 {
        let mut x = 2.0 * c.signum();
        for _ in 0..60 {
            x -= (x * x * x - 3.0 * x - c) / (3.0 * x * x - 3.0);
        }
        x
    }

    fn options(stop_at_fold: bool) -> TraceOptions {
        TraceOptions {
            stop_at_fold,
            max_steps: 500,
            first_step: 0.05,
            max_step: 0.2,
            max_norm: 100.0,
            min_lambda: -1.0,
        }
    }

    #[test]
    fn trace_follows_the_path_through_folds_to_lambda_one() {
        let a0 = DVector::from_element(1, cubic_root(-4.0));
        let path = trace(&s_curve, a0, options(false)).unwrap();
        let PathEnd::Reached(a) = path.end else {
            panic!("expected to reach λ = 1: {:?}", path.end)
        };
        approx::assert_relative_eq!(a[0], cubic_root(4.0), max_relative = 1e-12);
        assert_eq!(path.folds.len(), 1, "{:?}", path.folds);
        approx::assert_relative_eq!(path.folds[0], 0.75, epsilon = 0.02);
        // The path went back down to the second fold at λ = 1/4 on its way.
        let low = path
            .points
            .iter()
            .skip_while(|p| p.lambda < 0.7)
            .map(|p| p.lambda)
            .fold(f64::INFINITY, f64::min);
        approx::assert_relative_eq!(low, 0.25, epsilon = 0.02);
    }

    #[test]
    fn trace_can_stop_at_the_first_fold() {
        let a0 = DVector::from_element(1, cubic_root(-4.0));
        let path = trace(&s_curve, a0, options(true)).unwrap();
        let PathEnd::Fold { lambda } = path.end else {
            panic!("expected a fold: {:?}", path.end)
        };
        approx::assert_relative_eq!(lambda, 0.75, epsilon = 0.02);
    }
}
