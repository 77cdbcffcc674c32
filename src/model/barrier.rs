//! Barriers: which side of a reflecting barrier the state lives on (the `domain` line), and
//! binding the impact laws to numbers with the rules that make their domain unambiguous.
//!
//! A law that reverses the velocity's sign (`v -> -r*v`) keeps the state on one side of its
//! barrier (the model in its original coordinates); that side is said by a `domain` line, or,
//! for two barriers on one state, is the strip between them. A law that keeps the sign
//! (`v -> r*v`, the Zhuravlev form) lets the state pass through: it has no side. Which of the
//! two a law is can depend on parameters (`v -> r*v` with `r` set negative), so it is decided
//! when the model is bound, from the signs of the bound map at probe velocities.

use serde::Serialize;

use super::bind_error::BindError;
use super::{number, Model};
use crate::symbolic::{DeltaPolicy, Expr, Symbol};

/// Which side of a reflecting barrier the state lives on.
///
/// ```
/// use fpsolve::model::BarrierSide;
/// assert_eq!(BarrierSide::Above.sign(), 1.0);
/// assert_eq!(BarrierSide::Below.sign(), -1.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum BarrierSide {
    /// The state exceeds the barrier (a lower bound, the paper's y > 0).
    Above,
    /// The state stays below the barrier (an upper bound).
    Below,
}

impl BarrierSide {
    /// +1 above, −1 below: the `s` of y = y_b + s·|z|.
    ///
    /// ```
    /// assert_eq!(fpsolve::model::BarrierSide::Below.sign(), -1.0);
    /// ```
    pub fn sign(self) -> f64 {
        match self {
            BarrierSide::Above => 1.0,
            BarrierSide::Below => -1.0,
        }
    }
}

/// An impact law with its barrier at a number.
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/vibro_duffing.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// let bound = model.bind(&[]).unwrap();
/// assert_eq!(bound.impacts()[0].map.to_string(), "0.95*v");
/// assert_eq!(bound.impacts()[0].side, None);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct BoundImpact {
    /// Index of the state that meets the barrier.
    pub state: usize,
    /// The barrier's position.
    pub at: f64,
    /// Index of the state that jumps.
    pub other: usize,
    /// The post-impact value of `other`, an expression of the states only.
    pub map: Expr,
    /// The side of the barrier the state lives on, for a law that reverses the velocity
    /// (`v -> -r*v`, from the `domain` line or the strip of two barriers); `None` for a law
    /// the state passes through (`v -> r*v`, the Zhuravlev form).
    pub side: Option<BarrierSide>,
}

/// One bound of a [`Domain`]: an expression of parameters, and whether it was written `<`/`>`
/// rather than `<=`/`>=` (the same density; kept so the model prints back as written).
///
/// ```
/// let text = "model m\nparam c = 0.1\nstate y, v\ndrift y: v\ndrift v: -c*v - y\n\
///             noise xi: intensity 1\ndiffusion v: xi\nimpact y = 0: v -> -0.9*v\n\
///             domain y > 0\n";
/// let model = fpsolve::model::parse_model(text, None).unwrap();
/// let lower = model.domain().unwrap().lower.as_ref().unwrap();
/// assert!(lower.strict);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct DomainBound {
    /// Where the bound is.
    pub at: Expr,
    /// Written `<` or `>`.
    pub strict: bool,
}

/// The `domain` line: the interval of one state the motion is confined to by reflecting
/// barriers (`domain y >= 0`, `domain y <= b`, `domain a <= y <= b`).
///
/// ```
/// let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
///     .join("tests/models/grid_impact_linear.sde");
/// let model = fpsolve::model::load_model(&path).unwrap();
/// let domain = model.domain().unwrap();
/// assert_eq!(domain.state, 0);
/// assert!(domain.upper.is_none());
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Domain {
    /// Index of the confined state.
    pub state: usize,
    /// The lower bound (the state lives above it), if any.
    pub lower: Option<DomainBound>,
    /// The upper bound (the state lives below it), if any.
    pub upper: Option<DomainBound>,
}

impl Domain {
    /// `state >= at`: the state lives above a barrier at `at`.
    ///
    /// ```
    /// use fpsolve::model::Domain;
    /// let d = Domain::above(0, fpsolve::symbolic::Expr::num(0.0));
    /// assert!(d.upper.is_none() && !d.lower.unwrap().strict);
    /// ```
    pub fn above(state: usize, at: Expr) -> Domain {
        Domain {
            state,
            lower: Some(DomainBound { at, strict: false }),
            upper: None,
        }
    }

    /// `state <= at`: the state lives below a barrier at `at`.
    ///
    /// ```
    /// use fpsolve::model::Domain;
    /// let d = Domain::below(1, fpsolve::symbolic::Expr::num(2.0));
    /// assert!(d.lower.is_none() && d.state == 1);
    /// ```
    pub fn below(state: usize, at: Expr) -> Domain {
        Domain {
            state,
            lower: None,
            upper: Some(DomainBound { at, strict: false }),
        }
    }

    /// The domain as a model file writes it, without the keyword (`y >= 0`, `-d <= y <= d`).
    pub(crate) fn text(&self, states: &[Symbol; 2]) -> String {
        let s = &states[self.state];
        let op = |b: &DomainBound, lower: bool| match (lower, b.strict) {
            (true, false) => ">=",
            (true, true) => ">",
            (false, false) => "<=",
            (false, true) => "<",
        };
        match (&self.lower, &self.upper) {
            (Some(lo), Some(hi)) => format!(
                "{} {} {s} {} {}",
                lo.at,
                if lo.strict { "<" } else { "<=" },
                op(hi, false),
                hi.at
            ),
            (Some(lo), None) => format!("{s} {} {}", op(lo, true), lo.at),
            (None, Some(hi)) => format!("{s} {} {}", op(hi, false), hi.at),
            (None, None) => s.to_string(),
        }
    }
}

/// What a bound jump map does to the velocity's sign at the probe velocities.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Jump {
    /// Reverses it at every probe (`v -> -r*v`, r > 0): a reflecting barrier.
    Reflecting,
    /// Keeps it at every probe (`v -> r*v`, r > 0): the state passes through.
    PassThrough,
    /// Stops it at every probe (`v -> 0*v`): a plastic impact, r = 0.
    Plastic,
    /// Neither (a sign that depends on the velocity).
    Neither,
}

/// Probe velocities for the sign of a jump map: both signs, small to moderate speeds (the
/// speeds at which a barrier is met).
const SIGN_PROBES: [f64; 7] = [1e-3, 0.01, 0.1, 0.5, 1.0, 1.7, 3.0];

/// What the bound map of `law` does to the sign of the jumping state.
fn jump(law: &BoundImpact, states: &[Symbol; 2]) -> Jump {
    let mut signs = SIGN_PROBES.iter().flat_map(|&m| [m, -m]).map(|v| {
        let mut x = [0.0; 2];
        x[law.state] = law.at;
        x[law.other] = v;
        let after = law
            .map
            .eval_states(states, x, DeltaPolicy::Zero)
            .unwrap_or(f64::NAN);
        after * v
    });
    let first = signs.next().unwrap_or(f64::NAN);
    if first == 0.0 && signs.clone().all(|p| p == 0.0) {
        return Jump::Plastic;
    }
    let all = |neg: bool| {
        let ok = |p: f64| if neg { p < 0.0 } else { p > 0.0 };
        ok(first) && signs.clone().all(ok)
    };
    if all(true) {
        Jump::Reflecting
    } else if all(false) {
        Jump::PassThrough
    } else {
        Jump::Neither
    }
}

/// A domain bound and a barrier position are the same place: equal to rounding (a bound
/// `0.3` and a barrier `0.1 + 0.2` are one wall).
fn same_place(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1.0)
}

/// Which bound of the `domain` line an error is about (for locating it in the file).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum DomainPart {
    /// The whole line.
    Line,
    /// The lower bound.
    Lower,
    /// The upper bound.
    Upper,
}

/// The errors of this module, with what the model file's locator needs.
pub(crate) enum Placed {
    /// At the barrier of impact law `i`.
    Impact(usize, BindError),
    /// At a part of the `domain` line.
    Domain(DomainPart, BindError),
}

/// Binds the impact laws and gives each reflecting law its side: from the `domain` line for
/// one barrier, the strip between them for two. `value` evaluates an expression of
/// parameters, `subst` substitutes their values.
pub(crate) fn bind_impacts(
    model: &Model,
    value: &dyn Fn(&Expr) -> f64,
    subst: &dyn Fn(&Expr) -> Expr,
) -> Result<Vec<BoundImpact>, Placed> {
    let states = &model.states;
    let mut laws = Vec::with_capacity(model.impacts.len());
    for (i, law) in model.impacts.iter().enumerate() {
        let at = value(&law.at);
        if !at.is_finite() {
            return Err(Placed::Impact(i, BindError::BadBarrier { value: at }));
        }
        laws.push(BoundImpact {
            state: law.state,
            at,
            other: law.other,
            map: subst(&law.map),
            side: None,
        });
    }
    let kinds: Vec<Jump> = laws.iter().map(|l| jump(l, states)).collect();
    // Every law is on the same state (checked when the model was read).
    let state = model
        .impacts
        .first()
        .map(|l| states[l.state].to_string())
        .unwrap_or_default();
    let bound = |b: &Option<DomainBound>| -> Result<Option<f64>, BindError> {
        let Some(b) = b else { return Ok(None) };
        let v = value(&b.at);
        if v.is_finite() {
            Ok(Some(v))
        } else {
            Err(BindError::BadBarrier { value: v })
        }
    };
    let domain = match &model.domain {
        None => None,
        Some(d) => Some((
            bound(&d.lower).map_err(|e| Placed::Domain(DomainPart::Lower, e))?,
            bound(&d.upper).map_err(|e| Placed::Domain(DomainPart::Upper, e))?,
        )),
    };
    match laws.len() {
        0 => {}
        1 => {
            let at = laws[0].at;
            match (kinds[0], domain) {
                (Jump::Reflecting, None) => {
                    let op = if at <= 0.0 { ">=" } else { "<=" };
                    return Err(Placed::Impact(
                        0,
                        BindError::ReflectingWithoutDomain {
                            state: state.clone(),
                            at,
                            suggestion: format!("domain {} {op} {}", state.clone(), number(at)),
                        },
                    ));
                }
                (Jump::Reflecting, Some((lower, upper))) => {
                    laws[0].side = Some(match (lower, upper) {
                        (Some(lo), None) if same_place(lo, at) => BarrierSide::Above,
                        (None, Some(hi)) if same_place(hi, at) => BarrierSide::Below,
                        _ => {
                            // A bound away from the barrier, or a second bound with none.
                            let (part, b) =
                                [(DomainPart::Lower, lower), (DomainPart::Upper, upper)]
                                    .into_iter()
                                    .find_map(|(p, b)| {
                                        b.filter(|b| !same_place(*b, at)).map(|b| (p, b))
                                    })
                                    .unwrap_or((DomainPart::Upper, at));
                            return Err(Placed::Domain(
                                part,
                                BindError::DomainBoundWithoutImpact {
                                    state: state.clone(),
                                    bound: b,
                                },
                            ));
                        }
                    });
                }
                (Jump::Plastic, Some(_)) => {
                    return Err(Placed::Impact(
                        0,
                        BindError::PlasticWall {
                            state: state.clone(),
                            at,
                            jump: jump_text(model, &laws[0]),
                        },
                    ))
                }
                (_, Some(_)) => {
                    return Err(Placed::Domain(
                        DomainPart::Line,
                        BindError::DomainWithoutReflection {
                            state: state.clone(),
                            at,
                            jump: jump_text(model, &laws[0]),
                        },
                    ))
                }
                (_, None) => {}
            }
        }
        _ => {
            for (i, kind) in kinds.iter().enumerate() {
                if *kind != Jump::Reflecting {
                    return Err(Placed::Impact(
                        i,
                        BindError::StripNeedsReflecting {
                            state: state.clone(),
                            at: laws[i].at,
                            jump: jump_text(model, &laws[i]),
                        },
                    ));
                }
            }
            if same_place(laws[0].at, laws[1].at) {
                return Err(Placed::Impact(
                    1,
                    BindError::SameBarrier {
                        state: state.clone(),
                        at: laws[1].at,
                    },
                ));
            }
            laws.sort_by(|a, b| a.at.total_cmp(&b.at));
            let (lo, hi) = (laws[0].at, laws[1].at);
            if let Some((lower, upper)) = domain {
                let matches = |b: Option<f64>, at: f64| b.is_some_and(|b| same_place(b, at));
                if !matches(lower, lo) || !matches(upper, hi) {
                    let declared = model.domain.as_ref().expect("a domain was bound");
                    let mut declared_text = declared.text(states);
                    if let (Some(l), Some(u)) = (lower, upper) {
                        declared_text =
                            format!("{} <= {} <= {}", number(l), state.clone(), number(u));
                    }
                    return Err(Placed::Domain(
                        DomainPart::Line,
                        BindError::DomainDisagrees {
                            declared: declared_text,
                            implied: format!(
                                "{} <= {} <= {}",
                                number(lo),
                                state.clone(),
                                number(hi)
                            ),
                        },
                    ));
                }
            }
            laws[0].side = Some(BarrierSide::Above);
            laws[1].side = Some(BarrierSide::Below);
        }
    }
    Ok(laws)
}

/// `ydot -> -0.95*ydot`, for messages.
fn jump_text(model: &Model, law: &BoundImpact) -> String {
    format!("{} -> {:#}", model.states[law.other], law.map)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{parse_model, BindError, ModelError, Override, SemanticError};

    const BASE: &str = "model m\nparam c = 0.1, k = 1, r = 0.9, d = 1\nstate y, v\ndrift y: v\n\
                        drift v: -c*v - k*y\nnoise xi: intensity 1\ndiffusion v: xi\n";

    fn bound(extra: &str) -> Result<Vec<BoundImpact>, BindError> {
        let m = parse_model(
            &format!("{BASE}{extra}"),
            Some(std::path::Path::new("m.sde")),
        )
        .unwrap_or_else(|e| panic!("{extra}: {e}"));
        m.bind(&[]).map(|b| b.impacts().to_vec())
    }

    fn semantic(extra: &str) -> (SemanticError, usize, usize) {
        match parse_model(&format!("{BASE}{extra}"), None) {
            Err(ModelError::Semantic { error, diagnostic }) => {
                (*error, diagnostic.line(), diagnostic.column())
            }
            other => panic!("{extra}: {other:?}"),
        }
    }

    fn sides(laws: &[BoundImpact]) -> Vec<(f64, Option<BarrierSide>)> {
        laws.iter().map(|l| (l.at, l.side)).collect()
    }

    #[test]
    fn every_form_of_the_domain_line_gives_the_side() {
        let cases = [
            (
                "impact y = 0: v -> -r*v\ndomain y >= 0\n",
                BarrierSide::Above,
                0.0,
            ),
            (
                "impact y = 0: v -> -r*v\ndomain y > 0\n",
                BarrierSide::Above,
                0.0,
            ),
            (
                "impact y = d: v -> -r*v\ndomain y <= d\n",
                BarrierSide::Below,
                1.0,
            ),
            (
                "impact y = -d/2: v -> -r*v\ndomain y < -0.5\n",
                BarrierSide::Below,
                -0.5,
            ),
            (
                "impact y = 2*d: v -> -v\ndomain y >= 2\n",
                BarrierSide::Above,
                2.0,
            ),
            (
                "impact y = 0.1 + 0.2: v -> -v\ndomain y >= 0.3\n",
                BarrierSide::Above,
                0.1 + 0.2,
            ),
        ];
        for (extra, side, at) in cases {
            assert_eq!(sides(&bound(extra).unwrap()), [(at, Some(side))], "{extra}");
        }
        // A pass-through law has no side.
        let laws = bound("impact y = 0: v -> r*v\n").unwrap();
        assert_eq!(sides(&laws), [(0.0, None)]);
    }

    #[test]
    fn two_reflecting_laws_bound_a_strip_in_any_order() {
        for extra in [
            "impact y = d: v -> -r*v\nimpact y = -d: v -> -r*v\n",
            "impact y = -d: v -> -r*v\nimpact y = d: v -> -r*v\ndomain -d <= y <= d\n",
            "impact y = d: v -> -r*v\nimpact y = -d: v -> -0.5*v\ndomain -1 < y < 1\n",
        ] {
            let laws = bound(extra).unwrap();
            assert_eq!(
                sides(&laws),
                [
                    (-1.0, Some(BarrierSide::Above)),
                    (1.0, Some(BarrierSide::Below))
                ],
                "{extra}"
            );
        }
    }

    #[test]
    fn a_reflecting_law_without_a_domain_is_refused_with_the_line_to_add() {
        let err = bound("impact y = 0: v -> -r*v\n").unwrap_err();
        assert_eq!(
            err.cause(),
            &BindError::ReflectingWithoutDomain {
                state: "y".into(),
                at: 0.0,
                suggestion: "domain y >= 0".into()
            }
        );
        let d = err.diagnostic().unwrap();
        assert_eq!((d.line(), d.column()), (8, 12));
        assert_eq!(d.help(), Some("add the line `domain y >= 0`"));
        // The sign is decided at bind: `r` set negative makes a pass-through law reflecting.
        let m = parse_model(&format!("{BASE}impact y = d: v -> r*v\n"), None).unwrap();
        let err = m.bind(&[Override::number("r", -0.9)]).unwrap_err();
        assert!(matches!(
            err.cause(),
            BindError::ReflectingWithoutDomain { suggestion, .. } if suggestion == "domain y <= 1"
        ));
    }

    #[test]
    fn a_domain_must_sit_on_reflecting_barriers() {
        let err = bound("impact y = 0: v -> r*v\ndomain y >= 0\n").unwrap_err();
        assert!(
            matches!(err.cause(), BindError::DomainWithoutReflection { jump, .. } if jump == "v -> 0.9*v"),
            "{err}"
        );
        assert_eq!(err.diagnostic().unwrap().line(), 9);
        // A plastic law keeps the state at the barrier: a plastic wall, not a pass-through,
        // refused at its impact line.
        let err = bound("impact y = 0: v -> 0*v\ndomain y >= 0\n").unwrap_err();
        assert!(
            matches!(err.cause(), BindError::PlasticWall { jump, .. } if jump == "v -> 0*v"),
            "{err}"
        );
        assert_eq!(err.diagnostic().unwrap().line(), 8);
        let err = bound("impact y = 0: v -> -r*v\ndomain y >= d\n").unwrap_err();
        assert_eq!(
            err.cause(),
            &BindError::DomainBoundWithoutImpact {
                state: "y".into(),
                bound: 1.0
            }
        );
        assert_eq!(
            (
                err.diagnostic().unwrap().line(),
                err.diagnostic().unwrap().column()
            ),
            (9, 13)
        );
        let err = bound("impact y = 0: v -> -r*v\ndomain 0 <= y <= d\n").unwrap_err();
        assert!(matches!(
            err.cause(),
            BindError::DomainBoundWithoutImpact { bound, .. } if *bound == 1.0
        ));
        // An override that moves the barrier away from its bound is caught at bind.
        let m = parse_model(
            &format!("{BASE}impact y = d: v -> -r*v\ndomain y <= 1\n"),
            None,
        )
        .unwrap();
        assert!(m.bind(&[]).is_ok());
        let err = m.bind(&[Override::number("d", 2.0)]).unwrap_err();
        assert!(matches!(
            err.cause(),
            BindError::DomainBoundWithoutImpact { bound, .. } if *bound == 1.0
        ));
    }

    #[test]
    fn a_strip_needs_two_reflecting_laws_at_two_places() {
        let err = bound("impact y = -d: v -> -r*v\nimpact y = d: v -> r*v\n").unwrap_err();
        assert!(matches!(
            err.cause(),
            BindError::StripNeedsReflecting { at, .. } if *at == 1.0
        ));
        assert_eq!(err.diagnostic().unwrap().line(), 9);
        let err = bound("impact y = d: v -> -r*v\nimpact y = 1: v -> -r*v\n").unwrap_err();
        assert!(matches!(err.cause(), BindError::SameBarrier { at, .. } if *at == 1.0));
        let err = bound("impact y = -d: v -> -r*v\nimpact y = d: v -> -r*v\ndomain y >= -1\n")
            .unwrap_err();
        assert_eq!(
            err.cause(),
            &BindError::DomainDisagrees {
                declared: "y >= -1".into(),
                implied: "-1 <= y <= 1".into()
            }
        );
        let err = bound("impact y = -d: v -> -r*v\nimpact y = d: v -> -r*v\ndomain -2 <= y <= 1\n")
            .unwrap_err();
        assert!(matches!(
            err.cause(),
            BindError::DomainDisagrees { declared, .. } if declared == "-2 <= y <= 1"
        ));
    }

    #[test]
    fn impact_and_domain_lines_are_checked_when_read() {
        let (e, l, c) =
            semantic("impact y = 0: v -> -v\nimpact y = 1: v -> -v\nimpact y = 2: v -> -v\n");
        assert_eq!(
            e,
            SemanticError::TooManyImpacts {
                previous_lines: (8, 9)
            }
        );
        assert_eq!((l, c), (10, 1));
        let (e, l, c) = semantic("impact y = 0: v -> -v\nimpact v = 1: y -> -y\n");
        assert_eq!(
            e,
            SemanticError::ImpactsOnDifferentStates {
                first: "y".into(),
                second: "v".into()
            }
        );
        assert_eq!((l, c), (9, 8));
        let (e, l, _) = semantic("domain y >= 0\n");
        assert_eq!(e, SemanticError::DomainWithoutImpact { state: "y".into() });
        assert_eq!(l, 8);
        let (e, ..) = semantic("impact y = 0: v -> -v\ndomain v >= 0\n");
        assert!(matches!(e, SemanticError::DomainOnOtherState { .. }));
        let (e, ..) = semantic("impact y = 0: v -> -v\ndomain y >= 0\ndomain y >= 0\n");
        assert!(matches!(
            e,
            SemanticError::DuplicateStatement {
                keyword: "domain",
                ..
            }
        ));
        let (e, ..) = semantic("impact y = 0: v -> -v\ndomain w >= 0\n");
        assert!(matches!(
            e,
            SemanticError::UnknownState {
                context: "domain",
                ..
            }
        ));
        let (e, ..) = semantic("impact y = 0: v -> -v\ndomain y >= v\n");
        assert!(matches!(e, SemanticError::StateInConstant { .. }), "{e:?}");
    }

    #[test]
    fn the_domain_line_prints_back_as_written() {
        for line in [
            "domain y >= 0",
            "domain y > 0",
            "domain -d <= y < d",
            "domain y <= d",
        ] {
            let laws = if line.contains("<=") && line.contains('-') || line.contains("< d") {
                "impact y = -d: v -> -r*v\nimpact y = d: v -> -r*v\n"
            } else if line.contains("<= d") {
                "impact y = d: v -> -r*v\n"
            } else {
                "impact y = 0: v -> -r*v\n"
            };
            let m = parse_model(&format!("{BASE}{laws}{line}\n"), None).unwrap();
            let printed = m.to_string();
            assert!(printed.contains(&format!("{line}\n")), "{printed}");
            assert_eq!(parse_model(&printed, None).unwrap(), m);
        }
    }
}
