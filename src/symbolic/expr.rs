//! The expression tree shared by every stage after parsing.
//!
//! Expressions are kept in a small canonical vocabulary: n-ary sums and products, powers,
//! numbers, symbols and calls. Subtraction is `a + (-1)·b`, division is `a · b^(-1)` and
//! negation is `(-1)·a`, so that simplification and differentiation have few cases to handle;
//! [`std::fmt::Display`] prints them back as `a - b`, `a/b` and `-a`.

use std::collections::BTreeSet;
use std::sync::Arc;

/// A name in an expression: a state variable, a parameter or a noise source.
///
/// ```
/// let s: fpsolve::symbolic::Symbol = "z".into();
/// assert_eq!(fpsolve::symbolic::Expr::sym("z"), fpsolve::symbolic::Expr::Sym(s));
/// ```
pub type Symbol = Arc<str>;

/// The functions of the model language.
///
/// ```
/// use fpsolve::symbolic::Func;
/// assert_eq!(Func::from_name("abs"), Some(Func::Abs));
/// assert_eq!(Func::Abs.name(), "abs");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Func {
    /// `abs(u)`, |u|.
    Abs,
    /// `sgn(u)`: −1, 0 or 1.
    Sgn,
    /// `delta(u)`: the Dirac delta, a distribution, never a pointwise value.
    Delta,
    /// `exp(u)`.
    Exp,
    /// `log(u)`, the natural logarithm.
    Log,
    /// `sqrt(u)`.
    Sqrt,
    /// `sin(u)`.
    Sin,
    /// `cos(u)`.
    Cos,
    /// `tanh(u)`.
    Tanh,
    /// `min(u, w)`.
    Min,
    /// `max(u, w)`.
    Max,
}

impl Func {
    /// Every function, in the order the documentation lists them.
    pub const ALL: [Func; 11] = [
        Func::Abs,
        Func::Sgn,
        Func::Delta,
        Func::Exp,
        Func::Log,
        Func::Sqrt,
        Func::Sin,
        Func::Cos,
        Func::Tanh,
        Func::Min,
        Func::Max,
    ];

    /// The name used in model files.
    ///
    /// ```
    /// use fpsolve::symbolic::Func;
    /// assert_eq!(Func::Sgn.name(), "sgn");
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Func::Abs => "abs",
            Func::Sgn => "sgn",
            Func::Delta => "delta",
            Func::Exp => "exp",
            Func::Log => "log",
            Func::Sqrt => "sqrt",
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tanh => "tanh",
            Func::Min => "min",
            Func::Max => "max",
        }
    }

    /// Looks a function up by its model-file name.
    ///
    /// ```
    /// use fpsolve::symbolic::Func;
    /// assert_eq!(Func::from_name("tanh"), Some(Func::Tanh));
    /// assert_eq!(Func::from_name("sinh"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == name)
    }

    /// How many arguments the function takes.
    ///
    /// ```
    /// use fpsolve::symbolic::Func;
    /// assert_eq!(Func::Max.arity(), 2);
    /// assert_eq!(Func::Abs.arity(), 1);
    /// ```
    pub fn arity(self) -> usize {
        match self {
            Func::Min | Func::Max => 2,
            _ => 1,
        }
    }

    /// Applies the function to numbers. `delta` has no pointwise value; see [`DeltaPolicy`].
    fn apply(self, args: &[f64], delta: DeltaPolicy) -> Result<f64, EvalError> {
        let u = args[0];
        Ok(match self {
            Func::Abs => u.abs(),
            Func::Sgn => sgn(u),
            Func::Delta => return delta.value(u),
            Func::Exp => u.exp(),
            Func::Log => u.ln(),
            Func::Sqrt => u.sqrt(),
            Func::Sin => u.sin(),
            Func::Cos => u.cos(),
            Func::Tanh => u.tanh(),
            Func::Min => u.min(args[1]),
            Func::Max => u.max(args[1]),
        })
    }
}

/// The sign function with `sgn(0) = 0`, as the paper's Eq. 24 uses it.
///
/// ```
/// assert_eq!(fpsolve::symbolic::sgn(-3.0), -1.0);
/// assert_eq!(fpsolve::symbolic::sgn(0.0), 0.0);
/// ```
#[inline]
pub fn sgn(u: f64) -> f64 {
    if u > 0.0 {
        1.0
    } else if u < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// What a pointwise evaluation does with `delta(u)`.
///
/// ```
/// use fpsolve::symbolic::{DeltaPolicy, Expr, Func};
/// let e = Expr::call(Func::Delta, Expr::sym("z"));
/// let z = ["z".into(), "v".into()];
/// assert_eq!(e.eval_states(&z, [1.0, 0.0], DeltaPolicy::Zero), Ok(0.0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum DeltaPolicy {
    /// Refuse: a Dirac delta has no value at a point.
    #[default]
    Reject,
    /// `delta(u) = 0`: right wherever `u ≠ 0`, as in a time-stepping simulation between impacts.
    Zero,
    /// A Gaussian of standard deviation `width` in place of the delta.
    Gaussian {
        /// The regulariser's standard deviation, > 0.
        width: f64,
    },
}

impl DeltaPolicy {
    /// The value that stands in for `delta(u)`.
    ///
    /// ```
    /// use fpsolve::symbolic::DeltaPolicy;
    /// let g = DeltaPolicy::Gaussian { width: 1.0 };
    /// assert!((g.value(0.0).unwrap() - 0.398942280401).abs() < 1e-9);
    /// assert!(DeltaPolicy::Reject.value(0.3).is_err());
    /// ```
    pub fn value(self, u: f64) -> Result<f64, EvalError> {
        match self {
            DeltaPolicy::Reject => Err(EvalError::Delta),
            DeltaPolicy::Zero => Ok(0.0),
            DeltaPolicy::Gaussian { width } => {
                let s = u / width;
                Ok((-0.5 * s * s).exp() / (width * (2.0 * std::f64::consts::PI).sqrt()))
            }
        }
    }
}

/// Why an expression could not be evaluated at a point.
///
/// ```
/// use fpsolve::symbolic::{EvalError, Expr};
/// assert_eq!(Expr::sym("k").eval(&|_| None), Err(EvalError::Unbound("k".into())));
/// ```
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EvalError {
    /// A symbol had no value.
    #[error("no value for `{0}`")]
    Unbound(Symbol),
    /// A Dirac delta was met under [`DeltaPolicy::Reject`].
    #[error("delta(...) has no pointwise value")]
    Delta,
}

/// A symbolic expression.
///
/// ```
/// use fpsolve::symbolic::Expr;
/// let e = Expr::sym("x") - Expr::num(1.0) / Expr::sym("y");
/// assert_eq!(e.to_string(), "x - 1/y");
/// let v = e.eval(&|s: &str| if s == "x" { Some(3.0) } else { Some(2.0) }).unwrap();
/// assert_eq!(v, 2.5);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    /// A number.
    Num(f64),
    /// A state variable, parameter or noise source, by name.
    Sym(Symbol),
    /// A sum of two or more terms.
    Add(Vec<Expr>),
    /// A product of two or more factors.
    Mul(Vec<Expr>),
    /// `base ^ exponent`.
    Pow(Box<Expr>, Box<Expr>),
    /// A function applied to as many arguments as its [`Func::arity`].
    Call(Func, Vec<Expr>),
}

impl Expr {
    /// A number.
    ///
    /// ```
    /// assert_eq!(fpsolve::symbolic::Expr::num(2.0).to_string(), "2");
    /// ```
    pub fn num(value: f64) -> Expr {
        Expr::Num(value)
    }

    /// A symbol.
    ///
    /// ```
    /// assert_eq!(fpsolve::symbolic::Expr::sym("mu").to_string(), "mu");
    /// ```
    pub fn sym(name: &str) -> Expr {
        Expr::Sym(Symbol::from(name))
    }

    /// `base ^ exponent`.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// assert_eq!(Expr::pow(Expr::sym("x"), Expr::num(3.0)).to_string(), "x^3");
    /// ```
    pub fn pow(base: Expr, exponent: Expr) -> Expr {
        Expr::Pow(Box::new(base), Box::new(exponent))
    }

    /// A call of a one-argument function.
    ///
    /// ```
    /// use fpsolve::symbolic::{Expr, Func};
    /// assert_eq!(Expr::call(Func::Abs, Expr::sym("v")).to_string(), "abs(v)");
    /// ```
    pub fn call(func: Func, arg: Expr) -> Expr {
        Expr::Call(func, vec![arg])
    }

    /// A sum of any number of terms: none is `0`, one is itself, nested sums are flattened.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// assert_eq!(Expr::sum(vec![]), Expr::num(0.0));
    /// assert_eq!(Expr::sum(vec![Expr::sym("x")]), Expr::sym("x"));
    /// ```
    pub fn sum(terms: Vec<Expr>) -> Expr {
        let mut flat = Vec::with_capacity(terms.len());
        for t in terms {
            match t {
                Expr::Add(inner) => flat.extend(inner),
                other => flat.push(other),
            }
        }
        match flat.len() {
            0 => Expr::Num(0.0),
            1 => flat.pop().expect("one term"),
            _ => Expr::Add(flat),
        }
    }

    /// A product of any number of factors: none is `1`, one is itself, nested products are
    /// flattened.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// assert_eq!(Expr::product(vec![]), Expr::num(1.0));
    /// ```
    pub fn product(factors: Vec<Expr>) -> Expr {
        let mut flat = Vec::with_capacity(factors.len());
        for f in factors {
            match f {
                Expr::Mul(inner) => flat.extend(inner),
                other => flat.push(other),
            }
        }
        match flat.len() {
            0 => Expr::Num(1.0),
            1 => flat.pop().expect("one factor"),
            _ => Expr::Mul(flat),
        }
    }

    /// The number this expression is, if it is one.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// assert_eq!(Expr::num(4.0).as_num(), Some(4.0));
    /// assert_eq!(Expr::sym("x").as_num(), None);
    /// ```
    pub fn as_num(&self) -> Option<f64> {
        match self {
            Expr::Num(v) => Some(*v),
            _ => None,
        }
    }

    /// Calls `visit` on every node, parents before children.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// let e = Expr::pow(Expr::sym("x"), Expr::num(2.0));
    /// let mut n = 0;
    /// e.walk(&mut |_| n += 1);
    /// assert_eq!(n, 3);
    /// ```
    pub fn walk(&self, visit: &mut dyn FnMut(&Expr)) {
        visit(self);
        match self {
            Expr::Num(_) | Expr::Sym(_) => {}
            Expr::Add(v) | Expr::Mul(v) | Expr::Call(_, v) => v.iter().for_each(|c| c.walk(visit)),
            Expr::Pow(b, e) => {
                b.walk(visit);
                e.walk(visit);
            }
        }
    }

    /// The symbols the expression mentions, sorted.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// let e = Expr::sym("k") * Expr::sym("z");
    /// let names: Vec<String> = e.symbols().iter().map(|s| s.to_string()).collect();
    /// assert_eq!(names, ["k", "z"]);
    /// ```
    pub fn symbols(&self) -> BTreeSet<Symbol> {
        let mut out = BTreeSet::new();
        self.walk(&mut |e| {
            if let Expr::Sym(s) = e {
                out.insert(s.clone());
            }
        });
        out
    }

    /// Whether the expression mentions symbol `name`.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// assert!(Expr::sym("z").mentions("z"));
    /// assert!(!Expr::num(1.0).mentions("z"));
    /// ```
    pub fn mentions(&self, name: &str) -> bool {
        let mut found = false;
        self.walk(&mut |e| {
            if matches!(e, Expr::Sym(s) if &**s == name) {
                found = true;
            }
        });
        found
    }

    /// Whether the expression contains a `delta(...)`.
    ///
    /// ```
    /// use fpsolve::symbolic::{Expr, Func};
    /// assert!(Expr::call(Func::Delta, Expr::sym("z")).contains_delta());
    /// ```
    pub fn contains_delta(&self) -> bool {
        let mut found = false;
        self.walk(&mut |e| {
            if matches!(e, Expr::Call(Func::Delta, _)) {
                found = true;
            }
        });
        found
    }

    /// Whether the expression has `min`, `max`, `abs` or `sgn`: a kink or a jump somewhere
    /// (every other function is analytic where defined).
    ///
    /// ```
    /// use fpsolve::symbolic::{Expr, Func};
    /// let z = Expr::sym("z");
    /// assert!(Expr::Call(Func::Max, vec![z.clone(), Expr::num(0.0)]).has_kink());
    /// assert!(!Expr::call(Func::Tanh, z).has_kink());
    /// ```
    pub fn has_kink(&self) -> bool {
        let mut found = false;
        self.walk(&mut |e| {
            if matches!(
                e,
                Expr::Call(Func::Min | Func::Max | Func::Abs | Func::Sgn, _)
            ) {
                found = true;
            }
        });
        found
    }

    /// The expression with every `delta(...)` replaced by 0 (no simplification): its regular
    /// part between impacts, and the classical derivative of `abs`/`sgn` away from their kinks
    /// once the distributional δ parts are dropped.
    ///
    /// ```
    /// use fpsolve::symbolic::{simplify, Expr, Func};
    /// let e = Expr::sym("v") + Expr::call(Func::Delta, Expr::sym("z"));
    /// assert_eq!(simplify(&e.without_deltas()), Expr::sym("v"));
    /// ```
    pub fn without_deltas(&self) -> Expr {
        match self {
            Expr::Call(Func::Delta, _) => Expr::num(0.0),
            Expr::Num(_) | Expr::Sym(_) => self.clone(),
            Expr::Add(v) => Expr::Add(v.iter().map(Expr::without_deltas).collect()),
            Expr::Mul(v) => Expr::Mul(v.iter().map(Expr::without_deltas).collect()),
            Expr::Pow(b, x) => Expr::pow(b.without_deltas(), x.without_deltas()),
            Expr::Call(f, a) => Expr::Call(*f, a.iter().map(Expr::without_deltas).collect()),
        }
    }

    /// Replaces every occurrence of symbol `name` by `value` (no simplification).
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// let e = (Expr::sym("k") * Expr::sym("z")).substitute("k", &Expr::num(2.0));
    /// assert_eq!(e.to_string(), "2*z");
    /// ```
    pub fn substitute(&self, name: &str, value: &Expr) -> Expr {
        self.map_symbols(&|s| (&**s == name).then(|| value.clone()))
    }

    /// Rebuilds the tree, replacing each symbol for which `f` returns `Some`.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// let e = Expr::sym("a") + Expr::sym("b");
    /// let e = e.map_symbols(&|s| (&**s == "a").then(|| Expr::num(1.0)));
    /// assert_eq!(e.to_string(), "1 + b");
    /// ```
    pub fn map_symbols(&self, f: &dyn Fn(&Symbol) -> Option<Expr>) -> Expr {
        match self {
            Expr::Num(_) => self.clone(),
            Expr::Sym(s) => f(s).unwrap_or_else(|| self.clone()),
            Expr::Add(v) => Expr::Add(v.iter().map(|c| c.map_symbols(f)).collect()),
            Expr::Mul(v) => Expr::Mul(v.iter().map(|c| c.map_symbols(f)).collect()),
            Expr::Call(func, v) => Expr::Call(*func, v.iter().map(|c| c.map_symbols(f)).collect()),
            Expr::Pow(b, e) => Expr::pow(b.map_symbols(f), e.map_symbols(f)),
        }
    }

    /// Evaluates by walking the tree; `delta(...)` is refused. For many points, compile the
    /// expression to a [`crate::symbolic::Tape`] instead.
    ///
    /// ```
    /// use fpsolve::symbolic::Expr;
    /// let e = Expr::pow(Expr::sym("x"), Expr::num(2.0));
    /// assert_eq!(e.eval(&|_| Some(3.0)).unwrap(), 9.0);
    /// ```
    pub fn eval(&self, lookup: &dyn Fn(&str) -> Option<f64>) -> Result<f64, EvalError> {
        self.eval_with(lookup, DeltaPolicy::Reject)
    }

    /// Evaluates by walking the tree, with `delta(...)` treated as `policy` says.
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Expr, Func};
    /// let e = Expr::call(Func::Delta, Expr::sym("z"));
    /// assert_eq!(e.eval_with(&|_| Some(0.5), DeltaPolicy::Zero).unwrap(), 0.0);
    /// ```
    pub fn eval_with(
        &self,
        lookup: &dyn Fn(&str) -> Option<f64>,
        policy: DeltaPolicy,
    ) -> Result<f64, EvalError> {
        Ok(match self {
            Expr::Num(v) => *v,
            Expr::Sym(s) => lookup(s).ok_or_else(|| EvalError::Unbound(s.clone()))?,
            Expr::Add(v) => {
                let mut acc = 0.0;
                for c in v {
                    acc += c.eval_with(lookup, policy)?;
                }
                acc
            }
            Expr::Mul(v) => {
                let mut acc = 1.0;
                for c in v {
                    acc *= c.eval_with(lookup, policy)?;
                }
                acc
            }
            Expr::Pow(b, e) => powf(b.eval_with(lookup, policy)?, e.eval_with(lookup, policy)?),
            Expr::Call(func, args) => {
                let mut vals = [0.0; 2];
                for (slot, a) in vals.iter_mut().zip(args) {
                    *slot = a.eval_with(lookup, policy)?;
                }
                func.apply(&vals[..args.len()], policy)?
            }
        })
    }

    /// Evaluates an expression of two named variables (the states) at `x`, by walking the
    /// tree; any other symbol is unbound.
    ///
    /// ```
    /// use fpsolve::symbolic::{DeltaPolicy, Expr};
    /// let e = Expr::sym("z") * Expr::sym("v");
    /// let v = e.eval_states(&["z".into(), "v".into()], [2.0, 3.0], DeltaPolicy::Reject);
    /// assert_eq!(v, Ok(6.0));
    /// ```
    pub fn eval_states(
        &self,
        states: &[Symbol; 2],
        x: [f64; 2],
        policy: DeltaPolicy,
    ) -> Result<f64, EvalError> {
        self.eval_with(
            &|s| {
                if s == &*states[0] {
                    Some(x[0])
                } else if s == &*states[1] {
                    Some(x[1])
                } else {
                    None
                }
            },
            policy,
        )
    }
}

/// `base^exponent` with integer exponents done by repeated multiplication, so that a negative
/// base with an integer exponent is exact and never NaN.
///
/// ```
/// assert_eq!(fpsolve::symbolic::powf(-2.0, 3.0), -8.0);
/// assert_eq!(fpsolve::symbolic::powf(4.0, 0.5), 2.0);
/// ```
#[inline]
pub fn powf(base: f64, exponent: f64) -> f64 {
    if exponent.fract() == 0.0 && exponent.abs() <= i32::MAX as f64 {
        base.powi(exponent as i32)
    } else {
        base.powf(exponent)
    }
}

impl std::ops::Add for Expr {
    type Output = Expr;
    /// `a + b`, flattening nested sums (no other simplification).
    fn add(self, rhs: Expr) -> Expr {
        Expr::sum(vec![self, rhs])
    }
}

impl std::ops::Sub for Expr {
    type Output = Expr;
    /// `a - b`, as `a + (-1)·b`.
    fn sub(self, rhs: Expr) -> Expr {
        self + (-rhs)
    }
}

impl std::ops::Mul for Expr {
    type Output = Expr;
    /// `a · b`, flattening nested products (no other simplification).
    fn mul(self, rhs: Expr) -> Expr {
        Expr::product(vec![self, rhs])
    }
}

impl std::ops::Div for Expr {
    type Output = Expr;
    /// `a / b`, as `a · b^(-1)`.
    fn div(self, rhs: Expr) -> Expr {
        self * Expr::pow(rhs, Expr::Num(-1.0))
    }
}

impl std::ops::Neg for Expr {
    type Output = Expr;
    /// `-a`: a negated number stays a number, anything else becomes `(-1)·a`.
    fn neg(self) -> Expr {
        match self {
            Expr::Num(v) => Expr::Num(-v),
            other => Expr::Num(-1.0) * other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn x() -> Expr {
        Expr::sym("x")
    }

    #[test]
    fn prints_with_minimal_parentheses() {
        let e = (x() + Expr::num(1.0)) * Expr::sym("y");
        assert_eq!(e.to_string(), "(x + 1)*y");
        let e = -Expr::pow(x(), Expr::num(2.0));
        assert_eq!(e.to_string(), "-x^2");
        let e = Expr::pow(Expr::num(-2.0), x());
        assert_eq!(e.to_string(), "(-2)^x");
        let e = Expr::pow(Expr::pow(x(), Expr::num(2.0)), Expr::num(3.0));
        assert_eq!(e.to_string(), "(x^2)^3");
        let e = Expr::pow(x(), Expr::pow(Expr::sym("y"), Expr::sym("z")));
        assert_eq!(e.to_string(), "x^y^z");
        let e = Expr::pow(x(), Expr::num(-1.0));
        assert_eq!(e.to_string(), "x^(-1)");
        let e = x() - Expr::num(2.0) * Expr::sym("y");
        assert_eq!(e.to_string(), "x - 2*y");
        let e = x() - (Expr::sym("y") - Expr::sym("z"));
        assert_eq!(e.to_string(), "x - (y - z)");
        let e = x() / (Expr::sym("y") * Expr::sym("z"));
        assert_eq!(e.to_string(), "x/(y*z)");
        let e = Expr::Add(vec![x(), Expr::Num(-0.5)]);
        assert_eq!(e.to_string(), "x - 0.5");
    }

    #[test]
    fn integer_powers_of_negative_bases_are_exact() {
        let e = Expr::pow(x(), Expr::num(3.0));
        assert_eq!(e.eval(&|_| Some(-2.0)).unwrap(), -8.0);
    }

    #[test]
    fn unbound_symbols_and_deltas_are_errors() {
        let e = x() + Expr::call(Func::Delta, x());
        assert_eq!(e.eval(&|_| None), Err(EvalError::Unbound("x".into())));
        assert_eq!(e.eval(&|_| Some(1.0)), Err(EvalError::Delta));
        assert_eq!(e.eval_with(&|_| Some(1.0), DeltaPolicy::Zero), Ok(1.0));
    }
}
