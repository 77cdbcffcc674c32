//! What `fpsolve check` prints: a model with its parameter values and its derived
//! Fokker–Planck operator, and, for a model with one reflecting barrier in its own
//! coordinates, the Zhuravlev transform EPC solves (Eqs. 5–10) with its operator. One
//! rendering for the command line and the Python package.

use std::fmt::Write;

use crate::fpk::{FpkError, FpkOperator};
use crate::model::{number, BoundModel, Model};
use crate::transform::{zhuravlev, zhuravlev_bound};

/// The text `fpsolve check` prints for `model` bound as `bound`.
///
/// ```
/// use fpsolve::model::parse_model;
/// let model = parse_model("model m\nparam c = 0.5\nstate z, v\ndrift z: v\ndrift v: -c*v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?;
/// let bound = model.bind(&[])?;
/// let text = fpsolve::check::render(&model, &bound)?;
/// assert!(text.contains("#   c = 0.5"));
/// assert!(text.contains("# derived Fokker-Planck operator"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// # Errors
/// The [`FpkError`] of a model whose operator cannot be derived.
pub fn render(model: &Model, bound: &BoundModel) -> Result<String, FpkError> {
    let mut out = String::new();
    // Writing to a String cannot fail.
    let _ = write!(out, "{model}");
    let _ = writeln!(out, "\n# parameter values");
    for (name, value) in bound.params() {
        let _ = writeln!(out, "#   {name} = {}", number(*value));
    }
    if bound.time_dependent() {
        // Its operator changes in time: the stationary derivation (and its checks) do not
        // apply, but the model itself is valid and printed.
        let _ = writeln!(
            out,
            "\n# the equations depend on the time `t`: the density changes in time and there is \
             no stationary Fokker-Planck operator to derive (stationary methods refuse this model)"
        );
        return Ok(out);
    }
    let fpk = FpkOperator::derive(bound)?;
    let _ = writeln!(out, "\n# derived Fokker-Planck operator");
    commented(&mut out, &fpk);
    // A reflecting barrier in original coordinates: the model EPC solves instead (Eqs. 5-10).
    if let (Ok(t), Ok(tb)) = (zhuravlev(model), zhuravlev_bound(bound)) {
        let fpk = FpkOperator::derive(&tb.model)?;
        let head = "Zhuravlev transform (Eqs. 5-10), the model EPC solves; the lines below are a";
        let _ = write!(out, "\n# {head} model file\n{}", t.model);
        let _ = writeln!(out, "# its derived Fokker-Planck operator");
        commented(&mut out, &fpk);
    }
    Ok(out)
}

/// `text` as `# ` comment lines.
fn commented(out: &mut String, text: &impl std::fmt::Display) {
    for line in text.to_string().lines() {
        let _ = writeln!(out, "# {line}");
    }
}
