//! Embedding fpsolve in a program: a model given as a string, parsed, overridden, solved by
//! EPC at degree 4, and its densities queried.
//!
//! `cargo run --release --example embed`
//!
//! The model is the paper's vibro-impact Duffing oscillator after the Zhuravlev transformation
//! (Eq. 10), here with the strong nonlinearity and negative parametric factor of Table 1,
//! case 4 (μ = 1, ε = −0.1), set by overrides as `--set` would.

use fpsolve::epc::{Epc, NormalisationKind};
use fpsolve::fpk::FpkOperator;
use fpsolve::model::{parse_expr, parse_model, Override};
use fpsolve::observe::{observable_pdf, ObservableMap};

const MODEL: &str = r#"
model vibro_duffing "Vibro-impact Duffing oscillator, Zhuravlev-transformed (Eq. 10)"
param c = 0.1, k = 1, mu = 0.1, eps = 0.1, r = 0.95
param K = 1/(2*pi)                      # excitation intensity 2*pi*K = 1
state z, v
drift z: v
drift v: -c*v - k*z - mu*z^3 - (1 - r)*v*abs(v)*delta(z)
noise xi: intensity 2*pi*K
diffusion v: (sgn(z) + eps*z) * xi
interpretation: stratonovich
impact z = 0: v -> r*v
observe y = abs(z), ydot = v*sgn(z), energy = v^2/2 + k*z^2/2 + mu*z^4/4
delta: exact
"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Text → validated model. A mistake in MODEL would come back as a `ModelError` whose
    // Display shows the line, the column and a caret, like `fpsolve check` does.
    let model = parse_model(MODEL, None)?;

    // Overrides, as `--set mu=1 --set eps=-mu/10` would give them: values are expressions of
    // numbers, `pi`, `e` and the other parameters.
    let overrides = [
        Override::number("mu", 1.0),
        Override {
            name: "eps".into(),
            value: parse_expr("-mu/10")?,
        },
    ];
    let bound = model.bind(&overrides)?;
    println!("model {}: {}", model.name(), model.description());
    for (name, value) in bound.params() {
        println!("  {name} = {value}");
    }

    // The stationary FPK operator, derived symbolically (δ terms sifted onto z = 0).
    let fpk = FpkOperator::derive(&bound)?;
    println!("\nderived operator:\n{fpk}");

    // EPC of degree 4, continued from degree 2 (the Gaussian closure starts both).
    let sol = Epc::new(&fpk, bound.delta_treatment()).degree(4).solve()?;
    let report = &sol.solve;
    println!(
        "EPC n = {}: {} after {} iterations, ‖R‖ = {:.2e} (needed ≤ {:.1e}), ∫|F|p = {:.3e}",
        sol.degree,
        report.method,
        report.iterations,
        report.residual,
        report.residual_threshold,
        sol.fpk_residual
    );
    let norm = &sol.normalisation;
    let kind = match &norm.kind {
        NormalisationKind::Plane { .. } => "on the plane".to_string(),
        NormalisationKind::InsideRidge { depth, .. } => {
            format!("inside a ridge {depth:.1} e-folds deep")
        }
    };
    println!(
        "normalised {kind}: ln C = {:.6}, relative error estimate {:.1e}",
        norm.log_c, norm.error_estimate
    );
    println!("Q(z, v) in original variables:");
    for (&(i, j), a) in sol.exponents.iter().zip(&sol.coefficients) {
        if a.abs() > 1e-12 {
            println!("  {a:+.6e} · z^{i} v^{j}");
        }
    }
    for (name, m) in ["z", "v"].iter().zip(&sol.moments) {
        println!(
            "  {name}: mean {:+.5}, sd {:.5}, kurtosis {:.4}",
            m.mean,
            m.variance.sqrt(),
            m.kurtosis
        );
    }

    // The joint density and a marginal, queried pointwise.
    println!("\njoint p(z, v) and marginal p_z(z):");
    for z in [0.0, 0.5, 1.0, 1.5] {
        println!(
            "  z = {z:3.1}: p(z, 0) = {:.6}, p(z, 1) = {:.6}, p_z(z) = {:.6}",
            sol.pdf(z, 0.0),
            sol.pdf(z, 1.0),
            sol.marginal_at(0, z)
        );
    }
    println!("  P(|z| > 1.5) = {:.4e}", sol.tail_probability(0, 1.5));

    // PDFs of the observables of the original oscillator (Eqs. 23–28): y = |z| and
    // ydot = v·sgn(z) are ± a state on each quadrant (exact line integrals); the energy is
    // not, and goes through the kernel method.
    let states = bound.states();
    for obs in bound.observables() {
        let map = ObservableMap::classify(&obs.expr, states);
        let method = match map {
            ObservableMap::SignedState { .. } => "line integrals",
            ObservableMap::General { .. } => "kernel estimate",
        };
        let u: Vec<f64> = match obs.name.as_ref() {
            "y" => vec![0.0, 0.25, 0.5, 1.0, 1.5, 2.0],
            "ydot" => vec![-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0],
            // The kernel estimate is biased within a few kernel widths of a support edge
            // (the energy's at 0), so it is queried away from it.
            _ => vec![0.5, 1.0, 2.0, 4.0],
        };
        let p = observable_pdf(&sol, &map, &u);
        println!("\np_{}(u) ({method}):", obs.name);
        for (u, p) in u.iter().zip(&p) {
            println!("  u = {u:+5.2}: {p:.6}");
        }
        // Each observable density must carry the whole probability mass.
        if let ObservableMap::SignedState { .. } = map {
            let (lo, hi) = if obs.name.as_ref() == "y" {
                (0.0, 8.0)
            } else {
                (-8.0, 8.0)
            };
            let h = (hi - lo) / 4000.0; // midpoint rule
            let mids: Vec<f64> = (0..4000).map(|k| lo + (k as f64 + 0.5) * h).collect();
            let mass = h * observable_pdf(&sol, &map, &mids).iter().sum::<f64>();
            println!("  ∫ p_{} = {mass:.8}", obs.name);
        }
    }
    Ok(())
}
