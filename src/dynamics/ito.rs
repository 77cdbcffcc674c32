//! The Itô form of a bound model: the drift m = f + Wong–Zakai correction, and the diffusion
//! matrix b = G·S·Gᵀ, derived symbolically once for every method.

use crate::model::{BoundModel, Interpretation};
use crate::symbolic::{diff, expand, simplify, Expr, SymbolicError};

/// A symbolic derivation of the Itô form failed (a derivative with no meaning as a
/// distribution, say) while deriving `what`.
///
/// ```
/// use fpsolve::dynamics::DerivationError;
/// use fpsolve::symbolic::SymbolicError;
/// let source = SymbolicError::DeltaDerivative { expr: "delta(z)".into(), var: "z".into() };
/// let e = DerivationError { what: "d G[v][0] / dz".into(), source };
/// assert!(e.to_string().starts_with("while deriving d G[v][0] / dz"));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("while deriving {what}: {source}")]
pub struct DerivationError {
    /// The quantity being derived.
    pub what: String,
    /// The underlying failure.
    pub source: SymbolicError,
}

/// The Wong–Zakai correction and the Itô drift m = drift + correction, simplified.
pub(crate) fn ito_drift(model: &BoundModel) -> Result<([Expr; 2], [Expr; 2]), DerivationError> {
    let wz = wong_zakai(model)?;
    let d = model.drift();
    let m = [
        simplify(&(d[0].clone() + wz[0].clone())),
        simplify(&(d[1].clone() + wz[1].clone())),
    ];
    Ok((wz, m))
}

/// The Wong–Zakai drift correction m_i += ½ Σ_j Σ_kl S_kl G_jl ∂_j G_ik of a Stratonovich
/// model (zero for Itô models).
fn wong_zakai(model: &BoundModel) -> Result<[Expr; 2], DerivationError> {
    let states = model.states();
    let g = model.noise_matrix();
    let s = model.intensity();
    let m_src = model.noise_names().len();
    let mut wong_zakai: [Expr; 2] = [Expr::num(0.0), Expr::num(0.0)];
    if model.interpretation() == Interpretation::Stratonovich {
        for i in 0..2 {
            let mut terms = Vec::new();
            for (j, xj) in states.iter().enumerate() {
                for k in 0..m_src {
                    let dg = diff(&g[i][k], xj).map_err(|source| DerivationError {
                        what: format!("d G[{}][{k}] / d{xj}", states[i]),
                        source,
                    })?;
                    if dg.as_num() == Some(0.0) {
                        continue;
                    }
                    for l in 0..m_src {
                        if s[k][l] != 0.0 && g[j][l].as_num() != Some(0.0) {
                            terms.push(Expr::num(0.5 * s[k][l]) * g[j][l].clone() * dg.clone());
                        }
                    }
                }
            }
            wong_zakai[i] = simplify(&Expr::sum(terms));
        }
    }
    Ok(wong_zakai)
}

/// The diffusion matrix b = G·S·Gᵀ, each entry expanded (so that sgn(z)^2 = 1 and
/// z*sgn(z) = |z| are seen, Eq. 13's form) and simplified.
pub(crate) fn diffusion(model: &BoundModel) -> [[Expr; 2]; 2] {
    let g = model.noise_matrix();
    let s = model.intensity();
    let m_src = model.noise_names().len();
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let mut terms = Vec::new();
            for k in 0..m_src {
                for l in 0..m_src {
                    if s[k][l] != 0.0 {
                        terms.push(Expr::num(s[k][l]) * g[i][k].clone() * g[j][l].clone());
                    }
                }
            }
            simplify(&expand(&Expr::sum(terms)))
        })
    })
}
