//! The mechanical form x' = v, v' = m(x, v) + noise taken from the model's [`Dynamics`] (the
//! Itô drift m of v and the v–v diffusion b, compiled to one tape), and its reflecting walls.

use super::error::{EpcImpactError, Unsupported};
use crate::dynamics::{Barrier, Barriers, Dynamics, DynamicsError};
use crate::model::BoundModel;
use crate::symbolic::{diff, simplify, DeltaPolicy, Expr, Tape, TapeScratch};

pub use crate::model::BarrierSide;

/// A reflecting wall on the position: the model's [`Barrier`] with the side this method
/// needs it to have (it solves reflecting walls only).
#[derive(Clone, Debug)]
pub(crate) struct Wall {
    /// The side the state lives on (the barrier's reflecting side, checked when built).
    pub(crate) side: BarrierSide,
    /// The barrier, for its jump.
    barrier: Barrier,
}

impl Wall {
    /// Its position.
    pub(crate) fn at(&self) -> f64 {
        self.barrier.at()
    }

    /// The post-impact velocity of an arriving `v`.
    pub(crate) fn map(&self, v: f64) -> f64 {
        self.barrier.jump(v)
    }

    /// The sign of the arriving velocities (−1 at a lower barrier, +1 at an upper one).
    pub(crate) fn arriving(&self) -> f64 {
        match self.side {
            BarrierSide::Above => -1.0,
            BarrierSide::Below => 1.0,
        }
    }
}

/// Drift, diffusion and barriers of a mechanical-form model with reflecting impacts.
#[derive(Clone, Debug)]
pub(crate) struct Mechanics {
    /// Outputs m and b over (x, v).
    coefficients: Tape,
    /// Outputs ∂v m, ∂v b and ∂²v b over (x, v), for the FPK residual; `None` when they
    /// have δ terms (a drift with sgn(v), say), which the residual does not integrate.
    derivatives: Option<Tape>,
    /// 0, 1 or 2 barriers (two bound a strip, the lower one first).
    pub(crate) barriers: Vec<Wall>,
}

impl Mechanics {
    /// Reads the mechanical form of `model` and its barriers, or says why it has none.
    pub(crate) fn new(dynamics: &Dynamics) -> Result<Mechanics, EpcImpactError> {
        let model = dynamics.model();
        let barriers = dynamics.barriers().map_err(|e| match e {
            DynamicsError::JumpMap { source } => EpcImpactError::Symbolic {
                what: "the jump map".into(),
                source,
            },
            DynamicsError::TooManyBarriers { .. } => {
                let at = |i: usize| model.impacts().get(i).map_or(f64::NAN, |l| l.at);
                EpcImpactError::Unsupported {
                    model: model.name().to_string(),
                    reason: Unsupported::NotAStrip {
                        lower: at(0),
                        upper: at(1),
                    },
                }
            }
        })?;
        let states = dynamics.states();
        let (x, v) = (states[0].to_string(), states[1].to_string());
        let refuse = |reason| EpcImpactError::Unsupported {
            model: model.name().to_string(),
            reason,
        };
        let sde = dynamics.sde();
        for (coefficient, e) in [("drift", &sde.drift()[1]), ("drift", &sde.drift()[0])] {
            if e.contains_delta() {
                return Err(refuse(Unsupported::DeltaTerms {
                    velocity: v.clone(),
                    coefficient,
                }));
            }
        }
        if sde.noise_matrix()[1].iter().any(|g| g.contains_delta()) {
            return Err(refuse(Unsupported::DeltaTerms {
                velocity: v.clone(),
                coefficient: "diffusion",
            }));
        }
        if barriers.iter().any(|b| b.state() != 0 || b.other() != 1) {
            return Err(refuse(Unsupported::ImpactNotOnPosition {
                position: x,
                velocity: v,
            }));
        }
        // A model without a stationary density is refused before the form is read.
        let drift = dynamics.ito_drift().map_err(crate::fpk::FpkError::from)?;
        dynamics.admissible().map_err(crate::fpk::FpkError::from)?;
        // This method's reading of the form is stricter than the grid's (`Form`): the Itô
        // rate of the position must be v and the position's diffusion entries must vanish
        // as expressions (the grid asks that no source with an intensity of its own drives x).
        let rate = simplify(&drift[0]);
        if rate != Expr::sym(&v) {
            return Err(refuse(Unsupported::NotMechanical {
                position: x,
                velocity: v,
                rate: format!("{rate:#}"),
            }));
        }
        let b = dynamics.diffusion();
        for entry in [&b[0][0], &b[0][1]] {
            let e = simplify(entry);
            if e.as_num() != Some(0.0) {
                return Err(refuse(Unsupported::NoiseInPosition {
                    position: x,
                    diffusion: format!("{e:#}"),
                }));
            }
        }
        let vars = [x.as_str(), v.as_str()];
        let exprs = [simplify(&drift[1]), simplify(&b[1][1])];
        let coefficients = Tape::compile(&exprs, &vars, DeltaPolicy::Reject).map_err(|source| {
            EpcImpactError::Symbolic {
                what: format!("the drift and diffusion of `{v}`"),
                source,
            }
        })?;
        let derivatives = (|| {
            let dm = simplify(&diff(&exprs[0], &v).ok()?);
            let db = simplify(&diff(&exprs[1], &v).ok()?);
            let ddb = simplify(&diff(&db, &v).ok()?);
            Tape::compile(&[dm, db, ddb], &vars, DeltaPolicy::Reject).ok()
        })();
        let barriers = walls(model, barriers)?;
        Ok(Mechanics {
            coefficients,
            derivatives,
            barriers,
        })
    }

    /// m and b at the points (x[k], v[k]); an error names the first point where one is not
    /// finite.
    pub(crate) fn eval_batch(&self, x: &[f64], v: &[f64]) -> Result<[Vec<f64>; 2], EpcImpactError> {
        let mut out = [vec![0.0; x.len()], vec![0.0; x.len()]];
        self.coefficients
            .eval_batch(&[x, v], &mut out, &mut TapeScratch::new());
        for (what, col) in ["the drift of the velocity", "the diffusion"]
            .into_iter()
            .zip(&out)
        {
            if let Some(k) = col.iter().position(|c| !c.is_finite()) {
                return Err(EpcImpactError::NotFinite {
                    what,
                    x: x[k],
                    v: v[k],
                });
            }
        }
        Ok(out)
    }
}

impl Mechanics {
    /// ∂v m, ∂v b and ∂²v b at the points (x[k], v[k]); `None` when they have δ terms or a
    /// value that is not finite.
    pub(crate) fn derivatives_batch(&self, x: &[f64], v: &[f64]) -> Option<[Vec<f64>; 3]> {
        let tape = self.derivatives.as_ref()?;
        let mut out = [vec![0.0; x.len()], vec![0.0; x.len()], vec![0.0; x.len()]];
        tape.eval_batch(&[x, v], &mut out, &mut TapeScratch::new());
        out.iter()
            .all(|c| c.iter().all(|d| d.is_finite()))
            .then_some(out)
    }
}

/// The model's barriers as reflecting walls; a law without a side either stops the motion
/// (`v -> 0`) or passes through (the Zhuravlev form): this method solves neither.
fn walls(model: &BoundModel, barriers: &Barriers) -> Result<Vec<Wall>, EpcImpactError> {
    let mut out = Vec::new();
    for barrier in barriers.iter() {
        let printed = format!("{:#}", barrier.law().map());
        let Some(side) = barrier.side() else {
            let law = format!("impact at {}: v -> {printed}", barrier.at());
            let reason = if stops(barrier) {
                Unsupported::Plastic { law }
            } else {
                Unsupported::PassThrough { law }
            };
            return Err(EpcImpactError::Unsupported {
                model: model.name().to_string(),
                reason,
            });
        };
        let wall = Wall {
            side,
            barrier: barrier.clone(),
        };
        check_law(&wall, &printed).map_err(|reason| EpcImpactError::Unsupported {
            model: model.name().to_string(),
            reason,
        })?;
        out.push(wall);
    }
    out.sort_by(|a, b| a.at().total_cmp(&b.at()));
    Ok(out)
}

/// Whether the jump sends every probe velocity (±1e-3 to ±5e3) to zero: a plastic impact.
fn stops(barrier: &Barrier) -> bool {
    (-3..=3).all(|e| {
        [1.0, -1.0, 2.0, -2.0, 5.0, -5.0]
            .iter()
            .all(|f| barrier.jump(f * 10f64.powi(e)) == 0.0)
    })
}

/// A barrier pair must bound a strip: the lower one `Above`, the upper one `Below`.
pub(crate) fn check_strip(barriers: &[Wall]) -> Result<(), Unsupported> {
    if let [a, b] = barriers {
        let ok = a.side == BarrierSide::Above && b.side == BarrierSide::Below && a.at() < b.at();
        if !ok {
            return Err(Unsupported::NotAStrip {
                lower: a.at(),
                upper: b.at(),
            });
        }
    }
    Ok(())
}

/// The law must reflect: every arriving velocity is sent back into the domain, without
/// gaining speed (probes from 1e-3 to 1e3); a law that keeps the sign is the Zhuravlev form.
pub(crate) fn check_law(barrier: &Wall, printed: &str) -> Result<(), Unsupported> {
    let s = barrier.arriving();
    for e in -3..=3 {
        for f in [1.0, 2.0, 5.0] {
            let v = s * f * 10f64.powi(e);
            let w = barrier.map(v);
            if w.is_finite() && w != 0.0 && w.signum() == v.signum() {
                return Err(Unsupported::PassThrough {
                    law: format!("impact at {}: v -> {printed}", barrier.at()),
                });
            }
            if !(w.is_finite() && w.signum() == -v.signum() && w.abs() <= v.abs() * (1.0 + 1e-12)) {
                return Err(Unsupported::ImpactMap {
                    map: printed.to_string(),
                    at: barrier.at(),
                    velocity: v,
                    image: w,
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
impl Wall {
    /// A wall with the law v -> −r·v, for tests of barrier sets no bundled model states.
    pub(crate) fn restitution(at: f64, side: BarrierSide, r: f64) -> Wall {
        Wall {
            side,
            barrier: Barrier::restitution(at, side, r),
        }
    }
}
