//! The mechanical form the fast kernel (`kernel/mech`) runs: the step program's outputs
//! recognised, at plan time, as polynomials in `z`, `s = sgn(z)` and `v`:
//!
//! ```text
//! f(z, v)      = Σ_{l ≤ 3} v^l·(F_l0(z) + s·F_l1(z))
//! σ(z)         = S₀(z) + s·S₁(z)
//! ∂f/∂v(z)     = L₀(z) + s·L₁(z)          (only when f is affine in v)
//! ```
//!
//! A force affine in v (linear damping, van der Pol, parametric damping) comes with its
//! slope ∂f/∂v, which collapses the Heun corrector into one evaluation; a force of degree 2
//! or 3 in v (Rayleigh damping `v³`, energy-dependent damping `H(z, v)·v`) is evaluated twice
//! a step, at v and at the predictor, as the lane evaluator does it. The recogniser runs the
//! tape's instructions over this algebra (`abs(z)` is `s·z`); a program outside it (any
//! other function of a state, a division by one, `sgn(z)²`, a fourth power of `v`) is not
//! recognised and keeps the lane evaluator. The kernel evaluates each polynomial by Horner's
//! rule on coefficients prescaled by the step sizes (`kernel/mech/coef.rs`), not in the tape's
//! order, so its outputs agree with the tape's to rounding (a bound in the tests), not to the
//! bit.
//!
//! In a program of a time-dependent model the coefficients may depend on the time: an
//! instruction of the time only (`exp(-0.5*t)`, `cos(w*t)`) is a coefficient, and the
//! recogniser carries each coefficient built from such values as an expression of them
//! ([`TimedForm`]); the form's coefficients at a time are that expression's values there,
//! computed once per step for every lane (`TimedForm::at`).

use crate::mc::compile::lanes::{LaneOp, LaneProgram};
use crate::symbolic::{DeltaPolicy, Expr, Tape, TapeUnary as Unary};

/// Highest power of `z` the recogniser follows.
const MAX_DEGREE: usize = 8;
/// Highest power of `v` the recogniser follows (Rayleigh and energy-dependent damping).
pub(crate) const MAX_V_DEGREE: usize = 3;

/// A coefficient of the recogniser's polynomials: a number, or an expression of the values
/// of a program's time instructions (symbols [`time_slot`]), never zero.
#[derive(Clone, Debug, PartialEq)]
enum Coef {
    Num(f64),
    Time(Expr),
}

impl Coef {
    const ZERO: Coef = Coef::Num(0.0);

    fn is_zero(&self) -> bool {
        matches!(self, Coef::Num(c) if *c == 0.0)
    }

    fn expr(&self) -> Expr {
        match self {
            Coef::Num(c) => Expr::num(*c),
            Coef::Time(e) => e.clone(),
        }
    }

    /// `f` of two numbers as numbers (the arithmetic of a model without the time), else
    /// `g` of their expressions.
    fn combine(
        &self,
        o: &Coef,
        f: impl Fn(f64, f64) -> f64,
        g: impl Fn(Expr, Expr) -> Expr,
    ) -> Coef {
        match (self, o) {
            (Coef::Num(a), Coef::Num(b)) => Coef::Num(f(*a, *b)),
            _ => Coef::Time(g(self.expr(), o.expr())),
        }
    }

    fn add(&self, o: &Coef) -> Coef {
        match (self.is_zero(), o.is_zero()) {
            (_, true) if matches!(self, Coef::Time(_)) => self.clone(),
            (true, _) if matches!(o, Coef::Time(_)) => o.clone(),
            _ => self.combine(o, |a, b| a + b, |a, b| a + b),
        }
    }

    fn sub(&self, o: &Coef) -> Coef {
        match o.is_zero() {
            true if matches!(self, Coef::Time(_)) => self.clone(),
            _ => self.combine(o, |a, b| a - b, |a, b| a - b),
        }
    }

    fn mul(&self, o: &Coef) -> Coef {
        match (self, o) {
            (Coef::Num(a), Coef::Num(b)) => Coef::Num(a * b),
            _ if self.is_zero() || o.is_zero() => Coef::ZERO,
            _ => Coef::Time(self.expr() * o.expr()),
        }
    }

    fn scale(&self, c: f64) -> Coef {
        self.mul(&Coef::Num(c))
    }
}

/// The symbol standing for the value of a program's time instruction `slot` in the
/// coefficients of a [`TimedForm`].
fn time_slot(slot: usize) -> String {
    format!("@{slot}")
}

/// A polynomial in z, s (degree ≤ 1) and v (degree ≤ [`MAX_V_DEGREE`]): `c[k][j][l]`
/// multiplies `z^k s^j v^l`.
#[derive(Clone, Debug, PartialEq)]
struct Poly {
    c: [[[Coef; MAX_V_DEGREE + 1]; 2]; MAX_DEGREE + 1],
}

/// A value of the program under the algebra: a polynomial, or something outside it.
#[derive(Clone, Debug)]
enum Value {
    Poly(Box<Poly>),
    /// Not a polynomial of the form (e.g. `abs(v)`): vanishes only when multiplied by zero.
    Opaque,
}

impl Poly {
    fn zero() -> Poly {
        Poly {
            c: std::array::from_fn(|_| {
                std::array::from_fn(|_| std::array::from_fn(|_| Coef::ZERO))
            }),
        }
    }

    fn constant(c: Coef) -> Poly {
        let mut p = Poly::zero();
        p.c[0][0][0] = c;
        p
    }

    fn monomial(k: usize, j: usize, l: usize) -> Poly {
        let mut p = Poly::zero();
        p.c[k][j][l] = Coef::Num(1.0);
        p
    }

    fn is_zero(&self) -> bool {
        self.c.iter().flatten().flatten().all(Coef::is_zero)
    }

    fn map(&self, f: impl Fn(&Coef) -> Coef) -> Poly {
        let mut p = self.clone();
        p.c.iter_mut().flatten().flatten().for_each(|c| *c = f(c));
        p
    }

    fn zip(&self, o: &Poly, f: impl Fn(&Coef, &Coef) -> Coef) -> Poly {
        let mut p = Poly::zero();
        for k in 0..=MAX_DEGREE {
            for j in 0..2 {
                for l in 0..=MAX_V_DEGREE {
                    p.c[k][j][l] = f(&self.c[k][j][l], &o.c[k][j][l]);
                }
            }
        }
        p
    }

    /// The product, `None` when a degree leaves the form.
    fn mul(&self, o: &Poly) -> Option<Poly> {
        let mut p = Poly::zero();
        for (k1, a) in self.c.iter().enumerate() {
            for (j1, a) in a.iter().enumerate() {
                for (l1, a) in a.iter().enumerate() {
                    if a.is_zero() {
                        continue;
                    }
                    for (k2, b) in o.c.iter().enumerate() {
                        for (j2, b) in b.iter().enumerate() {
                            for (l2, b) in b.iter().enumerate() {
                                if b.is_zero() {
                                    continue;
                                }
                                let (k, j, l) = (k1 + k2, j1 + j2, l1 + l2);
                                if k > MAX_DEGREE || j > 1 || l > MAX_V_DEGREE {
                                    return None;
                                }
                                p.c[k][j][l] = p.c[k][j][l].add(&a.mul(b));
                            }
                        }
                    }
                }
            }
        }
        Some(p)
    }

    /// The coefficients of `s^j v^l` as a polynomial in z (trailing zeros trimmed).
    fn part(&self, j: usize, l: usize) -> ZPoly<Coef> {
        let mut coef: Vec<Coef> = self.c.iter().map(|c| c[j][l].clone()).collect();
        while coef.last().is_some_and(Coef::is_zero) {
            coef.pop();
        }
        ZPoly { coef }
    }
}

/// A polynomial in z, coefficients from the constant up (none: the zero polynomial).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ZPoly<C = f64> {
    pub(crate) coef: Vec<C>,
}

impl ZPoly {
    /// Horner's rule, from the highest power down.
    #[cfg(test)]
    pub(crate) fn eval(&self, z: f64) -> f64 {
        let mut it = self.coef.iter().rev();
        let Some(&top) = it.next() else {
            return 0.0;
        };
        it.fold(top, |p, &c| p * z + c)
    }
}

/// `P₀(z) + s·P₁(z)`, the sign part absent when zero.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SgnPoly<C = f64> {
    pub(crate) plain: ZPoly<C>,
    pub(crate) sgn: Option<ZPoly<C>>,
}

impl<C> SgnPoly<C> {
    fn new(plain: ZPoly<C>, sgn: ZPoly<C>) -> SgnPoly<C> {
        SgnPoly {
            plain,
            sgn: (!sgn.coef.is_empty()).then_some(sgn),
        }
    }

    /// Every coefficient, the plain part's first, `f` applied in that order.
    fn map<D>(&self, f: &mut impl FnMut(&C) -> D) -> SgnPoly<D> {
        let mut zmap = |p: &ZPoly<C>| ZPoly {
            coef: p.coef.iter().map(&mut *f).collect(),
        };
        let plain = zmap(&self.plain);
        SgnPoly {
            plain,
            sgn: self.sgn.as_ref().map(zmap),
        }
    }

    /// Every coefficient in [`SgnPoly::map`]'s order.
    fn visit_mut(&mut self, f: &mut impl FnMut(&mut C)) {
        self.plain.coef.iter_mut().for_each(&mut *f);
        if let Some(s) = &mut self.sgn {
            s.coef.iter_mut().for_each(f);
        }
    }
}

impl SgnPoly {
    #[cfg(test)]
    pub(crate) fn eval(&self, z: f64, s: f64) -> f64 {
        match &self.sgn {
            None => self.plain.eval(z),
            Some(q) => self.plain.eval(z) + s * q.eval(z),
        }
    }
}

/// The step program (outputs f, σ and, for a force affine in v, ∂f/∂v) recognised in the
/// mechanical form, with coefficients `C` (numbers, or for [`TimedForm`] at plan time
/// expressions of the time).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MechForm<C = f64> {
    /// The part of f free of v.
    pub(crate) force0: SgnPoly<C>,
    /// How f depends on v.
    pub(crate) in_v: InVelocity<C>,
    /// σ.
    pub(crate) sigma: SgnPoly<C>,
}

/// How the force f depends on the velocity, which decides how the Heun corrector is taken.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum InVelocity<C = f64> {
    /// `f = force0 + v·force1` (`force1` absent when f does not depend on v), with the
    /// slope ∂f/∂v as the step program computes it: the corrector needs no second
    /// evaluation of f.
    Affine {
        force1: Option<SgnPoly<C>>,
        slope: SgnPoly<C>,
    },
    /// `f = force0 + Σ_l v^l·powers[l − 1]` for l = 1..=[`MAX_V_DEGREE`] (a power absent
    /// when its coefficient is zero), of degree 2 or more in v: f is evaluated at v and at
    /// the predictor.
    Polynomial {
        powers: [Option<SgnPoly<C>>; MAX_V_DEGREE],
    },
}

/// sgn as the tape computes it (0 at zero and for NaN).
#[inline(always)]
pub(crate) fn sgn(z: f64) -> f64 {
    Unary::Sgn.apply(z)
}

impl<C> MechForm<C> {
    /// The form with every coefficient `f` of the one here, taken in a fixed order (the
    /// order of [`MechForm::visit_mut`]).
    fn map<D>(&self, f: &mut impl FnMut(&C) -> D) -> MechForm<D> {
        let force0 = self.force0.map(f);
        let in_v = match &self.in_v {
            InVelocity::Affine { force1, slope } => {
                let force1 = force1.as_ref().map(|p| p.map(f));
                InVelocity::Affine {
                    force1,
                    slope: slope.map(f),
                }
            }
            InVelocity::Polynomial { powers } => {
                let mut out: [Option<SgnPoly<D>>; MAX_V_DEGREE] = Default::default();
                for (o, p) in out.iter_mut().zip(powers) {
                    *o = p.as_ref().map(|p| p.map(f));
                }
                InVelocity::Polynomial { powers: out }
            }
        };
        MechForm {
            force0,
            in_v,
            sigma: self.sigma.map(f),
        }
    }

    /// Every coefficient, in the order of [`MechForm::map`].
    fn visit_mut(&mut self, f: &mut impl FnMut(&mut C)) {
        self.force0.visit_mut(f);
        match &mut self.in_v {
            InVelocity::Affine { force1, slope } => {
                if let Some(p) = force1 {
                    p.visit_mut(f);
                }
                slope.visit_mut(f);
            }
            InVelocity::Polynomial { powers } => {
                for p in powers.iter_mut().flatten() {
                    p.visit_mut(f);
                }
            }
        }
        self.sigma.visit_mut(f);
    }
}

impl MechForm {
    /// The form of `program` (outputs f, σ and, when f is affine in v, ∂f/∂v, of the states
    /// z, v), or `None` when the program is outside it or its coefficients depend on the
    /// time (see [`TimedForm::recognise`]).
    pub(crate) fn recognise(program: &LaneProgram) -> Option<MechForm> {
        let form = recognise(program)?;
        let mut numbers = true;
        let fixed = form.map(&mut |c| match c {
            Coef::Num(x) => *x,
            Coef::Time(_) => {
                numbers = false;
                f64::NAN
            }
        });
        numbers.then_some(fixed)
    }

    /// f, σ and (for a force affine in v) ∂f/∂v at `(z, v)` by Horner's rule (the
    /// reference of the tests).
    #[cfg(test)]
    pub(crate) fn eval(&self, z: f64, v: f64) -> (f64, f64, Option<f64>) {
        let s = sgn(z);
        let (f, slope) = match &self.in_v {
            InVelocity::Affine { force1, slope } => (
                match force1 {
                    None => self.force0.eval(z, s),
                    Some(b) => self.force0.eval(z, s) + v * b.eval(z, s),
                },
                Some(slope.eval(z, s)),
            ),
            InVelocity::Polynomial { powers } => {
                let mut acc = 0.0;
                for p in powers.iter().rev() {
                    acc = acc * v + p.as_ref().map_or(0.0, |p| p.eval(z, s));
                }
                (self.force0.eval(z, s) + acc * v, None)
            }
        };
        (f, self.sigma.eval(z, s), slope)
    }
}

/// The mechanical form of a program whose coefficients depend on the time: the form's
/// shape (which coefficients there are) and its coefficients as one tape of the values of
/// the program's time instructions, evaluated at a step's time by [`TimedForm::at`].
#[derive(Clone, Debug)]
pub(crate) struct TimedForm {
    /// The form; its time-dependent coefficients NaN, written by [`TimedForm::at`].
    shape: MechForm,
    /// For each coefficient in [`MechForm::visit_mut`]'s order, the tape output that is its
    /// value, or `None` for a number (kept as it is in `shape`).
    outputs: Vec<Option<usize>>,
    /// The time-dependent coefficients, of the variables `slots` (the program's time
    /// instructions whose values they take).
    tape: Tape,
    slots: Vec<u32>,
    /// The step program, whose time instructions `set_time` computes.
    program: LaneProgram,
}

/// Working memory of [`TimedForm::at`], so that a step allocates nothing.
#[derive(Clone, Debug, Default)]
pub(crate) struct TimedWork {
    slots: Vec<[f64; 1]>,
    vars: Vec<f64>,
    values: Vec<f64>,
    scratch: Vec<f64>,
}

impl TimedForm {
    /// The form of `program` when its coefficients depend on the time (as
    /// [`MechForm::recognise`]); `None` when it is outside the form, or its coefficients are
    /// numbers (then [`MechForm::recognise`] gives it).
    pub(crate) fn recognise(program: &LaneProgram) -> Option<TimedForm> {
        let form = recognise(program)?;
        let mut exprs = Vec::new();
        let mut outputs = Vec::new();
        let shape = form.map(&mut |c| match c {
            Coef::Num(x) => {
                outputs.push(None);
                *x
            }
            Coef::Time(e) => {
                outputs.push(Some(exprs.len()));
                exprs.push(e.clone());
                f64::NAN
            }
        });
        if exprs.is_empty() {
            return None;
        }
        let mut slots: Vec<u32> = (0..program.n_slots() as u32)
            .filter(|&i| exprs.iter().any(|e| e.mentions(&time_slot(i as usize))))
            .collect();
        slots.sort_unstable();
        let names: Vec<String> = slots.iter().map(|&i| time_slot(i as usize)).collect();
        let vars: Vec<&str> = names.iter().map(String::as_str).collect();
        let tape = Tape::compile(&exprs, &vars, DeltaPolicy::Zero).ok()?;
        Some(TimedForm {
            shape,
            outputs,
            tape,
            slots,
            program: program.clone(),
        })
    }

    /// Working memory for [`TimedForm::at`].
    pub(crate) fn work(&self) -> TimedWork {
        TimedWork {
            slots: vec![[0.0]; self.program.n_slots()],
            vars: vec![0.0; self.slots.len()],
            values: vec![0.0; self.tape.n_outputs()],
            scratch: Vec::new(),
        }
    }

    /// The form at time `t` into `form` (a clone of [`TimedForm::shape`]): its
    /// time-dependent coefficients evaluated there, by the tape's arithmetic.
    pub(crate) fn at(&self, t: f64, form: &mut MechForm, w: &mut TimedWork) {
        self.program.set_time(t, &mut w.slots);
        for (v, &s) in w.vars.iter_mut().zip(&self.slots) {
            *v = w.slots[s as usize][0];
        }
        self.tape.eval(&w.vars, &mut w.scratch, &mut w.values);
        let mut k = 0;
        form.visit_mut(&mut |c| {
            if let Some(j) = self.outputs[k] {
                *c = w.values[j];
            }
            k += 1;
        });
    }

    /// The form's shape, its time-dependent coefficients NaN (what [`TimedForm::at`] writes
    /// into; prescaled, the NaNs mark the kernel's coefficients that change with time).
    pub(crate) fn shape(&self) -> &MechForm {
        &self.shape
    }
}

/// The form of `program`, its coefficients numbers or expressions of its time instructions.
fn recognise(program: &LaneProgram) -> Option<MechForm<Coef>> {
    let outputs = program.outputs();
    if !(2..=3).contains(&outputs.len()) {
        return None;
    }
    let z = Poly::monomial(1, 0, 0);
    let mut vals: Vec<Value> = Vec::with_capacity(program.ops().len());
    for (i, &op) in program.ops().iter().enumerate() {
        let get = |a: u32| vals[a as usize].clone();
        let lin = |a: u32, f: &dyn Fn(&Poly) -> Poly| match get(a) {
            Value::Poly(p) => Value::Poly(Box::new(f(&p))),
            Value::Opaque => Value::Opaque,
        };
        let both = |a: u32, b: u32, f: &dyn Fn(&Coef, &Coef) -> Coef| match (get(a), get(b)) {
            (Value::Poly(p), Value::Poly(q)) => Value::Poly(Box::new(p.zip(&q, f))),
            _ => Value::Opaque,
        };
        let poly = |p: Poly| Value::Poly(Box::new(p));
        let value = match op {
            // A value of the time only is a coefficient, whatever it is built from.
            _ if program.is_time_only(i) => {
                poly(Poly::constant(Coef::Time(Expr::sym(&time_slot(i)))))
            }
            LaneOp::Const(c) => poly(Poly::constant(Coef::Num(c))),
            LaneOp::Var(0) => poly(z.clone()),
            LaneOp::Var(1) => poly(Poly::monomial(0, 0, 1)),
            LaneOp::Var(_) => Value::Opaque,
            LaneOp::Add(a, b) => both(a, b, &Coef::add),
            LaneOp::Sub(a, b) => both(a, b, &Coef::sub),
            LaneOp::Neg(a) => lin(a, &|p| p.map(|c| c.combine(c, |x, _| -x, |e, _| -e))),
            LaneOp::AddC(a, c) => lin(a, &|p| {
                let mut p = p.clone();
                p.c[0][0][0] = p.c[0][0][0].add(&Coef::Num(c));
                p
            }),
            // Anything times zero (the pattern matches −0 too) is zero here: a
            // non-finite state has blown up anyway.
            LaneOp::MulC(_, 0.0) => poly(Poly::zero()),
            LaneOp::MulC(a, c) => lin(a, &|p| p.map(|x| x.scale(c))),
            LaneOp::Mul(a, b) => match (get(a), get(b)) {
                (Value::Poly(p), Value::Poly(q)) => poly(p.mul(&q)?),
                (Value::Poly(p), Value::Opaque) | (Value::Opaque, Value::Poly(p))
                    if p.is_zero() =>
                {
                    poly(Poly::zero())
                }
                _ => Value::Opaque,
            },
            LaneOp::PowC(a, c) if c.fract() == 0.0 && (0.0..=8.0).contains(&c) => match get(a) {
                Value::Poly(p) => {
                    let mut acc = Poly::constant(Coef::Num(1.0));
                    for _ in 0..c as usize {
                        acc = acc.mul(&p)?;
                    }
                    poly(acc)
                }
                Value::Opaque => Value::Opaque,
            },
            LaneOp::Unary(f @ (Unary::Abs | Unary::Sgn), a) => match get(a) {
                Value::Poly(p) if *p == z => poly(match f {
                    Unary::Abs => Poly::monomial(1, 1, 0),
                    _ => Poly::monomial(0, 1, 0),
                }),
                _ => Value::Opaque,
            },
            _ => Value::Opaque,
        };
        vals.push(value);
    }
    let out = |j: usize| match &vals[outputs[j] as usize] {
        Value::Poly(p) => Some((**p).clone()),
        Value::Opaque => None,
    };
    let (f, sigma) = (out(0)?, out(1)?);
    let free_of_v = |p: &Poly| {
        p.c.iter()
            .flatten()
            .all(|c| c[1..].iter().all(Coef::is_zero))
    };
    if !free_of_v(&sigma) {
        return None;
    }
    let power = |l: usize| {
        let p = SgnPoly::new(f.part(0, l), f.part(1, l));
        (!p.plain.coef.is_empty() || p.sgn.is_some()).then_some(p)
    };
    let in_v = match outputs.len() {
        // The slope comes with a force the model's symbols show affine in v.
        3 => {
            let slope = out(2)?;
            if !free_of_v(&slope) || (2..=MAX_V_DEGREE).any(|l| power(l).is_some()) {
                return None;
            }
            InVelocity::Affine {
                force1: power(1),
                slope: SgnPoly::new(slope.part(0, 0), slope.part(1, 0)),
            }
        }
        2 => InVelocity::Polynomial {
            powers: std::array::from_fn(|l| power(l + 1)),
        },
        _ => return None,
    };
    Some(MechForm {
        force0: SgnPoly::new(f.part(0, 0), f.part(1, 0)),
        in_v,
        sigma: SgnPoly::new(sigma.part(0, 0), sigma.part(1, 0)),
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::mc::compile::scheme::{impact_specs, Dynamics, Plan, SchemeChoice};
    use crate::mc::McError;

    pub(crate) fn plan(name: &str) -> Result<Plan, McError> {
        let path = format!("{}/models/{name}.sde", env!("CARGO_MANIFEST_DIR"));
        let model = crate::model::load_model(path.as_ref())
            .unwrap()
            .bind(&[])
            .unwrap();
        Plan::of_model(&model, SchemeChoice::Auto, impact_specs(&model)?)
    }

    /// The plan of a model given as text.
    pub(crate) fn plan_of(source: &str) -> Result<Plan, McError> {
        let model = crate::model::parse_model(source, None)
            .unwrap()
            .bind(&[])
            .unwrap();
        Plan::of_model(&model, SchemeChoice::Auto, impact_specs(&model)?)
    }

    /// The bundled models on the mechanical path (the strip's runs the form too, though its
    /// two walls keep it on the lane evaluator).
    pub(crate) const MECHANICAL: [&str; 8] = [
        "vibro_duffing",
        "vibro_impact_duffing",
        "duffing",
        "linear",
        "parametric",
        "van_der_pol",
        "bistable_duffing",
        "vibro_impact_strip",
    ];

    /// Forces of degree 3 in v, none of them bundled: energy-dependent damping
    /// `(c₀ + c₁·H)·v` with the Duffing energy H, and Rayleigh damping `−c·v + d·v³` with
    /// a parametric noise and a barrier (the van der Pol–Rayleigh family under impacts).
    pub(crate) const POLYNOMIAL_IN_V: [(&str, &str); 2] = [
        (
            "energy_damping",
            "model energy_damping \"energy-dependent damping\"\n\
             param c0 = 0.05, c1 = 0.01, S = 0.05\n\
             state x, v\n\
             drift x: v\n\
             drift v: -(c0 + c1*(v^2/2 + x^2/2 + x^4/4))*v - x - x^3\n\
             noise xi: intensity 2*pi*S\n\
             diffusion v: xi\n",
        ),
        (
            "rayleigh_impact",
            "model rayleigh_impact \"Rayleigh damping at a barrier\"\n\
             param c = 0.1, d = 0.05, r = 0.8\n\
             state y, ydot\n\
             drift y: ydot\n\
             drift ydot: -c*ydot - d*ydot^3 + 0.02*abs(y)*ydot^2 - y\n\
             noise xi: intensity 0.2\n\
             diffusion ydot: (1 + 0.1*y)*xi\n\
             impact y = -0.5: ydot -> -r*ydot\n\
             domain y >= -0.5\n",
        ),
    ];

    /// The plan of a bundled model or of one of [`POLYNOMIAL_IN_V`], by name.
    pub(crate) fn plan_named(name: &str) -> Result<Plan, McError> {
        match POLYNOMIAL_IN_V.iter().find(|(n, _)| *n == name) {
            Some((_, text)) => plan_of(text),
            None => plan(name),
        }
    }

    /// Every mechanical model the kernel's tests run: the bundled ones and
    /// [`POLYNOMIAL_IN_V`].
    pub(crate) fn mechanical_plans() -> Vec<(&'static str, Plan)> {
        let names = MECHANICAL
            .iter()
            .chain(POLYNOMIAL_IN_V.iter().map(|(n, _)| n));
        names.map(|&n| (n, plan_named(n).unwrap())).collect()
    }

    fn form_of(p: &Plan) -> Option<&MechForm> {
        match &p.dynamics {
            Dynamics::Mechanical { form, .. } => form.as_ref(),
            Dynamics::General { .. } => panic!("not on the mechanical path"),
        }
    }

    #[test]
    fn the_mechanical_models_take_the_fast_path() {
        for (name, p) in mechanical_plans() {
            assert!(form_of(&p).is_some(), "{name}");
        }
        for (name, text) in POLYNOMIAL_IN_V {
            let p = plan_of(text).unwrap();
            let Some(MechForm {
                in_v: InVelocity::Polynomial { powers },
                ..
            }) = form_of(&p)
            else {
                panic!("{name}: not a force polynomial in v");
            };
            assert!(powers[2].is_some(), "{name}: no v³ term");
        }
        // σ = √(2D₁ sgn(z)² + 2D₂ z²): a square root, outside the form.
        assert!(form_of(&plan("vdp_vibro_impact").unwrap()).is_none());
    }

    #[test]
    fn the_form_of_vibro_duffing_is_its_model() {
        // f = −0.1 v − z − 0.1 z³ (the impact term, times 1 − r = 0 under δ = 0, drops),
        // σ = √(2πK)(sgn z + 0.1 z) with 2πK = 1, ∂f/∂v = −0.1.
        let p = plan("vibro_duffing").unwrap();
        let f = form_of(&p).unwrap();
        assert_eq!(f.force0.plain.coef, vec![0.0, -1.0, 0.0, -0.1]);
        assert!(f.force0.sgn.is_none());
        let InVelocity::Affine { force1, slope } = &f.in_v else {
            panic!("a force affine in v");
        };
        let b = force1.as_ref().unwrap();
        assert_eq!((b.plain.coef.as_slice(), &b.sgn), (&[-0.1][..], &None));
        assert_eq!(f.sigma.plain.coef, vec![0.0, 0.1]);
        assert_eq!(f.sigma.sgn.as_ref().unwrap().coef, vec![1.0]);
        assert_eq!(slope.plain.coef, vec![-0.1]);
    }

    #[test]
    fn the_form_of_energy_dependent_damping_is_its_model() {
        // f = −(c₀ + c₁(v²/2 + x²/2 + x⁴/4))·v − x − x³, c₀ = 0.05, c₁ = 0.01.
        let p = plan_of(POLYNOMIAL_IN_V[0].1).unwrap();
        let f = form_of(&p).unwrap();
        assert_eq!(f.force0.plain.coef, vec![0.0, -1.0, 0.0, -1.0]);
        let InVelocity::Polynomial { powers } = &f.in_v else {
            panic!("a force of degree 3 in v");
        };
        let coef = |l: usize| powers[l].as_ref().map(|p| p.plain.coef.clone());
        assert_eq!(coef(0), Some(vec![-0.05, 0.0, -0.005, 0.0, -0.0025]));
        assert_eq!(coef(1), None);
        assert_eq!(coef(2), Some(vec![-0.005]));
    }

    /// A fourth power of v, or a v under a function, keeps the lane evaluator.
    #[test]
    fn forces_outside_the_form_are_not_recognised() {
        for drift in [
            "-0.1*v^5 - x",
            "-0.1*v*v*v*v*v - x",
            "-0.1*tanh(v) - x",
            "-0.1*v/(1 + x^2) - x",
        ] {
            let text = POLYNOMIAL_IN_V[0]
                .1
                .replace("-(c0 + c1*(v^2/2 + x^2/2 + x^4/4))*v - x - x^3", drift);
            assert!(form_of(&plan_of(&text).unwrap()).is_none(), "{drift}");
        }
    }

    /// The form's f, σ, ∂f/∂v against the step program's at random states: Horner's order
    /// is not the tape's, so they agree to rounding, bounded by a few ulps of the sum of the
    /// terms' magnitudes (the bound of either order of summation).
    #[test]
    fn the_form_agrees_with_the_lane_evaluator() {
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut uniform = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for (name, p) in mechanical_plans() {
            let form = form_of(&p).unwrap();
            let Dynamics::Mechanical { step, .. } = &p.dynamics else {
                unreachable!()
            };
            // The magnitude bound: the form evaluated on |z| with |coefficients|.
            let abs = |q: &SgnPoly| SgnPoly {
                plain: ZPoly {
                    coef: q.plain.coef.iter().map(|c| c.abs()).collect(),
                },
                sgn: q.sgn.as_ref().map(|s| ZPoly {
                    coef: s.coef.iter().map(|c| c.abs()).collect(),
                }),
            };
            let bound = MechForm {
                force0: abs(&form.force0),
                in_v: match &form.in_v {
                    InVelocity::Affine { force1, slope } => InVelocity::Affine {
                        force1: force1.as_ref().map(abs),
                        slope: abs(slope),
                    },
                    InVelocity::Polynomial { powers } => InVelocity::Polynomial {
                        powers: std::array::from_fn(|l| powers[l].as_ref().map(abs)),
                    },
                },
                sigma: abs(&form.sigma),
            };
            for k in 0..2000 {
                let (z, v) = if k < 4 {
                    ([0.0, -0.0, 1.0, -1.0][k], 0.5)
                } else {
                    ((uniform() - 0.5) * 10.0, (uniform() - 0.5) * 10.0)
                };
                let mut want = [0.0; 3];
                step.eval_point(0.0, z, v, &mut want);
                let (f, s, l) = form.eval(z, v);
                let (fm, sm, lm) = bound.eval(z.abs(), v.abs());
                let mut pairs = vec![(f, want[0], fm), (s, want[1], sm)];
                if let (Some(l), Some(lm)) = (l, lm) {
                    pairs.push((l, want[2], lm));
                }
                for (got, want, mag) in pairs {
                    assert!(
                        (got - want).abs() <= 8.0 * f64::EPSILON * mag,
                        "{name} at ({z}, {v}): {got} vs the tape's {want}"
                    );
                }
            }
        }
    }
}
