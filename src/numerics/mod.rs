//! Numerical tools shared by the solution methods: quadrature rules, one damped Newton and
//! Levenberg–Marquardt, and sparse LU factorisations behind one trait. Nothing here knows a
//! model or a method; the methods build on it.

pub(crate) mod krylov;
pub mod newton;
pub(crate) mod poly2d;
pub(crate) mod quadrature;
pub(crate) mod sparse;
pub mod timestep;
