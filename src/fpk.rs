//! From drift, noise matrix and intensities to the stationary Fokker–Planck operator.
//!
//! For p = C·exp(Q) the stationary FPK equation divided by p is the residual
//! F = A0 + Σ_i A_i ∂_iQ + Σ_ij B_ij (∂_i∂_jQ + ∂_iQ ∂_jQ) (the paper's Eq. 18), with
//! A0 = −Σ_i ∂_i m_i + ½ Σ_ij ∂_i∂_j b_ij, A_i = −m_i + Σ_j ∂_j b_ij, B_ij = ½ b_ij,
//! where m is the Itô drift (Wong–Zakai corrected for a Stratonovich model) and b = G·S·Gᵀ.

use crate::symbolic::{DeltaSplit, Expr, Symbol};

/// The derived stationary FPK operator of a bound model, ready for the EPC engine.
#[derive(Clone, Debug, PartialEq)]
pub struct FpkOperator {
    /// The two states' names (x1, x2).
    pub states: [Symbol; 2],
    /// The Itô drift m_i (Wong–Zakai correction included for Stratonovich models).
    pub drift: [Expr; 2],
    /// The diffusion matrix b = G·S·Gᵀ (symmetric).
    pub diffusion: [[Expr; 2]; 2],
    /// A0 = −Σ_i ∂_i m_i + ½ Σ_ij ∂_i∂_j b_ij, split into its regular and delta parts.
    pub a0: DeltaSplit,
    /// A_i = −m_i + Σ_j ∂_j b_ij.
    pub a: [DeltaSplit; 2],
    /// B_ij = ½ b_ij (symmetric).
    pub b: [[DeltaSplit; 2]; 2],
}
