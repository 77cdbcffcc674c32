//! The mechanical form x' = v, v' = m(x, v) + noise that the grid solver discretises, taken
//! from a bound model: the Itô drift m of v, the diffusion b = b_vv and ∂b/∂v compiled to one
//! tape, and the model's impact law read as a barrier on x.

use super::error::{GridError, Unsupported};
use super::BarrierSide;
use crate::model::BoundModel;
use crate::symbolic::{diff, simplify, DeltaPolicy, Expr, Tape};

/// How the barrier acts on the flux that reaches it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum BarrierKind {
    /// The jump keeps the velocity's sign (`v -> r*v`, the Zhuravlev form): the state passes
    /// through and the density lives on both sides.
    PassThrough,
    /// The jump reverses the velocity (`v -> -r*v`, original coordinates): the state stays on
    /// one side.
    Reflecting(BarrierSide),
}

/// An impact law as the grid solver reads it from a model, before compilation.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Law {
    pub(crate) state: usize,
    pub(crate) other: usize,
    pub(crate) at: f64,
    pub(crate) map: Expr,
    /// The side the state lives on for a reflecting law (`None` for a pass-through law).
    pub(crate) side: Option<BarrierSide>,
}

/// The model's impact laws as the grid solver reads them: the one place that knows how the
/// model states them (none, one, or the two walls of a strip, each with its side).
fn model_laws(model: &BoundModel) -> Vec<Law> {
    model
        .impacts()
        .iter()
        .map(|law| Law {
            state: law.state,
            other: law.other,
            at: law.at,
            map: law.map.clone(),
            side: law.side,
        })
        .collect()
}

/// The model's impact law on the position axis.
#[derive(Clone, Debug)]
pub(crate) struct Barrier {
    pub(crate) at: f64,
    pub(crate) kind: BarrierKind,
    /// The jump map v -> map(x, v), compiled over (x, v).
    map: crate::dynamics::Jump,
}

impl Barrier {
    /// The post-impact velocity of `v` at the barrier.
    pub(crate) fn map(&self, v: f64) -> f64 {
        self.map.map(self.at, v)
    }
}

/// Drift, diffusion and barrier of a mechanical-form model.
#[derive(Clone, Debug)]
pub(crate) struct Mechanical {
    /// Outputs m, b, ∂b/∂v over (x, v). δ terms of the drift are left out: they are the
    /// paper's approximation of the impact that the re-injection represents exactly.
    coefficients: Tape,
    /// None, one, or two reflecting walls bounding a strip (lower first).
    pub(crate) barriers: Vec<Barrier>,
}

/// Coefficients at a batch of points.
pub(crate) struct Coefficients {
    pub(crate) m: Vec<f64>,
    pub(crate) b: Vec<f64>,
    pub(crate) db: Vec<f64>,
}

impl Mechanical {
    /// Reads the mechanical form of `model`, or says why it has none.
    pub(crate) fn new(model: &BoundModel) -> Result<Self, GridError> {
        Mechanical::with_laws(model, model_laws(model))
    }

    /// [`Mechanical::new`] with the impact laws `laws` in place of the model's own.
    pub(crate) fn with_laws(model: &BoundModel, laws: Vec<Law>) -> Result<Self, GridError> {
        let states = model.states();
        let (x, v) = (states[0].to_string(), states[1].to_string());
        let refuse = |reason| GridError::Unsupported {
            model: model.name().to_string(),
            reason,
        };
        let rate = simplify(&model.drift()[0].without_deltas());
        if rate != Expr::sym(&v) {
            return Err(refuse(Unsupported::NotMechanical {
                position: x,
                velocity: v,
                rate: format!("{rate:#}"),
            }));
        }
        let s = model.intensity();
        let g = model.noise_matrix();
        for (k, name) in model.noise_names().iter().enumerate() {
            if g[0][k].as_num() != Some(0.0) && s[k][k] != 0.0 {
                return Err(refuse(Unsupported::NoiseInPosition {
                    position: x,
                    noise: name.to_string(),
                }));
            }
        }
        crate::dynamics::check(model)?;
        // δ terms are dropped below only because an impact law stands for them exactly.
        if laws.is_empty() && model.drift()[1].contains_delta() {
            return Err(refuse(Unsupported::DeltaWithoutImpact {
                velocity: v,
                coefficient: "drift",
            }));
        }
        if (0..g[1].len()).any(|k| g[1][k].contains_delta()) {
            return Err(refuse(Unsupported::DeltaInDiffusion { velocity: v }));
        }
        let (_, ito) = crate::fpk::ito_drift(model)?;
        let m = simplify(&ito[1].without_deltas());
        let mut terms = Vec::new();
        for (k, row) in s.iter().enumerate() {
            for (l, &skl) in row.iter().enumerate() {
                if skl != 0.0 {
                    terms.push(Expr::num(skl) * g[1][k].clone() * g[1][l].clone());
                }
            }
        }
        let b = simplify(&crate::symbolic::expand(&Expr::sum(terms)).without_deltas());
        let db = diff(&b, &v).map_err(|source| GridError::Symbolic {
            what: format!("d b_{v}{v} / d{v}"),
            source,
        })?;
        let vars = [x.as_str(), v.as_str()];
        let coefficients = Tape::compile(&[m, b, db.without_deltas()], &vars, DeltaPolicy::Zero)
            .map_err(|source| GridError::Symbolic {
                what: format!("the drift and diffusion of `{v}`"),
                source,
            })?;
        let mut barriers = Vec::with_capacity(laws.len());
        for law in &laws {
            if law.state != 0 || law.other != 1 {
                return Err(refuse(Unsupported::ImpactNotOnPosition {
                    position: x,
                    velocity: v,
                }));
            }
            let map = crate::dynamics::Jump::compile(&law.map, &vars).map_err(|source| {
                GridError::Symbolic {
                    what: "the jump map".into(),
                    source,
                }
            })?;
            let mut barrier = Barrier {
                at: law.at,
                kind: BarrierKind::PassThrough,
                map,
            };
            let kind = classify(&barrier).ok_or_else(|| {
                refuse(Unsupported::ImpactMap {
                    map: format!("{:#}", law.map),
                })
            })?;
            barrier.kind = match kind {
                // The model says the side of every reflecting law (its `domain` line); a map
                // this solver reads as reflecting where the model did not is refused.
                BarrierKind::Reflecting(_) => {
                    BarrierKind::Reflecting(law.side.ok_or_else(|| {
                        refuse(Unsupported::ImpactMap {
                            map: format!("{:#}", law.map),
                        })
                    })?)
                }
                pass => pass,
            };
            barriers.push(barrier);
        }
        barriers.sort_by(|a, b| a.at.total_cmp(&b.at));
        let strip = match barriers.as_slice() {
            [lo, hi] => {
                lo.at < hi.at
                    && lo.kind == BarrierKind::Reflecting(BarrierSide::Above)
                    && hi.kind == BarrierKind::Reflecting(BarrierSide::Below)
            }
            _ => barriers.len() < 2,
        };
        if !strip {
            return Err(refuse(Unsupported::NotAStrip {
                count: barriers.len(),
                at: barriers.iter().map(|b| b.at).collect(),
            }));
        }
        Ok(Mechanical {
            coefficients,
            barriers,
        })
    }

    /// m, b and ∂b/∂v at the points (x[p], v[p]).
    pub(crate) fn eval(&self, x: &[f64], v: &[f64]) -> Result<Coefficients, GridError> {
        let n = x.len();
        let mut out = vec![vec![0.0; n]; 3];
        self.coefficients
            .eval_batch(&[x, v], &mut out, &mut crate::symbolic::TapeScratch::new());
        let db = out.pop().unwrap_or_default();
        let b = out.pop().unwrap_or_default();
        let m = out.pop().unwrap_or_default();
        let names = ["the drift", "the diffusion", "d b / dv"];
        for (what, col) in names.iter().zip([&m, &b, &db]) {
            if let Some(p) = col.iter().position(|c| !c.is_finite()) {
                return Err(GridError::NotFinite {
                    what,
                    x: x[p],
                    v: v[p],
                });
            }
        }
        Ok(Coefficients { m, b, db })
    }

    /// A Gaussian scale (σx, σv) from the linearisation at the origin: σv² = b/(2c),
    /// σx² = σv²/k; `None` when the origin is not a damped stable rest point.
    pub(crate) fn linear_scale(&self, centre: f64) -> Option<[f64; 2]> {
        let h = 1e-4;
        let at = |x: f64, v: f64| self.eval(&[x], &[v]).ok().map(|c| (c.m[0], c.b[0]));
        let (mxp, _) = at(centre + h, 0.0)?;
        let (mxm, _) = at(centre - h, 0.0)?;
        let (mvp, _) = at(centre, h)?;
        let (mvm, b) = at(centre, -h)?;
        let k = -(mxp - mxm) / (2.0 * h);
        let c = -(mvp - mvm) / (2.0 * h);
        (k > 0.0 && c > 0.0 && b > 0.0).then(|| {
            let sv = (b / (2.0 * c)).sqrt();
            [sv / k.sqrt(), sv]
        })
    }
}

/// Whether the jump keeps or reverses the sign of the velocity, monotonically and without
/// adding speed, on probes from 1e-3 to 1e3.
fn classify(barrier: &Barrier) -> Option<BarrierKind> {
    let mut sign = 0.0;
    let mut last = [0.0f64; 2];
    for e in -3..=3 {
        for f in [1.0, 2.0, 5.0] {
            let v = f * 10f64.powi(e);
            for (s, vv) in [v, -v].into_iter().enumerate() {
                let w = barrier.map(vv);
                let ratio = w / vv;
                if !(ratio.is_finite() && ratio != 0.0 && ratio.abs() <= 1.0 + 1e-12) {
                    return None;
                }
                if sign == 0.0 {
                    sign = ratio.signum();
                } else if ratio.signum() != sign {
                    return None;
                }
                if w.abs() < last[s] {
                    return None;
                }
                last[s] = w.abs();
            }
        }
    }
    Some(if sign > 0.0 {
        BarrierKind::PassThrough
    } else {
        BarrierKind::Reflecting(BarrierSide::Above)
    })
}
