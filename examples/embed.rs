//! Embedding fpsolve in a program: load a model, override a parameter, solve, and ask the
//! solution for the PDF, the tabulated marginal and the moments of an observable by name.
//!
//! `cargo run --release --example embed`
//!
//! The model is the paper's vibro-impact Duffing oscillator after the Zhuravlev transformation
//! (`models/vibro_duffing.sde`, Eq. 10), here with μ = 0.5.

use fpsolve::epc::NormalisationKind;
use fpsolve::{Method, Solution};

/// The lines an embedding user writes: load → bind → solve → ask by name.
fn pdf_of_y() -> Result<Solution, Box<dyn std::error::Error>> {
    let model = fpsolve::model::load_model("models/vibro_duffing.sde".as_ref())?;
    let bound = model.bind(&["mu=0.5".parse()?])?;
    let solution = fpsolve::solve(&bound, Method::Epc { degree: 4 })?;
    let p_y = solution.pdf("y", &[0.5, 1.0])?;
    println!("p_y(0.5) = {:.6}, p_y(1.0) = {:.6}", p_y[0], p_y[1]);
    Ok(solution)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let solution = pdf_of_y()?;
    let (x, p) = solution.marginal("y")?; // on the grid `fpsolve` writes pdf_y.csv on
    let m = solution.moments("y")?; // from the joint density, not the curve
    println!(
        "y on [{:.3}, {:.3}] ({} points, peak {:.4}); mean {:.5}, sd {:.5}, kurtosis {:.4}, E[y^4] {:.4}",
        x[0],
        x[x.len() - 1],
        x.len(),
        p.iter().copied().fold(0.0, f64::max),
        m.moments.mean,
        m.std_dev(),
        m.moments.kurtosis,
        m.moments.raw[3]
    );
    // The method's own report: here EPC's iterations, residual and normalisation.
    if let Some(epc) = solution.epc() {
        let kind = match &epc.normalisation.kind {
            NormalisationKind::Plane { .. } => "on the plane".to_string(),
            NormalisationKind::InsideRidge { depth, .. } => {
                format!("inside a ridge {depth:.1} e-folds deep")
            }
        };
        println!(
            "{}: {} iterations, ‖R‖ = {:.2e}, ∫|F|p = {:.3e}, normalised {kind}",
            solution.method(),
            epc.solve.iterations,
            epc.solve.residual,
            epc.fpk_residual
        );
    }
    // Every state and observable is known by name; anything else is a typed error.
    for q in solution.quantities() {
        let m = solution.moments(&q.name)?;
        println!(
            "  {:>5}: mean {:+.5}, sd {:.5}",
            q.name,
            m.moments.mean,
            m.std_dev()
        );
    }
    if let Err(e) = solution.pdf("w", &[0.0]) {
        println!("{e}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_front_door_lines_run() {
        let solution = super::pdf_of_y().unwrap();
        assert!(solution.moments("y").unwrap().moments.mean > 0.0);
    }
}
