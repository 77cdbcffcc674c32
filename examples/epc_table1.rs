//! The four cases of the paper's Table 1 at degrees 2, 4, 6, 8: outcome of each EPC solve.
//!
//! `cargo run --release --example epc_table1`

use std::path::Path;

use fpsolve::epc::Epc;
use fpsolve::fpk::FpkOperator;
use fpsolve::model::{load_model, Override};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
    let model = load_model(&path)?;
    for (case, (mu, eps)) in [(0.1, 0.1), (0.1, -0.1), (1.0, 0.1), (1.0, -0.1)]
        .into_iter()
        .enumerate()
    {
        let bound = model.bind(&[Override::number("mu", mu), Override::number("eps", eps)])?;
        let fpk = FpkOperator::derive(&bound)?;
        let t = std::time::Instant::now();
        let res = Epc::new(&fpk).solve_degrees(&[2, 4, 6, 8]);
        println!(
            "case {} (mu={mu}, eps={eps}) total {:.1} ms",
            case + 1,
            t.elapsed().as_secs_f64() * 1e3
        );
        for r in res {
            match r {
                Ok(s) => println!(
                    "  n={} {} it={} |R|={:.2e} (<= {:.1e}) norm={} sd(z)={:.4} sd(v)={:.4} kurt(z)={:.3} E|F|p={:.3e} Z err {:.1e}; ms closure/asm/solve/norm/resid = {:.2}/{:.2}/{:.2}/{:.2}/{:.2}; order {}",
                    s.degree,
                    s.solve.method,
                    s.solve.iterations,
                    s.solve.residual,
                    s.solve.residual_threshold,
                    serde_json::to_string(&s.normalisation.kind)?,
                    s.moments[0].variance.sqrt(),
                    s.moments[1].variance.sqrt(),
                    s.moments[0].kurtosis,
                    s.fpk_residual,
                    s.normalisation.error_estimate,
                    s.solve.closure_ms,
                    s.solve.assembly_ms,
                    s.solve.solve_ms,
                    s.solve.normalise_ms,
                    s.solve.fpk_residual_ms,
                    s.solve.quadrature_order,
                ),
                Err(e) => println!("  error: {e}"),
            }
        }
        // Degree 6: follow its solution from the exact r = 1, ε = 0 case to this case.
        let at = |l: f64| {
            let b = model
                .bind(&[
                    Override::number("mu", mu),
                    Override::number("r", 1.0 - 0.05 * l),
                    Override::number("eps", eps * l),
                ])
                .map_err(|e| e.to_string())?;
            FpkOperator::derive_unchecked(&b).map_err(|e| e.to_string())
        };
        match Epc::new(&fpk).degree(6).branch(&at) {
            Ok(b) => match b.end {
                fpsolve::epc::BranchEnd::Fold { lambda } => println!(
                    "  degree-6 branch from (r=1, eps=0) folds at lambda={lambda:.4} (r={:.4}, eps={:.4}) after {} points",
                    1.0 - 0.05 * lambda,
                    eps * lambda,
                    b.points.len()
                ),
                end => println!("  degree-6 branch: {end:?} after {} points", b.points.len()),
            },
            Err(e) => println!("  degree-6 branch: {e}"),
        }
        for n in [4, 6, 8] {
            let t = std::time::Instant::now();
            let ok = Epc::new(&fpk).degree(n).solve().is_ok();
            println!(
                "  solve() at degree {n}: {} in {:.1} ms",
                if ok { "solved" } else { "failed" },
                t.elapsed().as_secs_f64() * 1e3
            );
        }
    }
    Ok(())
}
