//! # fpsolve
//!
//! Stationary probability densities of randomly excited nonlinear oscillators, from a short
//! model file: the model language, the derived Fokker–Planck operator, the
//! exponential-polynomial closure (EPC) and Monte Carlo simulation.

pub mod epc;
pub mod fpk;
pub mod job;
pub mod mc;
pub mod model;
pub mod observe;
pub mod report;
pub mod study;
pub mod symbolic;
