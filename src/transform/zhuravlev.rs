//! The Zhuravlev transformation of a one-sided vibro-impact oscillator (paper, Eqs. 5–10).
//!
//! For a mechanical model (y' = ẏ, noise in the equation of ẏ only), ÿ = f(y, ẏ) + Σ g_k ξ_k,
//! with one reflecting barrier y = y_b, the state on side s (+1 above, −1 below) and the law
//! ẏ⁺ = −r·ẏ⁻, the new coordinates
//!
//! y = y_b + s·|z|,  ẏ = s·v·sgn z                                    (Eq. 5)
//!
//! give z' = v and, away from z = 0, v' = s·sgn(z)·ÿ: the drift of v is s·sgn(z)·f and every
//! noise coefficient is s·sgn(z)·g_k, both at (y_b + s|z|, s·v·sgn z). The barrier becomes
//! the line z = 0 crossed with v⁺ = r·v⁻ (Eq. 6), and the velocity lost there is the
//! impulsive damping −(1 − r)·v·|v|·δ(z) in the drift of v (Eqs. 7–9). The change of
//! variables is linear in the velocity at fixed z, so it adds no Itô term: the interpretation
//! is kept. The transformed model is simplified with identities that hold everywhere
//! (sgn(z)·|z| = z, sgn(z)·|z|³ = z³) and with sgn(z)² = 1, which fails only on the line
//! z = 0, of measure zero for the density and never sat on by a trajectory.

use crate::model::{number, BarrierSide, BoundImpact, BoundModel, ImpactLaw, Model, Observable};
use crate::symbolic::{diff, expand, simplify, Expr, Func, Symbol};

/// Why a model has no Zhuravlev transform.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// let err = fpsolve::transform::zhuravlev(&model).unwrap_err();
/// assert!(matches!(err, fpsolve::transform::ZhuravlevError::NotReflecting { .. }));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ZhuravlevError {
    /// The model has no impact law.
    #[error("the model has no impact law")]
    NoImpact,
    /// Two barriers bound a strip; the transformation folds one barrier only.
    #[error("the model has two barriers (a strip); the Zhuravlev transformation folds one")]
    TwoBarriers,
    /// The law does not keep the state on one side (no `domain` line, or a pass-through
    /// law `v -> r*v`, already the Zhuravlev form).
    #[error(
        "the impact law `{law}` is not a reflecting barrier with a `domain` side (a \
         pass-through law is already the Zhuravlev form)"
    )]
    NotReflecting {
        /// The law, printed.
        law: String,
    },
    /// The rate of the barrier state is not the jumping state.
    #[error("the drift of `{position}` is `{rate}`, not `{velocity}` (mechanical form y' = ẏ)")]
    NotMechanical {
        /// The barrier state.
        position: String,
        /// The jumping state.
        velocity: String,
        /// The drift of the barrier state, printed.
        rate: String,
    },
    /// Noise enters the equation of the barrier state.
    #[error("noise enters the equation of `{position}`; only the velocity may be excited")]
    NoiseInPosition {
        /// The barrier state.
        position: String,
    },
    /// The jump is not `-r*v` with r a constant.
    #[error("the jump `{map}` is not `-r*{velocity}` with a constant r")]
    NotLinear {
        /// The map, printed.
        map: String,
        /// The jumping state.
        velocity: String,
    },
    /// The model already has δ terms (an original-coordinates model has none: the impact
    /// line is the impact).
    #[error("{what} already contains delta(...): the model is not in its original coordinates")]
    DeltaInModel {
        /// Which expression.
        what: String,
    },
}

/// A model in its original coordinates and its Zhuravlev transform.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_impact_duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// let z = fpsolve::transform::zhuravlev(&model).unwrap();
/// assert_eq!((z.position.as_ref(), z.velocity.as_ref()), ("z", "v"));
/// assert_eq!(z.side, fpsolve::model::BarrierSide::Above);
/// assert_eq!(z.model.observables()[0].expr.to_string(), "abs(z)");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Zhuravlev<M> {
    /// The transformed model: states z, v; the original states and observables as
    /// observables of the same names.
    pub model: M,
    /// The name of the new position z (`z` unless the model uses it, then `z_`, `z__`, …).
    pub position: Symbol,
    /// The name of the new velocity v (`v` unless taken, then `v_`, …).
    pub velocity: Symbol,
    /// The side of the barrier the original state lives on.
    pub side: BarrierSide,
    /// The restitution coefficient r of the law, as an expression of the parameters.
    pub restitution: Expr,
}

/// The pieces of a model the transformation reads and writes (a [`Model`]'s or a
/// [`BoundModel`]'s, parameters symbolic or numbers).
struct Pieces {
    states: [Symbol; 2],
    drift: [Expr; 2],
    noise_matrix: [Vec<Expr>; 2],
    law: ImpactLaw,
    side: BarrierSide,
    observables: Vec<Observable>,
    /// Every name the model uses (parameters, noises, states, observables).
    taken: Vec<String>,
}

/// What the transformation gives.
struct Transformed {
    states: [Symbol; 2],
    drift: [Expr; 2],
    noise_matrix: [Vec<Expr>; 2],
    impact: ImpactLaw,
    observables: Vec<Observable>,
    restitution: Expr,
}

/// A name not in `taken`: `base`, else `base_`, `base__`, ….
fn free_name(base: &str, taken: &[String]) -> Symbol {
    let mut name = base.to_string();
    while taken.contains(&name) {
        name.push('_');
    }
    Symbol::from(name.as_str())
}

/// The readable canonical form: products over sums multiplied out, then the simplifier's
/// identities (sgn(z)·|z| = z, sgn(z)² = 1, ...).
fn tidy(e: &Expr) -> Expr {
    simplify(&expand(e))
}

fn is_zero(e: &Expr) -> bool {
    simplify(e).as_num() == Some(0.0)
}

fn derive(p: Pieces) -> Result<Transformed, ZhuravlevError> {
    let (i, j) = (p.law.state, p.law.other);
    let (y, w) = (p.states[i].clone(), p.states[j].clone());
    if simplify(&p.drift[i]) != Expr::Sym(w.clone()) {
        return Err(ZhuravlevError::NotMechanical {
            position: y.to_string(),
            velocity: w.to_string(),
            rate: format!("{:#}", p.drift[i]),
        });
    }
    if !p.noise_matrix[i].iter().all(is_zero) {
        return Err(ZhuravlevError::NoiseInPosition {
            position: y.to_string(),
        });
    }
    if p.drift[j].contains_delta() {
        return Err(ZhuravlevError::DeltaInModel {
            what: format!("the drift of `{w}`"),
        });
    }
    if p.noise_matrix[j].iter().any(Expr::contains_delta) {
        return Err(ZhuravlevError::DeltaInModel {
            what: format!("the diffusion of `{w}`"),
        });
    }
    // r from the map -r*w: r = -d(map)/dw, constant in both states, and map = -r*w exactly.
    let not_linear = || ZhuravlevError::NotLinear {
        map: format!("{:#}", p.law.map),
        velocity: w.to_string(),
    };
    let slope = diff(&p.law.map, &w).map_err(|_| not_linear())?;
    let r = simplify(&-slope);
    let constant = !r.mentions(&y) && !r.mentions(&w) && !r.contains_delta();
    if !constant
        || !is_zero(&expand(
            &(p.law.map.clone() + r.clone() * Expr::Sym(w.clone())),
        ))
    {
        return Err(not_linear());
    }

    let z = free_name("z", &p.taken);
    let v = free_name("v", &p.taken);
    let (ze, ve) = (Expr::Sym(z.clone()), Expr::Sym(v.clone()));
    let s = Expr::num(p.side.sign());
    let sgn_z = Expr::call(Func::Sgn, ze.clone());
    let y_of = tidy(&(p.law.at.clone() + s.clone() * Expr::call(Func::Abs, ze.clone())));
    let w_of = tidy(&(s.clone() * ve.clone() * sgn_z.clone()));
    let original = |e: &Expr| {
        e.map_symbols(&|sym| {
            if *sym == y {
                Some(y_of.clone())
            } else if *sym == w {
                Some(w_of.clone())
            } else {
                None
            }
        })
    };
    let factor = s * sgn_z;
    let folded = |e: &Expr| tidy(&(factor.clone() * original(e)));
    // Eq. 8: the velocity lost at each crossing, -(1 - r) v |v| δ(z), written as the paper
    // writes it (the simplifier would expand (1 - r)).
    let impact_term = -Expr::product(vec![
        Expr::num(1.0) - r.clone(),
        ve.clone(),
        Expr::call(Func::Abs, ve.clone()),
        Expr::call(Func::Delta, ze.clone()),
    ]);
    let drift_v = Expr::sum(vec![folded(&p.drift[j]), impact_term]);
    let noise_v: Vec<Expr> = p.noise_matrix[j].iter().map(folded).collect();
    let mut observables = vec![
        Observable {
            name: y.clone(),
            expr: y_of.clone(),
        },
        Observable {
            name: w.clone(),
            expr: w_of.clone(),
        },
    ];
    observables.extend(p.observables.iter().map(|o| Observable {
        name: o.name.clone(),
        expr: tidy(&original(&o.expr)),
    }));
    Ok(Transformed {
        states: [z, v.clone()],
        drift: [ve.clone(), drift_v],
        noise_matrix: [vec![Expr::num(0.0); noise_v.len()], noise_v],
        impact: ImpactLaw {
            state: 0,
            at: Expr::num(0.0),
            other: 1,
            map: r.clone() * ve,
        },
        observables,
        restitution: r,
    })
}

/// The one impact law of a model, or why there is not one.
fn the_law<L>(laws: &[L]) -> Result<&L, ZhuravlevError> {
    match laws {
        [] => Err(ZhuravlevError::NoImpact),
        [law] => Ok(law),
        _ => Err(ZhuravlevError::TwoBarriers),
    }
}

/// The Zhuravlev transform of a model with one reflecting barrier and its `domain` side,
/// parameters kept symbolic (so that it prints as a model file and binds like the original).
///
/// # Errors
/// A [`ZhuravlevError`] saying why the model has no such transform.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_impact_duffing.sde");
/// let model = fpsolve::model::load_model(&path)?;
/// let z = fpsolve::transform::zhuravlev(&model)?;
/// let text = z.model.to_string();
/// assert!(text.contains("impact z = 0: v -> r*v"));
/// assert!(text.contains("observe y = abs(z), ydot = v*sgn(z)"));
/// // The printed transform is a model file, which reads back to the same equations.
/// let read = fpsolve::model::parse_model(&text, None)?;
/// assert_eq!((read.drift(), read.noise_matrix()), (z.model.drift(), z.model.noise_matrix()));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn zhuravlev(model: &Model) -> Result<Zhuravlev<Model>, ZhuravlevError> {
    let states = model.states();
    let law = the_law(model.impacts())?;
    let side = match model.domain() {
        Some(d) if d.state == law.state && d.upper.is_none() => BarrierSide::Above,
        Some(d) if d.state == law.state && d.lower.is_none() => BarrierSide::Below,
        _ => {
            return Err(ZhuravlevError::NotReflecting {
                law: format!(
                    "impact {} = {}: {} -> {}",
                    states[law.state], law.at, states[law.other], law.map
                ),
            })
        }
    };
    let mut taken: Vec<String> = states.iter().map(|s| s.to_string()).collect();
    taken.extend(model.params().iter().map(|p| p.name.to_string()));
    taken.extend(model.noises().iter().map(|n| n.name.to_string()));
    taken.extend(model.observables().iter().map(|o| o.name.to_string()));
    let t = derive(Pieces {
        states: states.clone(),
        drift: model.drift().clone(),
        noise_matrix: model.noise_matrix().clone(),
        law: law.clone(),
        side,
        observables: model.observables().to_vec(),
        taken,
    })?;
    let transformed = Model {
        name: format!("{}_zhuravlev", model.name()),
        description: transformed_description(model.description()),
        params: model.params().to_vec(),
        states: t.states.clone(),
        drift: t.drift,
        noises: model.noises().to_vec(),
        correlations: model.correlations().to_vec(),
        noise_matrix: t.noise_matrix,
        interpretation: model.interpretation(),
        impacts: vec![t.impact],
        domain: None,
        observables: t.observables,
        delta: model.delta_treatment(),
        // A safe set and an initial state are written in the original states; first
        // passage and transients are solved there.
        safe: None,
        initial: None,
        periodic: None,
        origin: None,
    };
    Ok(Zhuravlev {
        model: transformed,
        position: t.states[0].clone(),
        velocity: t.states[1].clone(),
        side,
        restitution: t.restitution,
    })
}

/// The Zhuravlev transform of a bound model with one reflecting barrier (its side from the
/// `domain` line): what the δ-term EPC solves for an original-coordinates model. Equal to
/// binding the transform of the unbound model with the same parameter values.
///
/// # Errors
/// A [`ZhuravlevError`] saying why the model has no such transform.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_impact_duffing.sde");
/// let bound = fpsolve::model::load_model(&path)?.bind(&[])?;
/// let z = fpsolve::transform::zhuravlev_bound(&bound)?;
/// assert_eq!(z.model.impacts()[0].map.to_string(), "0.95*v");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn zhuravlev_bound(model: &BoundModel) -> Result<Zhuravlev<BoundModel>, ZhuravlevError> {
    let states = model.states();
    let law = the_law(model.impacts())?;
    let Some(side) = law.side else {
        return Err(ZhuravlevError::NotReflecting {
            law: format!(
                "impact {} = {}: {} -> {:#}",
                states[law.state],
                number(law.at),
                states[law.other],
                law.map
            ),
        });
    };
    let mut taken: Vec<String> = states.iter().map(|s| s.to_string()).collect();
    taken.extend(model.params().iter().map(|p| p.0.to_string()));
    taken.extend(model.noise_names().iter().map(|n| n.to_string()));
    taken.extend(model.observables().iter().map(|o| o.name.to_string()));
    let t = derive(Pieces {
        states: states.clone(),
        drift: model.drift().clone(),
        noise_matrix: model.noise_matrix().clone(),
        law: ImpactLaw {
            state: law.state,
            at: Expr::num(law.at),
            other: law.other,
            map: law.map.clone(),
        },
        side,
        observables: model.observables().to_vec(),
        taken,
    })?;
    let restitution = t.restitution.clone();
    let transformed = BoundModel {
        name: format!("{}_zhuravlev", model.name()),
        params: model.params().to_vec(),
        states: t.states.clone(),
        drift: t.drift,
        noise_names: model.noise_names().to_vec(),
        intensity: model.intensity().to_vec(),
        noise_matrix: t.noise_matrix,
        interpretation: model.interpretation(),
        impacts: vec![BoundImpact {
            state: 0,
            at: 0.0,
            other: 1,
            map: t.impact.map,
            side: None,
        }],
        observables: t.observables,
        delta: model.delta_treatment(),
        periodic: None,
        origin: None,
    };
    Ok(Zhuravlev {
        model: transformed,
        position: t.states[0].clone(),
        velocity: t.states[1].clone(),
        side,
        restitution,
    })
}

fn transformed_description(original: &str) -> String {
    if original.is_empty() {
        "Zhuravlev transform by fpsolve".to_string()
    } else {
        format!("{original}, Zhuravlev transform by fpsolve")
    }
}
