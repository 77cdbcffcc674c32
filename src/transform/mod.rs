//! Transformations of a model into an equivalent one that a method can solve.
//!
//! [`zhuravlev`] turns an oscillator with one reflecting barrier, written in its own
//! coordinates (`impact y = 0: ydot -> -r*ydot`, `domain y >= 0`), into the barrier-free
//! Zhuravlev form of the paper's Eqs. 5–10, which the δ-term EPC solves; the original states
//! and observables become observables of the transformed model, by their own names.
//!
//! ```
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_impact_duffing.sde");
//! let model = fpsolve::model::load_model(&path)?;
//! let z = fpsolve::transform::zhuravlev(&model)?;
//! assert_eq!(z.model.drift()[1].to_string(), "-c*v - k*z - mu*z^3 - (1 - r)*v*abs(v)*delta(z)");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod zhuravlev;

pub use zhuravlev::{zhuravlev, zhuravlev_bound, Zhuravlev, ZhuravlevError};

#[cfg(test)]
mod tests;
