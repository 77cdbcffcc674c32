//! Sparse LU factorisations of square systems: the pattern LU (pivoting inside supernodes)
//! and faer's supernodal LU with row pivoting.

pub(crate) mod faer_lu;
pub(crate) mod pattern_lu;
