//! The FPK residual of an epc-impact density: how far p = C·exp(Q) is from solving the
//! stationary FPK equation on its domain and the impact condition at its barriers, the figure
//! the δ-term EPC reports as ∫|F|·p (`epc/residual.rs`), here with the boundary term the
//! weak form carries instead of a δ line.

use nalgebra::DVector;

use super::mechanics::Mechanics;
use super::rule::System;

/// The two parts of the FPK residual of a normalised density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FpkResidual {
    /// ∫∫_D |F|·p dx dv with F = (L*p)/p, L* the FPK operator.
    pub(crate) interior: f64,
    /// Σ_barriers ∫_{arriving v} | |v|·p(x_b, v) − |map v|·p(x_b, map v)·|map′(v)| | dv: the
    /// mismatch between the probability flux that arrives at v and the flux the impact law
    /// sends back at map(v).
    pub(crate) boundary: f64,
}

impl System {
    /// The FPK residual of exp(Q) normalised on the box, by the system's rule; `None` when
    /// the derivatives of the drift or diffusion have δ terms or are not finite.
    ///
    /// With p = C·exp(Q), L*p = −∂x(v p) − ∂v(m p) + ½ ∂²v(b p) gives
    /// F = −v Q_x − ∂v m − m Q_v + ½ (∂²v b + 2 ∂v b Q_v + b (Q_vv + Q_v²)).
    pub(crate) fn fpk_residual(&self, mech: &Mechanics, a: &DVector<f64>) -> Option<FpkResidual> {
        let (xs, vs): (Vec<f64>, Vec<f64>) = self.nodes.iter().map(|n| (n[0], n[1])).unzip();
        let [m, b] = mech.eval_batch(&xs, &vs).ok()?;
        let [dm, db, ddb] = mech.derivatives_batch(&xs, &vs)?;
        let log_z = self.log_z(a);
        let [sx, sv] = self.sigma;
        let mut interior = 0.0;
        for k in 0..xs.len() {
            let d = derivatives(&self.exps, a.as_slice(), xs[k] / sx, vs[k] / sv);
            let (qx, qv, qvv) = (d[1] / sx, d[2] / sv, d[3] / (sv * sv));
            let f = -vs[k] * qx - dm[k] - m[k] * qv
                + 0.5 * (ddb[k] + 2.0 * db[k] * qv + b[k] * (qvv + qv * qv));
            interior += self.node_weights[k] * f.abs() * (d[0] - log_z).exp();
        }
        let p = |x: f64, v: f64| {
            (derivatives(&self.exps, a.as_slice(), x / sx, v / sv)[0] - log_z).exp()
        };
        let boundary = self
            .boundary
            .iter()
            .map(|n| {
                let arriving = n.v.abs() * p(n.at, n.v);
                let sent = n.image.abs() * p(n.at, n.image) * n.slope;
                n.weight * (arriving - sent).abs()
            })
            .sum();
        (interior.is_finite() && f64::is_finite(boundary))
            .then_some(FpkResidual { interior, boundary })
    }
}

/// Q, ∂ξQ, ∂ηQ and ∂²ηQ at (ξ, η) for Q = Σ a_s ξ^i η^j.
fn derivatives(exps: &[(usize, usize)], a: &[f64], xi: f64, eta: f64) -> [f64; 4] {
    let pw = |t: f64, k: usize, less: usize| {
        if k < less {
            0.0
        } else {
            t.powi((k - less) as i32)
        }
    };
    let mut out = [0.0; 4];
    for (&(i, j), c) in exps.iter().zip(a) {
        let (fi, fj) = (i as f64, j as f64);
        out[0] += c * pw(xi, i, 0) * pw(eta, j, 0);
        out[1] += c * fi * pw(xi, i, 1) * pw(eta, j, 0);
        out[2] += c * fj * pw(xi, i, 0) * pw(eta, j, 1);
        out[3] += c * fj * (fj - 1.0) * pw(xi, i, 0) * pw(eta, j, 2);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_of_a_polynomial() {
        // Q = 2ξ − ξ²η + 3η³.
        let exps = [(1, 0), (2, 1), (0, 3)];
        let a = [2.0, -1.0, 3.0];
        let (x, e) = (0.7, -1.3);
        let d = derivatives(&exps, &a, x, e);
        let exact = [
            2.0 * x - x * x * e + 3.0 * e.powi(3),
            2.0 - 2.0 * x * e,
            -x * x + 9.0 * e * e,
            18.0 * e,
        ];
        for (g, w) in d.iter().zip(exact) {
            approx::assert_relative_eq!(*g, w, max_relative = 1e-14);
        }
    }
}
