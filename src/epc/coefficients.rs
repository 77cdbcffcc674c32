//! The FPK operator's coefficients as six channels (A0, A1, A2, B11, B12, B22), their
//! evaluation at points, their kinks and their polynomial degree.

use crate::fpk::FpkOperator;
use crate::model::DeltaTreatment;
use crate::symbolic::{DeltaLine, DeltaPolicy, Expr, Func, Symbol, Tape, TapeScratch};

use super::EpcError;
use crate::numerics::quadrature::{normal_pdf, regularised_rule, split_normal_rule};

/// Channel order: A0, A1, A2, B11, B12, B22.
pub(crate) const CHANNELS: usize = 6;
const NAMES: [&str; CHANNELS] = ["A0", "A1", "A2", "B11", "B12", "B22"];

/// The operator's coefficients, one regular part and a list of delta lines per channel, with
/// the regular parts compiled into one tape and each line weight into its own (every point
/// evaluation of the engine goes through these tapes).
#[derive(Clone, Debug)]
pub(crate) struct Coefficients {
    states: [Symbol; 2],
    regular: [Expr; CHANNELS],
    lines: [Vec<DeltaLine>; CHANNELS],
    regular_tape: Tape,
    line_tapes: [Vec<Tape>; CHANNELS],
}

/// A quadrature point: position, weight and the six coefficient values (original units).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Point {
    pub x: [f64; 2],
    pub w: f64,
    pub g: [f64; CHANNELS],
}

/// Evaluates a (kink-argument) expression at a point by walking its tree: used only for the
/// few evaluations of root finding, never for coefficients at quadrature points.
fn eval_expr(what: &str, e: &Expr, states: &[Symbol; 2], x: [f64; 2]) -> Result<f64, EpcError> {
    let v = e
        .eval_states(states, x, DeltaPolicy::Reject)
        .map_err(|source| EpcError::Eval {
            what: what.to_string(),
            x1: x[0],
            x2: x[1],
            source,
        })?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(EpcError::NonFinite {
            what: what.to_string(),
            x1: x[0],
            x2: x[1],
        })
    }
}

/// The first non-finite value of a batch, as an error naming the channel and the point.
fn check_finite(what: &str, values: &[f64], x1: &[f64], x2: &[f64]) -> Result<(), EpcError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(p) => Err(EpcError::NonFinite {
            what: what.to_string(),
            x1: x1[p],
            x2: x2[p],
        }),
    }
}

impl Coefficients {
    pub(crate) fn new(fpk: &FpkOperator) -> Result<Coefficients, EpcError> {
        let parts = [
            &fpk.a0,
            &fpk.a[0],
            &fpk.a[1],
            &fpk.b[0][0],
            &fpk.b[0][1],
            &fpk.b[1][1],
        ];
        let regular = parts.map(|p| p.regular.clone());
        let lines = parts.map(|p| p.lines.clone());
        let vars = [&*fpk.states[0], &*fpk.states[1]];
        let compile = |what: &str, exprs: &[Expr]| {
            Tape::compile(exprs, &vars, DeltaPolicy::Reject).map_err(|source| EpcError::Compile {
                what: what.to_string(),
                source,
            })
        };
        let regular_tape = compile("the regular FPK coefficients", &regular)?;
        let mut line_tapes: [Vec<Tape>; CHANNELS] = Default::default();
        for (c, ls) in lines.iter().enumerate() {
            for l in ls {
                line_tapes[c].push(compile(NAMES[c], std::slice::from_ref(&l.weight))?);
            }
        }
        Ok(Coefficients {
            states: fpk.states.clone(),
            regular,
            lines,
            regular_tape,
            line_tapes,
        })
    }

    /// The six regular channels at the points (x1[p], x2[p]): `out[c][p]`.
    pub(crate) fn regular_batch(
        &self,
        x1: &[f64],
        x2: &[f64],
        scratch: &mut TapeScratch,
    ) -> Result<Vec<Vec<f64>>, EpcError> {
        let mut out = vec![vec![0.0; x1.len()]; CHANNELS];
        self.regular_tape.eval_batch(&[x1, x2], &mut out, scratch);
        for (c, v) in out.iter().enumerate() {
            check_finite(NAMES[c], v, x1, x2)?;
        }
        Ok(out)
    }

    /// Line `k` of channel `c`'s weight at the points (x1[p], x2[p]).
    fn line_batch(
        &self,
        c: usize,
        k: usize,
        x1: &[f64],
        x2: &[f64],
        scratch: &mut TapeScratch,
    ) -> Result<Vec<f64>, EpcError> {
        let mut out = [vec![0.0; x1.len()]];
        self.line_tapes[c][k].eval_batch(&[x1, x2], &mut out, scratch);
        let [v] = out;
        check_finite(NAMES[c], &v, x1, x2)?;
        Ok(v)
    }

    /// All expressions (regular parts and line weights).
    fn exprs(&self) -> impl Iterator<Item = &Expr> {
        self.regular
            .iter()
            .chain(self.lines.iter().flatten().map(|l| &l.weight))
    }

    /// The largest per-state polynomial degree of any coefficient (piecewise: kinks at
    /// single-state abs/sgn/min/max arguments are allowed), or `None` when some coefficient is
    /// not piecewise polynomial along the axes.
    pub(crate) fn polynomial_degree(&self) -> Option<u32> {
        let mut d = 0;
        for e in self.exprs() {
            for s in &self.states {
                d = d.max(degree_in(e, s, &self.states)?);
            }
        }
        Some(d)
    }

    /// Kink positions of each state (original units), searched within ±`range[i]`, and whether
    /// some kink argument mixes both states (then no axis split makes the integrand piecewise
    /// polynomial).
    pub(crate) fn kinks(&self, range: [f64; 2]) -> Result<([Vec<f64>; 2], bool), EpcError> {
        let mut args = Vec::new();
        for e in self.exprs() {
            e.walk(&mut |n| {
                if let Expr::Call(f, a) = n {
                    match f {
                        Func::Abs | Func::Sgn => args.push(a[0].clone()),
                        Func::Min | Func::Max => args.push(a[0].clone() - a[1].clone()),
                        _ => {}
                    }
                }
            });
        }
        let mut out = [vec![], vec![]];
        let mut mixed = false;
        for u in args {
            let m = [u.mentions(&self.states[0]), u.mentions(&self.states[1])];
            match m {
                [true, true] => mixed = true,
                [false, false] => {}
                _ => {
                    let axis = if m[0] { 0 } else { 1 };
                    out[axis].extend(self.roots(&u, axis, range[axis])?);
                }
            }
        }
        for k in &mut out {
            k.sort_by(f64::total_cmp);
            k.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        }
        Ok((out, mixed))
    }

    /// Sign changes of a one-state expression on [−range, range].
    fn roots(&self, u: &Expr, axis: usize, range: f64) -> Result<Vec<f64>, EpcError> {
        let at = |t: f64| {
            let mut x = [0.0; 2];
            x[axis] = t;
            eval_expr("a kink argument", u, &self.states, x)
        };
        // Affine arguments (the usual abs(x), sgn(x - a)) have their root in closed form.
        let (um, u0, up, u2) = (at(-1.0)?, at(0.0)?, at(1.0)?, at(2.5)?);
        let slope = up - u0;
        if slope != 0.0
            && (u0 - um - slope).abs() <= 1e-14 * slope.abs()
            && (u2 - u0 - 2.5 * slope).abs() <= 1e-13 * slope.abs()
        {
            let r = -u0 / slope;
            return Ok(if r.abs() <= range { vec![r] } else { vec![] });
        }
        let n = 1000;
        let h = range / n as f64;
        let mut roots = Vec::new();
        let mut prev = at(-range)?;
        for i in (-(n as i64) + 1)..=(n as i64) {
            let t = i as f64 * h;
            let v = at(t)?;
            if v == 0.0 {
                roots.push(t);
            } else if prev != 0.0 && v.signum() != prev.signum() {
                let (mut lo, mut hi) = (t - h, t);
                for _ in 0..80 {
                    let mid = 0.5 * (lo + hi);
                    if at(mid)?.signum() == prev.signum() {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                roots.push(0.5 * (lo + hi));
            }
            prev = v;
        }
        Ok(roots)
    }

    /// The delta lines as (channel, index within the channel, line).
    pub(crate) fn lines(&self) -> impl Iterator<Item = (usize, usize, &DeltaLine)> {
        self.lines
            .iter()
            .enumerate()
            .flat_map(|(c, ls)| ls.iter().enumerate().map(move |(k, l)| (c, k, l)))
    }

    /// Line `k` of channel `c`'s weight at points of the line, given by the other state's
    /// values `along` (the weight is sifted: evaluated on the line).
    pub(crate) fn line_weights(
        &self,
        c: usize,
        k: usize,
        along: &[f64],
        scratch: &mut TapeScratch,
    ) -> Result<Vec<f64>, EpcError> {
        let line = &self.lines[c][k];
        let at = vec![line.at; along.len()];
        if line.axis == 0 {
            self.line_batch(c, k, &at, along, scratch)
        } else {
            self.line_batch(c, k, along, &at, scratch)
        }
    }

    /// Quadrature points for integrals ∫ G(x)·ref(x) dx, ref = φ(ξ1)φ(ξ2)/(s1 s2) with
    /// ξ = (x − centre)/scale: the regular tensor grid (each axis split at its kinks) and the
    /// delta lines (sifted, or regularised by `treatment`).
    pub(crate) fn points(
        &self,
        centre: [f64; 2],
        scale: [f64; 2],
        kinks: &[Vec<f64>; 2],
        order: usize,
        treatment: DeltaTreatment,
    ) -> Result<Vec<Point>, EpcError> {
        let to_xi = |axis: usize, v: &f64| (v - centre[axis]) / scale[axis];
        let rules = [0, 1].map(|a| {
            let splits: Vec<f64> = kinks[a].iter().map(|v| to_xi(a, v)).collect();
            split_normal_rule(&splits, order)
        });
        let mut scratch = TapeScratch::new();
        let (n1, n2) = (rules[0].nodes.len(), rules[1].nodes.len());
        let mut x1 = Vec::with_capacity(n1 * n2);
        let mut x2 = Vec::with_capacity(n1 * n2);
        for t1 in &rules[0].nodes {
            for t2 in &rules[1].nodes {
                x1.push(centre[0] + scale[0] * t1);
                x2.push(centre[1] + scale[1] * t2);
            }
        }
        let g = self.regular_batch(&x1, &x2, &mut scratch)?;
        let mut pts = Vec::with_capacity(n1 * n2);
        for (i1, w1) in rules[0].weights.iter().enumerate() {
            for (i2, w2) in rules[1].weights.iter().enumerate() {
                let p = i1 * n2 + i2;
                pts.push(Point {
                    x: [x1[p], x2[p]],
                    w: w1 * w2,
                    g: std::array::from_fn(|c| g[c][p]),
                });
            }
        }
        for (c, k, line) in self.lines() {
            let a = line.axis;
            let o = 1 - a;
            let xi_at = to_xi(a, &line.at);
            let along = match treatment {
                DeltaTreatment::Exact => crate::numerics::quadrature::QuadratureRule {
                    nodes: vec![xi_at],
                    weights: vec![normal_pdf(xi_at)],
                },
                DeltaTreatment::Gaussian { width } => {
                    regularised_rule(xi_at, width / scale[a], order)
                }
            };
            let rule_o = &rules[o];
            let xo: Vec<f64> = rule_o
                .nodes
                .iter()
                .map(|to| centre[o] + scale[o] * to)
                .collect();
            // The weight is sifted: a function of the other state only, evaluated on the line.
            let wline = self.line_weights(c, k, &xo, &mut scratch)?;
            for (ta, wa) in along.nodes.iter().zip(&along.weights) {
                for ((xo, wo), wl) in xo.iter().zip(&rule_o.weights).zip(&wline) {
                    let mut x = [0.0; 2];
                    x[a] = centre[a] + scale[a] * ta;
                    x[o] = *xo;
                    let mut g = [0.0; CHANNELS];
                    g[c] = *wl;
                    pts.push(Point {
                        x,
                        w: wa * wo / scale[a],
                        g,
                    });
                }
            }
        }
        Ok(pts)
    }
}

/// Polynomial degree of `e` in state `s` (other states and parameters as constants), with
/// abs/sgn/min/max of one-state arguments counted as piecewise polynomial.
fn degree_in(e: &Expr, s: &Symbol, states: &[Symbol; 2]) -> Option<u32> {
    let has_state = |e: &Expr| states.iter().any(|st| e.mentions(st));
    Some(match e {
        Expr::Num(_) => 0,
        Expr::Sym(x) => u32::from(x == s),
        Expr::Add(v) => v
            .iter()
            .map(|c| degree_in(c, s, states))
            .try_fold(0, |a, d| d.map(|d| a.max(d)))?,
        Expr::Mul(v) => v
            .iter()
            .map(|c| degree_in(c, s, states))
            .try_fold(0, |a, d| d.map(|d| a + d))?,
        Expr::Pow(b, p) => match p.as_num() {
            Some(k) if k >= 0.0 && k.fract() == 0.0 && k <= 64.0 => {
                degree_in(b, s, states)? * k as u32
            }
            _ if !has_state(e) => 0,
            _ => return None,
        },
        Expr::Call(f, args) => {
            if !has_state(e) {
                return Some(0);
            }
            match f {
                Func::Abs | Func::Min | Func::Max => args
                    .iter()
                    .map(|c| degree_in(c, s, states))
                    .try_fold(0, |a, d| d.map(|d| a.max(d)))?,
                Func::Sgn => 0,
                _ => return None,
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn states() -> [Symbol; 2] {
        ["z".into(), "v".into()]
    }

    #[test]
    fn degrees_and_kinks_are_found() {
        let z = Expr::sym("z");
        let v = Expr::sym("v");
        let e = Expr::num(1.0)
            + Expr::num(0.2) * Expr::call(Func::Abs, z.clone())
            + Expr::pow(z.clone(), Expr::num(3.0)) * v.clone();
        assert_eq!(degree_in(&e, &"z".into(), &states()), Some(3));
        assert_eq!(degree_in(&e, &"v".into(), &states()), Some(1));
        let t = Expr::call(Func::Tanh, z.clone());
        assert_eq!(degree_in(&t, &"z".into(), &states()), None);
        let c = Coefficients {
            states: states(),
            regular: [
                e,
                Expr::call(Func::Sgn, z.clone() - Expr::num(0.5)),
                Expr::num(0.0),
                Expr::num(0.0),
                Expr::num(0.0),
                Expr::num(0.0),
            ],
            lines: Default::default(),
            regular_tape: Tape::compile(&[], &["z", "v"], DeltaPolicy::Reject).unwrap(),
            line_tapes: Default::default(),
        };
        let (k, mixed) = c.kinks([3.0, 3.0]).unwrap();
        assert!(!mixed);
        assert_eq!(k[0].len(), 2);
        assert!(k[0][0].abs() < 1e-12 && (k[0][1] - 0.5).abs() < 1e-12);
        assert!(k[1].is_empty());
    }
}
