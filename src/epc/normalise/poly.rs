//! The polynomial Q(ξ) of a solution in scaled variables, with the evaluations the
//! normalisation needs (values, derivatives, restrictions to rays, tensor grids).

/// A polynomial Q(ξ) = Σ a_s ξ1^i ξ2^j.
#[derive(Clone, Debug)]
pub(crate) struct Poly {
    /// Exponents (i, j) of the monomials.
    pub exps: Vec<(usize, usize)>,
    /// Their coefficients.
    pub a: Vec<f64>,
    /// The total degree n.
    pub degree: usize,
}

impl Poly {
    /// Q(x), Σ a·x1^i·x2^j summed in the order of [`Poly::exps`], with the powers from
    /// [`powers`] (bit for bit those of `powi`, without a call per monomial).
    pub(crate) fn eval(&self, x: [f64; 2]) -> f64 {
        let (p1, p2) = (powers(x[0]), powers(x[1]));
        self.exps
            .iter()
            .zip(&self.a)
            .map(|(&(i, j), a)| a * p1[i] * p2[j])
            .sum()
    }

    /// Gradient and Hessian.
    pub(crate) fn derivs(&self, x: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        // The powers from the table, bit for bit `powi`'s ([`powers`]).
        let powers = [powers(x[0]), powers(x[1])];
        // d-th derivative of x^k: k(k−1)…(k−d+1)·x^(k−d), the factor an exact integer.
        let p = |axis: usize, k: usize, d: usize| -> f64 {
            if k < d {
                0.0
            } else {
                let c = match d {
                    0 => 1.0,
                    1 => k as f64,
                    _ => ((k - 1) * k) as f64,
                };
                c * powers[axis][k - d]
            }
        };
        let mut g = [0.0; 2];
        let mut h = [[0.0; 2]; 2];
        for (&(i, j), a) in self.exps.iter().zip(&self.a) {
            g[0] += a * p(0, i, 1) * p(1, j, 0);
            g[1] += a * p(0, i, 0) * p(1, j, 1);
            h[0][0] += a * p(0, i, 2) * p(1, j, 0);
            h[0][1] += a * p(0, i, 1) * p(1, j, 1);
            h[1][1] += a * p(0, i, 0) * p(1, j, 2);
        }
        h[1][0] = h[0][1];
        (g, h)
    }

    /// Coefficients q_d of Q(m + r u) as a polynomial in r.
    pub(crate) fn along_ray(&self, m: [f64; 2], u: [f64; 2]) -> Vec<f64> {
        let mut q = vec![0.0; self.degree + 1];
        let binom = binomials();
        // The powers from the table, bit for bit `powi`'s ([`powers`]).
        let (pm, pu) = (m.map(powers), u.map(powers));
        let mut cl = [0.0; MAX_POWER + 1];
        for (&(i, j), a) in self.exps.iter().zip(&self.a) {
            // (m0 + r u0)^i (m1 + r u1)^j, the second factor's terms taken once.
            for (l, c) in cl.iter_mut().enumerate().take(j + 1) {
                *c = binom[j][l] * pm[1][j - l] * pu[1][l];
            }
            for k in 0..=i {
                let ck = binom[i][k] * pm[0][i - k] * pu[0][k];
                for (l, c) in cl.iter().enumerate().take(j + 1) {
                    q[k + l] += a * ck * c;
                }
            }
        }
        q
    }

    /// Coefficients c_k of Q on the line ξ_axis = `at` as a polynomial in the other
    /// variable t: Q = Σ_{k ≤ degree} c_k t^k (evaluate with [`horner`] on
    /// `c[..=degree]`; the entries above the degree are 0).
    pub(crate) fn on_line(&self, axis: usize, at: f64) -> [f64; MAX_POWER + 1] {
        let mut c = [0.0; MAX_POWER + 1];
        let p = powers(at);
        for (&(i, j), a) in self.exps.iter().zip(&self.a) {
            let (fixed, free) = if axis == 0 { (i, j) } else { (j, i) };
            c[free] += a * p[fixed];
        }
        c
    }

    /// Values on a tensor grid, row-major in ξ1 (index i·n2 + j).
    pub(crate) fn on_grid(&self, g1: &[f64], g2: &[f64]) -> Vec<f64> {
        let n = self.degree;
        let mut out = Vec::with_capacity(g1.len() * g2.len());
        let mut cj = vec![0.0; n + 1];
        for &x1 in g1 {
            cj.iter_mut().for_each(|v| *v = 0.0);
            let p1 = powers(x1);
            for (&(i, j), a) in self.exps.iter().zip(&self.a) {
                cj[j] += a * p1[i];
            }
            for &x2 in g2 {
                let mut v = 0.0;
                for c in cj.iter().rev() {
                    v = v * x2 + c;
                }
                out.push(v);
            }
        }
        out
    }
}

/// The binomial coefficients C(n, k) for n ≤ [`MAX_POWER`], each as the product
/// Π_{t<k} (n − t)/(t + 1) taken in that order (exact: every partial product is an integer
/// below 2^53), computed once.
fn binomials() -> &'static [[f64; MAX_POWER + 1]; MAX_POWER + 1] {
    static TABLE: std::sync::OnceLock<[[f64; MAX_POWER + 1]; MAX_POWER + 1]> =
        std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut table = [[0.0; MAX_POWER + 1]; MAX_POWER + 1];
        for (n, row) in table.iter_mut().enumerate() {
            for (k, b) in row.iter_mut().enumerate().take(n + 1) {
                *b = (0..k).fold(1.0, |acc, t| acc * (n - t) as f64 / (t + 1) as f64);
            }
        }
        table
    })
}

/// The highest power [`powers`] tabulates: the largest degree of Q (12) and then some.
pub(crate) const MAX_POWER: usize = 15;

/// x^k for k = 0…[`MAX_POWER`], each bit for bit equal to `x.powi(k)`: `powi` with an exponent
/// known only at run time is compiler-rt's `__powidf2`, which multiplies, from the lowest bit
/// of k up, the squares x, x², x⁴, x⁸ of the bits set in k (so x³ = x·x², x⁴ = (x²)², not
/// ((x·x)·x)·x). The table does the same multiplications once for all k, so evaluating Q
/// at a point costs four squarings and a product per power instead of a call per monomial,
/// and every printed number stays what `powi` gave.
#[inline]
pub(crate) fn powers(x: f64) -> [f64; MAX_POWER + 1] {
    // The highest set bit of k is multiplied last: x^k = x^(k − 2^h)·x^(2^h), and
    // 1·x^(2^h) is exact.
    let x2 = x * x;
    let x3 = x * x2;
    let x4 = x2 * x2;
    let x5 = x * x4;
    let x6 = x2 * x4;
    let x7 = x3 * x4;
    let x8 = x4 * x4;
    [
        1.0,
        x,
        x2,
        x3,
        x4,
        x5,
        x6,
        x7,
        x8,
        x * x8,
        x2 * x8,
        x3 * x8,
        x4 * x8,
        x5 * x8,
        x6 * x8,
        x7 * x8,
    ]
}

/// q(r) = Σ_d q_d r^d by Horner's rule.
pub(crate) fn horner(q: &[f64], r: f64) -> f64 {
    q.iter().rev().fold(0.0, |acc, c| acc * r + c)
}

/// The coefficients a line or ray polynomial has at most (degree 12, the largest EPC solves)
/// for an [`enclosure`].
const MAX_COEFS: usize = 13;

/// An interval holding every value `horner(c, t)` computes for t in [`lo`, `hi`]: `None` for
/// more than [`MAX_COEFS`] coefficients, or where a coefficient is NaN or the bounds
/// overflow.
///
/// The polynomial on the interval is its Taylor polynomial at the middle m, Σ d_k u^k with
/// |u| ≤ r, so it lies within Σ_{k odd} |d_k| r^k of d_0 plus the even terms, each between 0
/// and d_k r^k (near a maximum the enclosure stays below it). Rounding (of the d_k, of every
/// computed `horner(c, t)`, of m and of the points) moves a value by a small multiple of
/// ε·Σ |c_k| (|m| + r)^k: the enclosure is widened by 10⁻¹⁰ of that sum and r by 10⁻¹² of
/// the ends, far more than any of it.
pub(crate) fn enclosure(c: &[f64], lo: f64, hi: f64) -> Option<[f64; 2]> {
    if c.is_empty() || c.len() > MAX_COEFS {
        return None;
    }
    let n = c.len() - 1;
    let m = 0.5 * (lo + hi);
    let r = 0.5 * (hi - lo) + 1e-12 * (lo.abs() + hi.abs()) + f64::MIN_POSITIVE;
    // The Taylor coefficients at m by repeated synthetic division.
    let mut d = [0.0; MAX_COEFS];
    d[..=n].copy_from_slice(c);
    for i in 0..n {
        // d[j] += m·d[j + 1] from the top, the new d[j + 1] carried in a register (through
        // memory, each step waited for the last one's store).
        let mut carry = d[n];
        for dj in d[i..n].iter_mut().rev() {
            carry = *dj + m * carry;
            *dj = carry;
        }
    }
    // Σ_{k≥1} d_k u^k over |u| ≤ r: an odd power's term is within ±|d_k| r^k, an even
    // power's between 0 and d_k r^k.
    let (mut below, mut above, mut rk) = (0.0, 0.0, 1.0);
    for (k, &dk) in d.iter().enumerate().take(n + 1).skip(1) {
        rk *= r;
        let term = dk * rk;
        if k % 2 == 1 {
            below -= term.abs();
            above += term.abs();
        } else if term < 0.0 {
            below += term;
        } else {
            above += term;
        }
    }
    let margin = rounding(c, m.abs() + r);
    let (q_lo, q_hi) = (d[0] + below - margin, d[0] + above + margin);
    // Written so that a NaN or an overflow refuses.
    (q_lo.is_finite() && q_hi.is_finite()).then_some([q_lo, q_hi])
}

/// A bound on the rounding of `horner(c, t)` as computed, far above it, for |t| ≤ `reach`:
/// 10⁻¹⁰ of Σ |c_k| reach^k (a small multiple of ε times that sum is the actual bound).
pub(crate) fn rounding(c: &[f64], reach: f64) -> f64 {
    1e-10 * c.iter().rev().fold(0.0, |acc, ck| acc * reach + ck.abs())
}

/// The coefficients of the derivative of the polynomial `c` (Σ c_k t^k), (k + 1)·c_{k+1},
/// into `out[k]` for k = 0…`c.len()` − 2 (`out` has that length).
pub(crate) fn derivative(c: &[f64], out: &mut [f64]) {
    for (k, d) in out.iter_mut().enumerate() {
        *d = (k + 1) as f64 * c[k + 1];
    }
}

/// Points evaluated at once by [`horner_block`].
pub(crate) const BLOCK: usize = 32;

/// [`horner`]`(q, t)` at each of the points `t`, bit for bit: the same operations in the same
/// order for each point, the points side by side (independent chains, which vectorise, where
/// one evaluation waits on each multiply-add of its chain).
pub(crate) fn horner_block(q: &[f64], t: &[f64; BLOCK]) -> [f64; BLOCK] {
    let mut acc = [0.0; BLOCK];
    for &c in q.iter().rev() {
        for (a, &t) in acc.iter_mut().zip(t) {
            *a = *a * t + c;
        }
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block's values are `horner`'s, bit for bit.
    #[test]
    fn horner_block_is_horner() {
        let c = [0.3, -1.7, 0.25, 1e-3, -2.5e-2, 7e-5];
        let t: [f64; BLOCK] = std::array::from_fn(|k| 0.37 * k as f64 - 4.1);
        for (&t, &v) in t.iter().zip(&horner_block(&c, &t)) {
            assert_eq!(v.to_bits(), horner(&c, t).to_bits(), "t = {t}");
        }
    }

    #[test]
    fn powers_are_powi_bit_for_bit() {
        // Exponents hidden from the optimiser, so that `powi` is the run-time routine the
        // code used before the table (a constant exponent may be expanded differently).
        let mut x = 0.123_456_789_f64;
        for _ in 0..2000 {
            x = (x * 7.919 + 0.3).fract() * 40.0 - 20.0;
            let p = powers(x);
            for (k, pk) in p.iter().enumerate() {
                let e = std::hint::black_box(k as i32);
                assert_eq!(pk.to_bits(), x.powi(e).to_bits(), "{x}^{k}");
            }
        }
    }

    #[test]
    fn eval_is_the_polynomial() {
        let q = Poly {
            exps: vec![
                (1, 0),
                (0, 1),
                (2, 0),
                (1, 1),
                (0, 2),
                (3, 1),
                (0, 4),
                (4, 0),
            ],
            a: vec![0.3, -0.2, -0.5, 0.1, -0.7, 0.05, -0.01, -0.02],
            degree: 4,
        };
        let x = 1.7_f64;
        let y = -2.3_f64;
        let direct: f64 = 0.3 * x - 0.2 * y - 0.5 * x * x + 0.1 * x * y - 0.7 * y * y
            + 0.05 * x * x * x * y
            - 0.01 * y.powi(4)
            - 0.02 * x.powi(4);
        assert!((q.eval([x, y]) - direct).abs() < 1e-12);
        // Restricted to either coordinate line, by Horner in the free variable.
        let c = q.on_line(0, x);
        assert!((horner(&c[..=4], y) - direct).abs() < 1e-12);
        let c = q.on_line(1, y);
        assert!((horner(&c[..=4], x) - direct).abs() < 1e-12);
    }

    /// Q along a ray is Q at the ray's points (to rounding), at degrees 2 to 12; and the
    /// binomial table is C(n, k) exactly.
    #[test]
    fn along_ray_is_q_on_the_ray() {
        assert_eq!(binomials()[12][5], 792.0);
        assert_eq!(binomials()[15][7], 6435.0);
        for degree in [2, 4, 7, 12] {
            let exps: Vec<(usize, usize)> = (1..=degree)
                .flat_map(|d| (0..=d).map(move |j| (d - j, j)))
                .collect();
            let a: Vec<f64> = (0..exps.len())
                .map(|k| ((k * 37 % 11) as f64 - 5.0) * 0.1 / (1 + k) as f64)
                .collect();
            let q = Poly { exps, a, degree };
            let m = [0.4, -0.3];
            for th in [0.1_f64, 1.3, 2.9, 4.4] {
                let u = [th.cos(), th.sin()];
                let c = q.along_ray(m, u);
                for r in [0.0, 0.5, 1.0, 1.7] {
                    let x = [m[0] + r * u[0], m[1] + r * u[1]];
                    let (got, want) = (horner(&c, r), q.eval(x));
                    assert!(
                        (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                        "degree {degree}, θ {th}, r {r}: {got} vs {want}"
                    );
                }
            }
        }
    }
}
