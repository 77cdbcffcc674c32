//! # fpsolve
//!
//! Stationary probability densities of randomly excited nonlinear oscillators, from a short
//! model file: the model language, the derived Fokker–Planck operator, the
//! exponential-polynomial closure (EPC) and Monte Carlo simulation.
//!
//! The user documentation lives next to the code: `docs/model-files.md` (the model language
//! and its error messages) and `docs/method.md` (what is computed, with the equations, and
//! where the method stops). `examples/embed.rs` is a complete program built on this page.
//!
//! # The pipeline
//!
//! Data flows one way, one module per stage:
//!
//! | stage | module | in → out |
//! |---|---|---|
//! | read | [`model`] | text → [`model::Model`] ([`model::parse_model`], [`model::load_model`]) |
//! | bind | [`model`] | [`model::Model`] + [`model::Override`]s → [`model::BoundModel`] ([`model::Model::bind`]) |
//! | derive | [`fpk`] | [`model::BoundModel`] → [`fpk::FpkOperator`] (drift, b = G·S·Gᵀ, A0, A_i, B_ij) |
//! | solve | [`epc`] | [`fpk::FpkOperator`] → [`epc::EpcSolution`] ([`epc::Epc`] builder) |
//! | observe | [`observe`] | joint density + observable → its PDF (paper Eqs. 23–28) |
//! | simulate | [`mc`] | [`model::BoundModel`] → [`mc::McResult`] (histograms with error bars) |
//! | report | [`report`] | tables, JSON, figures into an [`report::OutputDir`] |
//!
//! The front door is [`solve()`]: a bound model and a [`Method`] give a [`Solution`] that
//! answers `pdf`, `marginal` and `moments` for any state or observable by name:
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = fpsolve::model::load_model("models/vibro_duffing.sde".as_ref())?;
//! let bound = model.bind(&["mu=0.5".parse()?])?;
//! let solution = fpsolve::solve(&bound, fpsolve::Method::Epc { degree: 4 })?;
//! let p_y = solution.pdf("y", &[0.5, 1.0])?;
//! let (x, p) = solution.marginal("y")?;
//! let m = solution.moments("y")?;
//! # assert!(p_y[0] > 0.0 && x.len() == p.len() && m.moments.mean > 0.0);
//! # Ok(())
//! # }
//! ```
//!
//! [`study::Study`] runs bind → derive → EPC at several degrees → PDFs of every state and
//! observable on common grids in one call; [`symbolic`] is the expression layer underneath
//! (simplification, distributional derivatives of `abs`, `sgn`, `delta`, sifting, tapes).
//!
//! # A walk through the API
//!
//! ```
//! use fpsolve::epc::Epc;
//! use fpsolve::fpk::FpkOperator;
//! use fpsolve::mc::{McConfig, Simulation};
//! use fpsolve::model::{parse_expr, parse_model, Override};
//! use fpsolve::report::{OutputDir, PdfTable};
//!
//! // 1. Read: a Duffing oscillator z'' + c z' + k z + mu z^3 = xi(t). A model file would be
//! //    read with `load_model(path)`; errors carry line, column and a caret display.
//! let model = parse_model(
//!     "model duffing \"Duffing oscillator under additive white noise\"
//! param c = 0.5, k = 1, mu = 0.1, K = 1/(2*pi)
//! state z, v
//! drift z: v
//! drift v: -c*v - k*z - mu*z^3
//! noise xi: intensity 2*pi*K
//! diffusion v: xi
//! observe y = abs(z)
//! ",
//!     None,
//! )?;
//!
//! // 2. Bind: defaults, or overrides (a value may be an expression of other parameters,
//! //    exactly as `fpsolve check model.sde --set mu=2*c` would give it).
//! let mu = Override { name: "mu".into(), value: parse_expr("2*c")? };
//! let bound = model.bind(&[mu])?;
//! assert_eq!(bound.param("mu"), Some(1.0));
//!
//! // 3. Derive the stationary FPK operator symbolically.
//! let fpk = FpkOperator::derive(&bound)?;
//! assert_eq!(fpk.b[1][1].regular.to_string(), "0.5"); // B_vv = ½·2πK
//!
//! // 4. Solve by EPC at degree 4 (continued from degree 2, started by a Gaussian closure).
//! let sol = Epc::new(&fpk).degree(4).solve()?;
//! assert!(sol.solve.residual <= sol.solve.residual_threshold);
//! // This model's exact density is exp(-(c/πK)(v²/2 + k z²/2 + mu z⁴/4)), a degree-4
//! // exponential polynomial, so EPC reproduces it: Var v = πK/c = 1.
//! assert!((sol.moments[1].variance - 1.0).abs() < 1e-6);
//! assert!((sol.coefficient(4, 0) - (-0.25)).abs() < 1e-6); // −(c/πK)·mu/4
//! let p00 = sol.pdf(0.0, 0.0); // joint density
//! let pz0 = sol.marginal_at(0, 0.0); // marginal of z
//! assert!(p00 > 0.0 && pz0 > p00);
//!
//! // 5. Observe: the PDF of y = |z| (Eq. 25, exact line integrals of the joint density).
//! //    The front door knows every state and observable by name.
//! let solution = fpsolve::solve(&bound, fpsolve::Method::Epc { degree: 4 })?;
//! let py = solution.pdf("y", &[0.0, 0.5, 1.0])?;
//! assert!((py[0] - 2.0 * pz0).abs() < 1e-6 * py[0]); // p_Y(0) = 2 p_Z(0)
//!
//! // 6. Simulate: a (small) Monte Carlo reference with standard errors over batches.
//! let config = McConfig { trajectories: 256, lanes: 32, samples: 200, seed: 7, ..McConfig::default() };
//! let mc = Simulation::new(&bound, &config)?.run()?;
//! let var_v = mc.quantity("v").unwrap().moments.variance;
//! assert!((var_v.value - 1.0).abs() < 5.0 * var_v.stderr + 0.05);
//!
//! // 7. Report: a CSV table of the EPC density of y (JSON and figures work alike).
//! # let tmp = std::env::temp_dir().join(format!("fpsolve-doc-lib-{}", std::process::id()));
//! let dir = OutputDir::create(&tmp)?;
//! let table = PdfTable {
//!     variable: "y".into(),
//!     x: vec![0.0, 0.5, 1.0],
//!     columns: vec![("epc_n4".into(), py)],
//! };
//! table.write_csv(&dir, "pdf_y.csv")?;
//! # std::fs::remove_dir_all(&tmp)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Each stage fails with its own typed error ([`model::ModelError`], [`model::BindError`],
//! [`fpk::FpkError`], [`epc::EpcError`], [`mc::McError`], [`report::ReportError`]); numeric
//! failures say what was tried and how far it got (see `docs/method.md` on what an EPC
//! failure means).

#![warn(missing_docs)]

pub mod base;
pub mod check;
pub mod density;
pub mod dynamics;
pub mod epc;
pub mod epc_impact;
mod error;
pub mod fpk;
pub mod grid;
pub mod job;
pub mod mc;
pub mod model;
pub mod numerics;
pub mod observe;
pub mod report;
pub mod solve;
pub mod stats;
pub mod study;
pub mod sweep;
pub mod symbolic;
pub mod transform;

pub use error::Error;
pub use solve::{solve, Method, Solution};
