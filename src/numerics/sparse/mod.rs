//! Sparse LU factorisations of square systems behind one [`Factorization`] trait: the pattern
//! LU (pivoting inside supernodes only, on the pattern of A + Aᵀ) and faer's supernodal LU
//! with row pivoting. Each solve can be checked by its backward error, so a caller can fall
//! back from one to the other on the same test.

mod error;
mod factorization;
pub(crate) mod faer_lu;
pub(crate) mod pattern;
pub(crate) mod pattern_lu;

pub(crate) use error::FactorError;
pub(crate) use factorization::{Check, Factorization};
