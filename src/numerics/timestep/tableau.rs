//! The Butcher tableaux of the steppers: singly diagonally implicit Runge–Kutta methods with
//! an explicit first stage (ESDIRK), stiffly accurate (the step's result is the last stage),
//! each with an embedded method of another order for the error estimate.

/// The coefficients of one ESDIRK method.
#[derive(Debug)]
pub(crate) struct Tableau {
    /// The stage abscissae c₀ = 0, c₁, …, c_{s−1} = 1.
    pub(crate) c: &'static [f64],
    /// Row i − 1 holds a_{i,0} … a_{i,i−1}, the explicit weights of implicit stage i.
    pub(crate) a: &'static [&'static [f64]],
    /// The diagonal a_{i,i} of every implicit stage: each solves with I − γ h A.
    pub(crate) gamma: f64,
    /// b − b̂ per stage: the method's weights minus the embedded method's.
    pub(crate) error: &'static [f64],
    /// The power of h in the local error estimate (one more than the lower of the two
    /// orders).
    pub(crate) estimate_order: i32,
}

/// The time-stepping method of a [`super::Esdirk`] run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum Scheme {
    /// TR-BDF2 (Bank et al. 1985; Hosea & Shampine 1996): second order, L-stable, three
    /// stages (two solves), a third-order embedded estimate.
    #[default]
    TrBdf2,
    /// ESDIRK4(3)6L[2]SA (Kennedy & Carpenter 2003, the implicit part of ARK4(3)6L[2]SA):
    /// fourth order, L-stable, stage order two, six stages (five solves), a third-order
    /// embedded estimate.
    Esdirk4,
}

impl Scheme {
    pub(crate) fn tableau(self) -> &'static Tableau {
        match self {
            Scheme::TrBdf2 => &TR_BDF2,
            Scheme::Esdirk4 => &ESDIRK4,
        }
    }
}

/// γ = 2 − √2: the trapezoidal stage ends at t + γh.
const G: f64 = 2.0 - std::f64::consts::SQRT_2;
/// The implicit coefficient of both stages, γ/2 = (1 − γ)/(2 − γ).
const D: f64 = 1.0 - std::f64::consts::FRAC_1_SQRT_2;
/// The explicit weights of the BDF2 stage, y₁ = y₀ + h (w f₀ + w f_γ + d f₁).
const W: f64 = std::f64::consts::SQRT_2 / 4.0;

/// TR-BDF2 in ESDIRK form, with the embedded third-order weights ((1 − w)/3, (3w + 1)/3,
/// d/3) of Hosea & Shampine (1996).
static TR_BDF2: Tableau = Tableau {
    c: &[0.0, G, 1.0],
    a: &[&[D], &[W, W]],
    gamma: D,
    error: &[(4.0 * W - 1.0) / 3.0, -1.0 / 3.0, 2.0 * D / 3.0],
    estimate_order: 3,
};

/// The method's weights b (its last row: stiffly accurate).
const B4: [f64; 6] = [
    82889.0 / 524892.0,
    0.0,
    15625.0 / 83664.0,
    69875.0 / 102672.0,
    -2260.0 / 8211.0,
    0.25,
];

/// The embedded third-order weights b̂.
const B3: [f64; 6] = [
    4586570599.0 / 29645900160.0,
    0.0,
    178811875.0 / 945068544.0,
    814220225.0 / 1159782912.0,
    -3700637.0 / 11593932.0,
    61727.0 / 225920.0,
];

static ESDIRK4: Tableau = Tableau {
    c: &[0.0, 0.5, 83.0 / 250.0, 31.0 / 50.0, 17.0 / 20.0, 1.0],
    a: &[
        &[0.25],
        &[8611.0 / 62500.0, -1743.0 / 31250.0],
        &[
            5012029.0 / 34652500.0,
            -654441.0 / 2922500.0,
            174375.0 / 388108.0,
        ],
        &[
            15267082809.0 / 155376265600.0,
            -71443401.0 / 120774400.0,
            730878875.0 / 902184768.0,
            2285395.0 / 8070912.0,
        ],
        &[B4[0], B4[1], B4[2], B4[3], B4[4]],
    ],
    gamma: 0.25,
    error: &[
        B4[0] - B3[0],
        B4[1] - B3[1],
        B4[2] - B3[2],
        B4[3] - B3[3],
        B4[4] - B3[4],
        B4[5] - B3[5],
    ],
    estimate_order: 4,
};

#[cfg(test)]
mod tests {
    use super::*;

    /// The full matrix A (s × s) and the weights b of a tableau.
    fn full(t: &Tableau) -> (Vec<Vec<f64>>, Vec<f64>) {
        let s = t.c.len();
        let mut a = vec![vec![0.0; s]; s];
        for (i, row) in t.a.iter().enumerate() {
            a[i + 1][..row.len()].copy_from_slice(row);
            a[i + 1][i + 1] = t.gamma;
        }
        let b = a[s - 1].clone();
        (a, b)
    }

    fn dot(u: &[f64], v: &[f64]) -> f64 {
        u.iter().zip(v).map(|(a, b)| a * b).sum()
    }

    fn times(a: &[Vec<f64>], v: &[f64]) -> Vec<f64> {
        a.iter().map(|row| dot(row, v)).collect()
    }

    /// The order conditions (all eight up to order four), the row sums, stiff accuracy and
    /// the embedded method's order, checked on the coefficients as written.
    #[test]
    fn order_conditions_hold() {
        for (scheme, order) in [(Scheme::TrBdf2, 2), (Scheme::Esdirk4, 4)] {
            let t = scheme.tableau();
            let (a, b) = full(t);
            let c = t.c;
            for (i, row) in a.iter().enumerate() {
                assert!(
                    (row.iter().sum::<f64>() - c[i]).abs() < 1e-15,
                    "{scheme:?} row {i}"
                );
            }
            let c2: Vec<f64> = c.iter().map(|x| x * x).collect();
            let c3: Vec<f64> = c.iter().map(|x| x * x * x).collect();
            let ac = times(&a, c);
            let bc: Vec<f64> = b.iter().zip(c).map(|(b, c)| b * c).collect();
            let mut conditions = vec![
                (1, dot(&b, &vec![1.0; c.len()]), 1.0),
                (2, dot(&b, c), 0.5),
                (3, dot(&b, &c2), 1.0 / 3.0),
                (3, dot(&b, &ac), 1.0 / 6.0),
                (4, dot(&b, &c3), 0.25),
                (4, dot(&bc, &ac), 0.125),
                (4, dot(&b, &times(&a, &c2)), 1.0 / 12.0),
                (4, dot(&b, &times(&a, &ac)), 1.0 / 24.0),
            ];
            conditions.retain(|(p, ..)| *p <= order);
            for (p, value, exact) in conditions {
                assert!(
                    (value - exact).abs() < 1e-14,
                    "{scheme:?} order {p}: {value} vs {exact}"
                );
            }
            // The embedded weights b̂ = b − error: one order apart from the method.
            let bhat: Vec<f64> = b.iter().zip(t.error).map(|(b, e)| b - e).collect();
            let sum: f64 = t.error.iter().sum();
            assert!(sum.abs() < 1e-15, "{scheme:?}: both methods consistent");
            let lower = t.estimate_order - 1;
            let embedded = [
                dot(&bhat, c) - 0.5,
                dot(&bhat, &c2) - 1.0 / 3.0,
                dot(&bhat, &ac) - 1.0 / 6.0,
            ];
            assert!(embedded.iter().all(|e| e.abs() < 1e-14), "{scheme:?} b̂");
            if lower == 3 && order == 4 {
                // The embedded method is of order three, not four.
                assert!((dot(&bhat, &c3) - 0.25).abs() > 1e-6);
            }
        }
    }

    /// L-stability: the stability function R(z) = 1 + z bᵀ(I − zA)⁻¹1 vanishes at −∞ (the
    /// stiffly accurate method's R(∞) = 0) and |R(iy)| ≤ 1 on the imaginary axis.
    #[test]
    fn l_stable() {
        for scheme in [Scheme::TrBdf2, Scheme::Esdirk4] {
            let (a, b) = full(scheme.tableau());
            let s = b.len();
            // R(z) for real z by forward substitution; complex z as pairs.
            let r = |re: f64, im: f64| {
                let mut k = vec![(0.0f64, 0.0f64); s];
                for i in 0..s {
                    // k_i = 1 + z Σ_j a_ij k_j (j ≤ i): solve for k_i.
                    let (mut sr, mut si) = (1.0, 0.0);
                    for j in 0..i {
                        let (kr, ki) = k[j];
                        let (pr, pi) = (re * kr - im * ki, re * ki + im * kr);
                        sr += a[i][j] * pr;
                        si += a[i][j] * pi;
                    }
                    let (dr, di) = (1.0 - a[i][i] * re, -a[i][i] * im);
                    let den = dr * dr + di * di;
                    k[i] = ((sr * dr + si * di) / den, (si * dr - sr * di) / den);
                }
                k[s - 1]
            };
            let (r0, i0) = r(-1e12, 0.0);
            assert!(
                r0.abs() < 1e-9 && i0.abs() < 1e-9,
                "{scheme:?}: R(-inf) = {r0}"
            );
            for k in 0..2000 {
                let y = (k as f64 * 0.01).powi(2);
                let (re, im) = r(0.0, y);
                assert!(
                    re * re + im * im <= 1.0 + 1e-12,
                    "{scheme:?}: |R({y}i)| > 1"
                );
                let (re, im) = r(-y, y);
                assert!(
                    re * re + im * im <= 1.0 + 1e-12,
                    "{scheme:?}: |R(-{y}+{y}i)| > 1"
                );
            }
        }
    }
}
