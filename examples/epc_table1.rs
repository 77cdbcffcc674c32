//! The four cases of the paper's Table 1 at degrees 2, 4, 6, 8: outcome of each EPC solve.

#[path = "../benches/epc.rs"]
#[allow(dead_code)]
mod bench_model;

fn main() {
    use fpsolve::epc::Epc;
    use fpsolve::model::DeltaTreatment;
    for (case, (mu, eps)) in [(0.1, 0.1), (0.1, -0.1), (1.0, 0.1), (1.0, -0.1)]
        .iter()
        .enumerate()
    {
        let fpk = bench_model::vibro_impact(0.1, 1.0, *mu, 1.0, 0.95, *eps);
        let t = std::time::Instant::now();
        let res = Epc::new(&fpk, DeltaTreatment::Exact).solve_degrees(&[2, 4, 6, 8]);
        println!(
            "case {} (mu={mu}, eps={eps}) total {:.1} ms",
            case + 1,
            t.elapsed().as_secs_f64() * 1e3
        );
        for r in res {
            match r {
                Ok(s) => println!(
                    "  n={} {} it={} |R|={:.2e} norm={} sd(z)={:.4} sd(v)={:.4} kurt(z)={:.3} E|F|p={:.3e} times closure/asm/solve/norm = {:.1}/{:.1}/{:.1}/{:.1} ms order {}",
                    s.degree,
                    s.solve.method,
                    s.solve.iterations,
                    s.solve.residual,
                    serde_json::to_string(&s.normalisation.kind).unwrap(),
                    s.moments[0].variance.sqrt(),
                    s.moments[1].variance.sqrt(),
                    s.moments[0].kurtosis,
                    s.fpk_residual,
                    s.solve.closure_ms,
                    s.solve.assembly_ms,
                    s.solve.solve_ms,
                    s.solve.normalise_ms,
                    s.solve.quadrature_order,
                ),
                Err(e) => println!("  error: {e}"),
            }
        }
    }
}
