//! Numerical tools shared by the solution methods: quadrature rules, the nonlinear solver and
//! sparse factorisations. Nothing here knows a model or a method; the methods build on it.

pub(crate) mod quadrature;
pub(crate) mod sparse;
