//! The derived FPK operator of `models/vibro_duffing.sde` equals the paper's Eq. 13 / Eq. 18 term by
//! term, for the four cases of Table 1 and a few others, evaluated at many random points.

use std::path::Path;

use fpsolve::fpk::FpkOperator;
use fpsolve::model::{load_model, Override};
use fpsolve::symbolic::{DeltaSplit, Expr};
use rand::{Rng, SeedableRng};

fn at(e: &Expr, z: f64, v: f64) -> f64 {
    e.eval(&|s| match s {
        "z" => Some(z),
        "v" => Some(v),
        _ => None,
    })
    .unwrap_or_else(|err| panic!("{e}: {err}"))
}

/// The regular part and the weight of the single line δ(z) (0 when there is none).
fn parts(s: &DeltaSplit, z: f64, v: f64) -> (f64, f64) {
    let mut line = 0.0;
    for l in &s.lines {
        assert_eq!(l.axis, 0, "a delta on v: {:?}", s);
        assert_eq!(l.at, 0.0);
        line += at(&l.weight, 0.0, v);
    }
    (at(&s.regular, z, v), line)
}

#[test]
fn vibro_duffing_operator_is_the_papers_eq_13() {
    let model = load_model(Path::new("models/vibro_duffing.sde")).expect("bundled model parses");
    let cases = [
        (0.1, 0.1, 0.95, 0.1, 1.0),
        (0.1, -0.1, 0.95, 0.1, 1.0),
        (1.0, 0.1, 0.95, 0.1, 1.0),
        (1.0, -0.1, 0.95, 0.1, 1.0),
        (0.3, 0.7, 0.6, 0.25, 2.0),
    ];
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(13);
    for (mu, eps, r, c, k) in cases {
        let two_pi_k = 1.3;
        let sets = [
            Override::number("mu", mu),
            Override::number("eps", eps),
            Override::number("r", r),
            Override::number("c", c),
            Override::number("k", k),
            Override::number("K", two_pi_k / (2.0 * std::f64::consts::PI)),
        ];
        let bound = model.bind(&sets).unwrap();
        let op = FpkOperator::derive(&bound).unwrap();
        let pik = two_pi_k / 2.0;
        for _ in 0..200 {
            let z: f64 = rng.random_range(-4.0..4.0);
            let v: f64 = rng.random_range(-4.0..4.0);
            if z.abs() < 1e-9 {
                continue;
            }
            let close = |got: f64, want: f64, what: &str| {
                assert!(
                    (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                    "{what} at ({z}, {v}) for mu={mu} eps={eps}: got {got}, paper {want}"
                );
            };
            // Eq. 18: c + 2(1-r)|x2| δ(x1)
            let (reg, line) = parts(&op.a0, z, v);
            close(reg, c, "A0 regular");
            close(line, 2.0 * (1.0 - r) * v.abs(), "A0 delta weight");
            // −x2 ∂Q/∂x1
            let (reg, line) = parts(&op.a[0], z, v);
            close(reg, -v, "A_z");
            close(line, 0.0, "A_z delta weight");
            // {c x2 + k x1 + μ x1³ + (1−r) x2|x2| δ(x1)} ∂Q/∂x2
            let (reg, line) = parts(&op.a[1], z, v);
            close(reg, c * v + k * z + mu * z.powi(3), "A_v regular");
            close(line, (1.0 - r) * v * v.abs(), "A_v delta weight");
            // πK{1 + 2ε x1 sgn(x1) + ε² x1²}[(∂Q/∂x2)² + ∂²Q/∂x2²]
            let (reg, line) = parts(&op.b[1][1], z, v);
            close(
                reg,
                pik * (1.0 + 2.0 * eps * z.abs() + eps * eps * z * z),
                "B_vv",
            );
            close(line, 0.0, "B_vv delta weight");
            for (i, j) in [(0, 0), (0, 1), (1, 0)] {
                let (reg, line) = parts(&op.b[i][j], z, v);
                close(reg, 0.0, "B off");
                close(line, 0.0, "B off delta");
            }
        }
    }
}
