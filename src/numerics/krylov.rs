//! GMRES (Saad & Schultz 1986): one cycle of the minimal-residual Krylov method for A x = b
//! from x = 0, A given only by its action on a vector. Arnoldi by modified Gram–Schmidt, the
//! small least-squares problem by Givens rotations, so that the residual's 2-norm is known
//! at every iteration without forming x; the caller restarts from the true residual.

/// What one cycle did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cycle {
    /// Products with A taken.
    pub(crate) products: usize,
    /// The residual's 2-norm ‖b − A x‖₂ as the rotations give it (exact in exact arithmetic
    /// for a linear A).
    pub(crate) residual: f64,
}

/// One GMRES cycle for A x = `b` from x = 0: at most `most` products with A (`apply`), fewer
/// once the residual's 2-norm is at most `stop`; returns x and what the cycle did. A
/// breakdown (the Krylov space invariant) ends the cycle with x exact.
pub(crate) fn gmres<E>(
    mut apply: impl FnMut(&[f64]) -> Result<Vec<f64>, E>,
    b: &[f64],
    most: usize,
    stop: f64,
) -> Result<(Vec<f64>, Cycle), E> {
    let n = b.len();
    let norm = |u: &[f64]| u.iter().map(|v| v * v).sum::<f64>().sqrt();
    let beta = norm(b);
    let mut x = vec![0.0; n];
    if beta == 0.0 || most == 0 {
        return Ok((
            x,
            Cycle {
                products: 0,
                residual: beta,
            },
        ));
    }
    let mut basis = vec![b.iter().map(|v| v / beta).collect::<Vec<f64>>()];
    // Columns of the Hessenberg matrix after the rotations (R), the rotations, and g = Qᵀβe₁.
    let mut r: Vec<Vec<f64>> = Vec::new();
    let mut rotations: Vec<(f64, f64)> = Vec::new();
    let mut g = vec![beta];
    let mut residual = beta;
    while r.len() < most && residual > stop {
        let k = r.len();
        let mut w = apply(&basis[k])?;
        let mut h = Vec::with_capacity(k + 2);
        for v in &basis {
            let d: f64 = w.iter().zip(v).map(|(a, b)| a * b).sum();
            w.iter_mut().zip(v).for_each(|(a, b)| *a -= d * b);
            h.push(d);
        }
        let next = norm(&w);
        h.push(next);
        for (i, &(c, s)) in rotations.iter().enumerate() {
            let (a, b) = (h[i], h[i + 1]);
            h[i] = c * a + s * b;
            h[i + 1] = -s * a + c * b;
        }
        let (a, b) = (h[k], h[k + 1]);
        let rho = a.hypot(b);
        let (c, s) = if rho == 0.0 {
            (1.0, 0.0)
        } else {
            (a / rho, b / rho)
        };
        h[k] = rho;
        h[k + 1] = 0.0;
        rotations.push((c, s));
        g.push(-s * g[k]);
        g[k] *= c;
        residual = g[k + 1].abs();
        h.truncate(k + 1);
        r.push(h);
        if next == 0.0 || !next.is_finite() {
            break;
        }
        basis.push(w.iter().map(|v| v / next).collect());
    }
    // R y = g (upper triangular), x = V y.
    let m = r.len();
    let mut y = vec![0.0; m];
    for i in (0..m).rev() {
        let sum: f64 = (i + 1..m).map(|j| r[j][i] * y[j]).sum();
        y[i] = if r[i][i] == 0.0 {
            0.0
        } else {
            (g[i] - sum) / r[i][i]
        };
    }
    for (v, yi) in basis.iter().zip(&y) {
        x.iter_mut().zip(v).for_each(|(x, v)| *x += yi * v);
    }
    Ok((
        x,
        Cycle {
            products: m,
            residual,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A non-symmetric 5×5 system: solved in at most 5 products, and the reported residual
    /// is the true one.
    #[test]
    fn solves_a_small_nonsymmetric_system() {
        let a = [
            [4.0, 1.0, 0.0, 0.5, 0.0],
            [-1.0, 3.0, 1.0, 0.0, 0.0],
            [0.0, -2.0, 5.0, 1.0, 0.3],
            [0.2, 0.0, -1.0, 2.0, 1.0],
            [0.0, 0.1, 0.0, -1.0, 3.0],
        ];
        let mul = |x: &[f64]| -> Result<Vec<f64>, ()> {
            Ok(a.iter()
                .map(|row| row.iter().zip(x).map(|(a, x)| a * x).sum())
                .collect())
        };
        let b = [1.0, -2.0, 0.5, 3.0, 1.0];
        let (x, cycle) = gmres(mul, &b, 10, 1e-13).unwrap();
        assert!(cycle.products <= 5);
        let ax = mul(&x).unwrap();
        let true_residual = ax
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(true_residual < 1e-12, "{true_residual}");
        assert!((true_residual - cycle.residual).abs() < 1e-12);
        // A cycle stopped after two products reports the residual of its x.
        let (x2, c2) = gmres(mul, &b, 2, 0.0).unwrap();
        let r2 = mul(&x2)
            .unwrap()
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).powi(2))
            .sum::<f64>()
            .sqrt();
        assert_eq!(c2.products, 2);
        assert!(
            (r2 - c2.residual).abs() < 1e-12 && r2 > 1e-3,
            "{r2} {}",
            c2.residual
        );
    }
}
