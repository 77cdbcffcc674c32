//! What a solve of the Galerkin system did, as data: the method that produced the solution
//! and where it started ([`SolverMethod`], [`StartPoint`]), and when nothing converged, every
//! attempt with how it ended ([`Attempt`], [`AttemptEnd`], [`HomotopyPath`]) and the best
//! point reached ([`BestPoint`]). `Display` turns each into the sentence the CLI prints; tests
//! and callers branch on the fields.

use std::fmt;

use serde::{Serialize, Serializer};

use crate::numerics::newton::{LmStop, NewtonStop};

/// Where an iteration started.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let sol = Epc::new(&fpk).degree(2).solve().unwrap();
/// assert_eq!(sol.solve.method, SolverMethod::Newton { from: StartPoint::GaussianClosure });
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartPoint {
    /// The solution at a lower degree, padded with zeros (continuation in degree).
    LowerDegree {
        /// That degree.
        degree: usize,
    },
    /// The Gaussian closure (or the weights' Gaussian when σ were given).
    GaussianClosure,
}

impl fmt::Display for StartPoint {
    /// ```
    /// use fpsolve::epc::StartPoint;
    /// assert_eq!(StartPoint::LowerDegree { degree: 4 }.to_string(), "the degree-4 solution");
    /// assert_eq!(StartPoint::GaussianClosure.to_string(), "the Gaussian closure");
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StartPoint::LowerDegree { degree } => write!(f, "the degree-{degree} solution"),
            StartPoint::GaussianClosure => f.write_str("the Gaussian closure"),
        }
    }
}

/// A method of solving R(a) = 0, with its start.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::parse_model};
/// # let model = parse_model("model m\nparam c = 0.1\nstate z, v\ndrift z: v\n\
/// #     drift v: -c*v - z\nnoise xi: intensity 1\ndiffusion v: xi\n", None).unwrap();
/// # let fpk = FpkOperator::derive(&model.bind(&[]).unwrap()).unwrap();
/// let res = Epc::new(&fpk).solve_degrees(&[2, 4]);
/// // Degree 4 starts from the degree-2 solution (continuation in degree).
/// let from = StartPoint::LowerDegree { degree: 2 };
/// assert_eq!(res[1].as_ref().unwrap().solve.method, SolverMethod::Newton { from });
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverMethod {
    /// Damped Newton (backtracking line search on ½‖R‖²).
    Newton {
        /// Its start.
        from: StartPoint,
    },
    /// Pseudo-arclength continuation of (1 − λ)R_G + λR from the exact root of the Galerkin
    /// system R_G of the Gaussian-exact operator (the Gaussian-closure density).
    OperatorHomotopy,
    /// Pseudo-arclength continuation of the Newton homotopy R(a) − (1 − λ)R(a0).
    NewtonHomotopy {
        /// a0.
        from: StartPoint,
    },
    /// Levenberg–Marquardt.
    LevenbergMarquardt {
        /// Its start.
        from: StartPoint,
    },
    /// Levenberg–Marquardt from a deterministic perturbation of the best point so far.
    PerturbedLevenbergMarquardt {
        /// Which perturbation (1, 2, …).
        start: usize,
    },
}

impl SolverMethod {
    /// The method as the list of attempts of a failure names it (`Newton from …`).
    fn attempt_name(&self) -> String {
        match self {
            SolverMethod::Newton { from } => format!("Newton from {from}"),
            SolverMethod::OperatorHomotopy => {
                "operator homotopy from the Gaussian-exact operator".to_string()
            }
            SolverMethod::NewtonHomotopy { from } => format!("Newton homotopy from {from}"),
            SolverMethod::LevenbergMarquardt { from } => format!("Levenberg-Marquardt from {from}"),
            SolverMethod::PerturbedLevenbergMarquardt { start } => {
                format!("Levenberg-Marquardt from perturbed start {start}")
            }
        }
    }
}

impl fmt::Display for SolverMethod {
    /// The method in lower case, as the CLI table and `summary.json` report it.
    ///
    /// ```
    /// use fpsolve::epc::{SolverMethod, StartPoint};
    /// let m = SolverMethod::Newton { from: StartPoint::GaussianClosure };
    /// assert_eq!(m.to_string(), "newton from the Gaussian closure");
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolverMethod::Newton { from } => write!(f, "newton from {from}"),
            SolverMethod::LevenbergMarquardt { from } => {
                write!(f, "levenberg-marquardt from {from}")
            }
            SolverMethod::PerturbedLevenbergMarquardt { start } => {
                write!(f, "levenberg-marquardt from perturbed start {start}")
            }
            // A homotopy is reported by its whole name in lower case.
            SolverMethod::OperatorHomotopy | SolverMethod::NewtonHomotopy { .. } => {
                f.write_str(&self.attempt_name().to_lowercase())
            }
        }
    }
}

/// Serialised as its `Display` string (the `method` field of `summary.json`).
impl Serialize for SolverMethod {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// A homotopy path whose ‖a‖ exceeds this many times 1 + ‖a0‖ counts as diverged.
pub(crate) const HOMOTOPY_NORM_FACTOR: f64 = 100.0;

/// Most continuation steps of one homotopy path.
pub(crate) const HOMOTOPY_STEPS: usize = 200;

/// How a homotopy path ended.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::load_model};
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// # let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
/// // Table 1 case 1 of the paper has no degree-6 solution connected to the Gaussian one.
/// let Err(EpcError::NoConvergence { attempts, best, .. }) = Epc::new(&fpk).degree(6).solve() else {
///     panic!("degree 6 of case 1 does not converge")
/// };
/// let ends: Vec<HomotopyEnd> = attempts.iter().filter_map(|a| match &a.end {
///     AttemptEnd::Homotopy(p) => Some(p.end),
///     _ => None,
/// }).collect();
/// assert!(!ends.is_empty() && !ends.contains(&HomotopyEnd::Reached));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HomotopyEnd {
    /// λ reached 1 (the root there did not meet the threshold, or the path is the solution).
    Reached,
    /// λ turned back at this λ and the path stopped there.
    TurnedBack {
        /// λ at the turn.
        lambda: f64,
    },
    /// The step size underflowed or the augmented system became singular at this λ.
    Stalled {
        /// The last λ reached.
        lambda: f64,
    },
    /// The path came back below λ = 0 (`lambda` < 0) or ‖a‖ grew beyond
    /// 100·(1 + ‖a0‖) at this λ.
    Escaped {
        /// λ where it escaped.
        lambda: f64,
    },
    /// The step budget (200 steps) ran out at this λ.
    Budget {
        /// λ when it ran out.
        lambda: f64,
    },
}

/// One homotopy path followed by pseudo-arclength continuation through folds in λ.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::load_model};
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// # let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
/// // Table 1 case 1 of the paper has no degree-6 solution connected to the Gaussian one.
/// let Err(EpcError::NoConvergence { attempts, best, .. }) = Epc::new(&fpk).degree(6).solve() else {
///     panic!("degree 6 of case 1 does not converge")
/// };
/// let operator = attempts.iter().find_map(|a| match &a.end {
///     AttemptEnd::Homotopy(p) if p.method == SolverMethod::OperatorHomotopy => Some(p),
///     _ => None,
/// }).unwrap();
/// // The branch from the Gaussian-exact operator folds at λ ≈ 0.497, before the model.
/// assert!((0.4..0.5).contains(&operator.folds[0]));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct HomotopyPath {
    /// [`SolverMethod::OperatorHomotopy`] or [`SolverMethod::NewtonHomotopy`]: λ deforms the operator
    /// (a fold then shows that the solution branch connected to the start does not reach the
    /// model) or the residual.
    pub method: SolverMethod,
    /// How it ended.
    pub end: HomotopyEnd,
    /// The largest λ reached.
    pub lambda_max: f64,
    /// λ at each fold (where the path turned back to decreasing λ).
    pub folds: Vec<f64>,
    /// Accepted continuation steps.
    pub steps: usize,
}

impl fmt::Display for HomotopyPath {
    /// What the path showed, claiming only what the continuation established.
    ///
    /// ```
    /// use fpsolve::epc::{HomotopyEnd, HomotopyPath, SolverMethod};
    /// let p = HomotopyPath {
    ///     method: SolverMethod::OperatorHomotopy,
    ///     end: HomotopyEnd::Escaped { lambda: -0.01 },
    ///     lambda_max: 0.5,
    ///     folds: vec![0.4967],
    ///     steps: 40,
    /// };
    /// assert!(p.to_string().starts_with(
    ///     "the operator homotopy from the Gaussian-exact operator folded at λ = 0.4967, then \
    ///      came back below λ = 0: the solution branch connected"));
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let end = match self.end {
            HomotopyEnd::Reached => {
                "reached λ = 1, where Newton did not converge to the threshold".to_string()
            }
            HomotopyEnd::TurnedBack { lambda } => format!("turned back at λ = {lambda:.4}"),
            HomotopyEnd::Stalled { lambda } => format!("stalled at λ = {lambda:.4}"),
            HomotopyEnd::Escaped { lambda } if lambda < 0.0 => "came back below λ = 0".to_string(),
            HomotopyEnd::Escaped { lambda } => format!(
                "diverged (‖a‖ beyond {HOMOTOPY_NORM_FACTOR} times its start's) at λ = {lambda:.4}"
            ),
            HomotopyEnd::Budget { lambda } => {
                format!("was still going at λ = {lambda:.4} after {HOMOTOPY_STEPS} steps")
            }
        };
        let folds = match self.folds.as_slice() {
            [] => String::new(),
            [l] => format!("folded at λ = {l:.4}, then "),
            f => format!("folded {} times (first at λ = {:.4}), then ", f.len(), f[0]),
        };
        let meaning = if self.end == HomotopyEnd::Reached {
            ""
        } else if self.method == SolverMethod::OperatorHomotopy && !self.folds.is_empty() {
            // A fold in a deformation of the operator is where the real solution connected to
            // the start meets another and both turn complex.
            ": the solution branch connected to the Gaussian-exact one does not reach the model along this path (real solutions off this path are not excluded)"
        } else {
            ": this path does not lead to a solution"
        };
        let reach = if self.folds.is_empty() {
            format!(" (largest λ reached {:.4})", self.lambda_max)
        } else {
            String::new()
        };
        write!(
            f,
            "the {}{reach} {folds}{end}{meaning}",
            self.method.attempt_name()
        )
    }
}

/// How one attempt that did not produce the solution ended.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::load_model};
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// # let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
/// // Table 1 case 1 of the paper has no degree-6 solution connected to the Gaussian one.
/// let Err(EpcError::NoConvergence { attempts, best, .. }) = Epc::new(&fpk).degree(6).solve() else {
///     panic!("degree 6 of case 1 does not converge")
/// };
/// assert!(attempts.iter().any(|a| matches!(a.end, AttemptEnd::Homotopy(_))));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum AttemptEnd {
    /// A Newton run stopped short of the threshold.
    Newton {
        /// Why.
        stop: NewtonStop,
        /// ‖R‖ where it stopped.
        residual: f64,
    },
    /// A homotopy path.
    Homotopy(HomotopyPath),
    /// A Levenberg–Marquardt run stopped short of the threshold.
    LevenbergMarquardt {
        /// Why.
        stop: LmStop,
        /// ‖R‖ where it stopped.
        residual: f64,
    },
}

/// One attempt at solving R(a) = 0 and how it ended.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::load_model};
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// # let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
/// // Table 1 case 1 of the paper has no degree-6 solution connected to the Gaussian one.
/// let Err(EpcError::NoConvergence { attempts, best, .. }) = Epc::new(&fpk).degree(6).solve() else {
///     panic!("degree 6 of case 1 does not converge")
/// };
/// assert_eq!(attempts[0].method, SolverMethod::Newton { from: StartPoint::LowerDegree { degree: 4 } });
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Attempt {
    /// The method and its start.
    pub method: SolverMethod,
    /// How it ended.
    pub end: AttemptEnd,
}

/// What the best point of a failed solve is.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::load_model};
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// # let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
/// // Table 1 case 1 of the paper has no degree-6 solution connected to the Gaussian one.
/// let Err(EpcError::NoConvergence { attempts, best, .. }) = Epc::new(&fpk).degree(6).solve() else {
///     panic!("degree 6 of case 1 does not converge")
/// };
/// assert_eq!(best.kind, BestPointKind::LocalMinimum);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BestPointKind {
    /// Levenberg–Marquardt finds no descent there: a local minimum of ‖R‖.
    LocalMinimum,
    /// The iterations stalled away from a stationary point.
    Stalled,
}

/// The point of least ‖R‖ a failed solve reached.
///
/// ```
/// # use fpsolve::{epc::*, fpk::FpkOperator, model::load_model};
/// # let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// # let fpk = FpkOperator::derive(&load_model(&path).unwrap().bind(&[]).unwrap()).unwrap();
/// // Table 1 case 1 of the paper has no degree-6 solution connected to the Gaussian one.
/// let Err(EpcError::NoConvergence { attempts, best, .. }) = Epc::new(&fpk).degree(6).solve() else {
///     panic!("degree 6 of case 1 does not converge")
/// };
/// // ‖R‖ stays far above the threshold at a stationary point of ½‖R‖².
/// assert!(best.residual > 1e-4 && best.gradient < 1e-3 * best.residual);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BestPoint {
    /// ‖R‖ there.
    pub residual: f64,
    /// ‖JᵀR‖ there (the gradient of ½‖R‖²).
    pub gradient: f64,
    /// What it is.
    pub kind: BestPointKind,
}

impl fmt::Display for BestPointKind {
    /// What the best point shows, in words.
    ///
    /// ```
    /// use fpsolve::epc::BestPointKind;
    /// assert!(BestPointKind::LocalMinimum.to_string().starts_with("it is a local minimum"));
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BestPointKind::LocalMinimum => "it is a local minimum of ‖R‖ (Levenberg–Marquardt finds no descent), which by itself does not exclude real solutions elsewhere",
            BestPointKind::Stalled => "the iterations stalled away from a stationary point; a solution nearby is not excluded",
        })
    }
}

/// The attempts as a failure lists them: comma-separated, the perturbed Levenberg–Marquardt
/// runs counted in one entry.
pub(crate) fn tried(attempts: &[Attempt]) -> String {
    let perturbed = attempts
        .iter()
        .filter(|a| matches!(a.method, SolverMethod::PerturbedLevenbergMarquardt { .. }))
        .count();
    let mut names: Vec<String> = attempts
        .iter()
        .filter(|a| !matches!(a.method, SolverMethod::PerturbedLevenbergMarquardt { .. }))
        .map(|a| a.method.attempt_name())
        .collect();
    if perturbed > 0 {
        names.push(format!(
            "Levenberg-Marquardt from {perturbed} perturbed starts"
        ));
    }
    names.join(", ")
}

/// What each homotopy path showed, each entry starting with "; ".
pub(crate) fn continuation(attempts: &[Attempt]) -> String {
    attempts
        .iter()
        .filter_map(|a| match &a.end {
            AttemptEnd::Homotopy(p) => Some(format!("; {p}")),
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perturbed_starts_are_listed_as_one_counted_entry() {
        let lm = |method| Attempt {
            method,
            end: AttemptEnd::LevenbergMarquardt {
                stop: LmStop::IterationLimit,
                residual: 1.0,
            },
        };
        let attempts = vec![
            Attempt {
                method: SolverMethod::Newton {
                    from: StartPoint::GaussianClosure,
                },
                end: AttemptEnd::Newton {
                    stop: NewtonStop::NoDescent,
                    residual: 1.0,
                },
            },
            lm(SolverMethod::LevenbergMarquardt {
                from: StartPoint::GaussianClosure,
            }),
            lm(SolverMethod::PerturbedLevenbergMarquardt { start: 1 }),
            lm(SolverMethod::PerturbedLevenbergMarquardt { start: 2 }),
        ];
        assert_eq!(
            tried(&attempts),
            "Newton from the Gaussian closure, Levenberg-Marquardt from the Gaussian closure, \
             Levenberg-Marquardt from 2 perturbed starts"
        );
        assert_eq!(continuation(&attempts), "");
        assert_eq!(
            SolverMethod::PerturbedLevenbergMarquardt { start: 3 }.to_string(),
            "levenberg-marquardt from perturbed start 3"
        );
        assert_eq!(
            SolverMethod::NewtonHomotopy {
                from: StartPoint::GaussianClosure
            }
            .to_string(),
            "newton homotopy from the gaussian closure"
        );
    }
}
