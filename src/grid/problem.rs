//! The mechanical form x' = v, v' = m(x, v) + noise that the grid solver discretises, taken
//! from the model's [`Dynamics`]: the Itô drift m of v, the diffusion b = b_vv and ∂b/∂v
//! compiled to one tape, and the barriers on x.

use super::error::{GridError, Unsupported};
use super::BarrierSide;
use crate::dynamics::{
    Barrier, BarrierKind, Barriers, Dynamics, DynamicsError, Form, NotMechanical,
};
use crate::model::BoundModel;
use crate::symbolic::{diff, simplify, DeltaPolicy, Tape};

/// Drift, diffusion and barrier of a mechanical-form model.
#[derive(Clone, Debug)]
pub(crate) struct Mechanical {
    /// Outputs m, b, ∂b/∂v over (x, v). δ terms of the drift are left out: they are the
    /// paper's approximation of the impact that the re-injection represents exactly.
    coefficients: Tape,
    /// None, one, or two reflecting walls bounding a strip (lower first).
    pub(crate) barriers: Vec<Barrier>,
    /// Whether the coefficients depend on the time [`crate::model::TIME`] (the tape's third
    /// variable), and the time they are evaluated at ([`Mechanical::at_time`]).
    time_dependent: bool,
    now: f64,
    /// The position's window when it is periodic ([`crate::model::BoundPeriodic`]).
    pub(crate) window: Option<[f64; 2]>,
    /// The fluxes asked for instead of those the barriers call for
    /// ([`Mechanical::with_midpoint_fluxes`]).
    midpoint: bool,
}

/// Coefficients at a batch of points.
pub(crate) struct Coefficients {
    pub(crate) m: Vec<f64>,
    pub(crate) b: Vec<f64>,
    pub(crate) db: Vec<f64>,
}

/// How the mechanical operator takes its fluxes over a face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Fluxes {
    /// The value at the face's midpoint (second order), and a wall's outflow from the line
    /// through the two cells beside it. Where a wall's law is not elastic the density jumps
    /// at the wall's v = 0, a singular corner whose error falls at order 1.2–1.3 in its
    /// neighbourhood whichever the fluxes. There the averaged fluxes are more accurate per
    /// cell but not per second: the paper's case 1 at 192×384, marginal masses 6.3e−5 /
    /// 6.4e−5 (z / v) against 9.1e−5 / 6.9e−5 from a 768×1536 solve of each scheme, took
    /// 0.77 s against 0.28 s with the estimate's partners (the corner's couplings fill the
    /// factor), and the midpoint fluxes on 256×512 (5.4e−5 / 3.9e−5) cost less than that.
    /// A first passage takes these too ([`Mechanical::with_midpoint_fluxes`]).
    Midpoint,
    /// Each flux averaged over its face to third order ([`super::assemble`]): the cell
    /// masses converge at order 3 on every exact case.
    Averaged,
}

impl Mechanical {
    /// The fluxes of this problem's operator: averaged where the density is smooth up to
    /// its walls (none, elastic walls, a pass-through barrier with no jump), at the
    /// midpoints where a wall's law makes a singular corner.
    pub(crate) fn fluxes(&self) -> Fluxes {
        if !self.midpoint && self.barriers.iter().all(smooth) {
            Fluxes::Averaged
        } else {
            Fluxes::Midpoint
        }
    }

    /// Reads the mechanical form of `model`, or says why it has none.
    pub(crate) fn new(dynamics: &Dynamics) -> Result<Self, GridError> {
        let model = dynamics.model();
        let barriers = dynamics.barriers().map_err(|e| jump_map_error(model, e))?;
        Mechanical::with_barriers(model, dynamics, barriers)
    }

    /// [`Mechanical::new`] for a transient: a model whose drift or diffusion mentions the
    /// time is accepted (evaluated at t = 0 until [`Mechanical::at_time`]), and the checks
    /// that only a stationary density needs are skipped for it; the mechanical form, the
    /// barriers and the δ terms are checked as for any model.
    pub(crate) fn transient(dynamics: &Dynamics) -> Result<Self, GridError> {
        let model = dynamics.model();
        let barriers = dynamics.barriers().map_err(|e| jump_map_error(model, e))?;
        Mechanical::build(model, dynamics, barriers, !model.time_dependent())
    }

    /// [`Mechanical::new`] for a first passage: none of the checks that only a stationary
    /// density needs (the first-passage solver decides which of their reasons it accepts);
    /// the mechanical form, the barriers and the δ terms are checked as for any model.
    pub(crate) fn first_passage(dynamics: &Dynamics) -> Result<Self, GridError> {
        let model = dynamics.model();
        let barriers = dynamics.barriers().map_err(|e| jump_map_error(model, e))?;
        Mechanical::build(model, dynamics, barriers, false)
    }

    /// The problem, or [`Unsupported::PeriodicProblem`] for `what` (a first passage, a
    /// transient) when its position is periodic: those solvers do not wrap the cells yet.
    pub(crate) fn not_periodic(
        self,
        model: &BoundModel,
        what: &'static str,
    ) -> Result<Self, GridError> {
        match self.window {
            None => Ok(self),
            Some(_) => Err(GridError::Unsupported {
                model: model.name().to_string(),
                reason: Unsupported::PeriodicProblem { what },
            }),
        }
    }

    /// Whether the coefficients depend on the time.
    pub(crate) fn time_dependent(&self) -> bool {
        self.time_dependent
    }

    /// The same problem with the midpoint fluxes whatever its barriers. For a first passage,
    /// whose absorbing boundary makes a corner where the outflow meets v = 0 as an inelastic
    /// wall does: with averaged fluxes the mean times of the linear oscillator (c = 1,
    /// |z| < 1.2) converged unevenly from 30×40 to 60×80 to 240×320, and E[T²] at 60×80 was
    /// 2.92 from the 240×320 value where its half-cells estimate said 2.64.(A transient keeps the stationary solver's fluxes,
    /// so that its long-time limit is that solver's density.)
    pub(crate) fn with_midpoint_fluxes(self) -> Mechanical {
        Mechanical {
            midpoint: true,
            ..self
        }
    }

    /// The same problem with its coefficients evaluated at time `t` (a no-op for a
    /// time-invariant one).
    pub(crate) fn at_time(&self, t: f64) -> Mechanical {
        Mechanical {
            now: t,
            ..self.clone()
        }
    }

    /// [`Mechanical::new`] with the barriers `barriers` in place of the model's own.
    pub(crate) fn with_barriers(
        model: &BoundModel,
        dynamics: &Dynamics,
        barriers: &Barriers,
    ) -> Result<Self, GridError> {
        Mechanical::build(model, dynamics, barriers, true)
    }

    /// The problem; `admit` runs the stationary admissibility checks.
    fn build(
        model: &BoundModel,
        dynamics: &Dynamics,
        barriers: &Barriers,
        admit: bool,
    ) -> Result<Self, GridError> {
        let states = dynamics.states();
        let (x, v) = (states[0].to_string(), states[1].to_string());
        let refuse = |reason| GridError::Unsupported {
            model: model.name().to_string(),
            reason,
        };
        if let Form::General { why } = dynamics.form() {
            return Err(refuse(match why.clone() {
                NotMechanical::Rate {
                    position,
                    velocity,
                    rate,
                } => Unsupported::NotMechanical {
                    position,
                    velocity,
                    rate,
                },
                NotMechanical::NoiseInPosition { position, noise } => {
                    Unsupported::NoiseInPosition { position, noise }
                }
            }));
        }
        if admit {
            dynamics.admissible()?;
        }
        let window = periodic_window(model)?;
        let sde = dynamics.sde();
        // δ terms are dropped below only because an impact law stands for them exactly.
        if barriers.is_empty() && sde.drift()[1].contains_delta() {
            return Err(refuse(Unsupported::DeltaWithoutImpact {
                velocity: v,
                coefficient: "drift",
            }));
        }
        if sde.noise_matrix()[1].iter().any(|g| g.contains_delta()) {
            return Err(refuse(Unsupported::DeltaInDiffusion { velocity: v }));
        }
        let ito = dynamics.ito_drift().map_err(crate::fpk::FpkError::from)?;
        let m = simplify(&ito[1].without_deltas());
        // No δ in the diffusion (refused above), so b is the dynamics' entry as it stands.
        let b = dynamics.diffusion()[1][1].clone();
        let db = diff(&b, &v).map_err(|source| GridError::Symbolic {
            what: format!("d b_{v}{v} / d{v}"),
            source,
        })?;
        let time_dependent = model.time_dependent();
        let vars = [x.as_str(), v.as_str(), crate::model::TIME];
        let vars = &vars[..if time_dependent { 3 } else { 2 }];
        let coefficients = Tape::compile(&[m, b, db.without_deltas()], vars, DeltaPolicy::Zero)
            .map_err(|source| GridError::Symbolic {
                what: format!("the drift and diffusion of `{v}`"),
                source,
            })?;
        let mut walls = Vec::with_capacity(barriers.len());
        for barrier in barriers.iter() {
            if barrier.state != 0 || barrier.other != 1 {
                return Err(refuse(Unsupported::ImpactNotOnPosition {
                    position: x,
                    velocity: v,
                }));
            }
            let refused = || {
                refuse(Unsupported::ImpactMap {
                    map: format!("{:#}", barrier.law().map()),
                })
            };
            // This solver's own acceptance of a jump (monotone, no gain); the side of a
            // reflecting law is the model's (its `domain` line): a map this solver reads as
            // reflecting where the model did not is refused.
            let reflects = classify(barrier).ok_or_else(refused)?;
            if reflects && barrier.side().is_none() {
                return Err(refused());
            }
            walls.push(barrier.clone());
        }
        let mut barriers = walls;
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
            window,
            time_dependent,
            now: 0.0,
            midpoint: false,
        })
    }

    /// The tape's outputs at the points, at the time [`Mechanical::at_time`] set.
    fn eval_all(&self, x: &[f64], v: &[f64]) -> Vec<Vec<f64>> {
        let mut out = vec![vec![0.0; x.len()]; 3];
        let mut scratch = crate::symbolic::TapeScratch::new();
        if self.time_dependent {
            let t = vec![self.now; x.len()];
            self.coefficients
                .eval_batch(&[x, v, &t], &mut out, &mut scratch);
        } else {
            self.coefficients
                .eval_batch(&[x, v], &mut out, &mut scratch);
        }
        out
    }

    /// m, b and ∂b/∂v at the points (x[p], v[p]).
    pub(crate) fn eval(&self, x: &[f64], v: &[f64]) -> Result<Coefficients, GridError> {
        let mut out = self.eval_all(x, v);
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

    /// m, b and ∂b/∂v at the points (x[p], v[p]), NaN and infinite values included (for the
    /// pilot, which drops the trajectories that reach them).
    pub(crate) fn eval_raw(&self, x: &[f64], v: &[f64]) -> Coefficients {
        let mut out = self.eval_all(x, v);
        let db = out.pop().unwrap_or_default();
        let b = out.pop().unwrap_or_default();
        let m = out.pop().unwrap_or_default();
        Coefficients { m, b, db }
    }

    /// Whether the problem is unchanged by (x, v) → (−x, −v) on the box |x| ≤ `x`, |v| ≤ `v`:
    /// m odd and b even there (compared on a lattice of points, to rounding), and the
    /// barriers mirror images of each other with odd jump laws (none; one pass-through
    /// barrier at 0; a strip [−a, a]). Its stationary density is then point-symmetric, and a
    /// box symmetric about the origin keeps the discrete solution so (mean 0 to rounding).
    pub(crate) fn point_symmetric(&self, [x, v]: [f64; 2]) -> bool {
        if !(x > 0.0 && v > 0.0 && x.is_finite() && v.is_finite()) {
            return false;
        }
        let odd_law = |b: &Barrier, mirror: &Barrier| {
            [1e-3, 0.1, 0.7, 1.0, 3.0, 10.0, 1e3].iter().all(|&s| {
                let w = s * v.max(1.0);
                let (a, c) = (b.jump(w), mirror.jump(-w));
                (a + c).abs() <= 1e-12 * (a.abs() + c.abs()) + 1e-300
            })
        };
        let tiny = 1e-12 * x;
        let barriers_ok = match self.barriers.as_slice() {
            [] => true,
            [b] => b.kind == BarrierKind::PassThrough && b.at.abs() <= tiny && odd_law(b, b),
            [lo, hi] => (lo.at + hi.at).abs() <= tiny && odd_law(lo, hi) && odd_law(hi, lo),
            _ => false,
        };
        if !barriers_ok {
            return false;
        }
        // A lattice off the axes (offsets that put no point on an axis, where |x| and sgn have their kinks), and
        // its mirror image.
        const N: usize = 13;
        let mut px = Vec::with_capacity(2 * N * N);
        let mut pv = Vec::with_capacity(2 * N * N);
        for i in 0..N {
            for j in 0..N {
                let a = x * ((i as f64 + 0.271_828_18) / N as f64 * 2.0 - 1.0);
                let c = v * ((j as f64 + 0.577_215_665) / N as f64 * 2.0 - 1.0);
                px.push(a);
                pv.push(c);
            }
        }
        let n = px.len();
        for k in 0..n {
            px.push(-px[k]);
            pv.push(-pv[k]);
        }
        let c = self.eval_raw(&px, &pv);
        let scale = |col: &[f64]| col.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let (ms, bs) = (scale(&c.m), scale(&c.b));
        if !(ms.is_finite() && bs.is_finite()) {
            return false;
        }
        let close =
            |a: f64, b: f64, s: f64| (a - b).abs() <= 1e-12 * (a.abs() + b.abs()) + 1e-14 * s;
        (0..n).all(|k| close(c.m[k], -c.m[n + k], ms) && close(c.b[k], c.b[n + k], bs))
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

/// Whether the jump reverses (`true`) or keeps (`false`) the sign of the velocity,
/// monotonically and without adding speed, on probes from 1e-3 to 5e3; `None` when neither.
fn classify(barrier: &Barrier) -> Option<bool> {
    let mut sign = 0.0;
    let mut last = [0.0f64; 2];
    for e in -3..=3 {
        for f in [1.0, 2.0, 5.0] {
            let v = f * 10f64.powi(e);
            for (s, vv) in [v, -v].into_iter().enumerate() {
                let w = barrier.jump(vv);
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
    Some(sign < 0.0)
}

/// The window of the model's periodic state, which the grid takes only as the first state
/// (its x axis); `None` without one.
pub(crate) fn periodic_window(model: &BoundModel) -> Result<Option<[f64; 2]>, GridError> {
    match model.periodic() {
        None => Ok(None),
        Some(p) if p.state == 0 => Ok(Some(p.window())),
        Some(p) => Err(GridError::Unsupported {
            model: model.name().to_string(),
            reason: Unsupported::PeriodicSecondState {
                state: model.states()[p.state].to_string(),
            },
        }),
    }
}

/// A jump map that does not compile, as the grid solver reports it.
pub(super) fn jump_map_error(model: &BoundModel, e: DynamicsError) -> GridError {
    match e {
        DynamicsError::JumpMap { source } => GridError::Symbolic {
            what: "the jump map".into(),
            source,
        },
        DynamicsError::TooManyBarriers { count } => GridError::Unsupported {
            model: model.name().to_string(),
            reason: Unsupported::NotAStrip {
                count,
                at: model.impacts().iter().map(|l| l.at).collect(),
            },
        },
    }
}

/// Whether `barrier` leaves the density smooth: a wall whose law is v → −v (elastic), or a
/// pass-through barrier whose law is v → v (no impact: the Zhuravlev form with r = 1),
/// checked at velocities across the range a density reaches, to rounding.
fn smooth(barrier: &Barrier) -> bool {
    let sign = match barrier.kind() {
        crate::dynamics::BarrierKind::Reflecting(_) => -1.0,
        crate::dynamics::BarrierKind::PassThrough => 1.0,
    };
    [-20.0, -3.0, -0.5, 0.25, 1.0, 7.0, 30.0]
        .iter()
        .all(|&v: &f64| (barrier.jump(v) - sign * v).abs() <= 1e-12 * v.abs())
}
