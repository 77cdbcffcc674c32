//! Text → [`ModelAst`]: limits checked first, then pest, then a Pratt parser for precedence.
//!
//! pest and the Pratt parser are recursive, and so is every later stage that walks the tree.
//! [`check_limits`] therefore bounds the nesting of each line *before* parsing: parentheses,
//! `^` chains (right-associative) and unary minus are the only constructs whose depth grows
//! the tree, because sums and products are kept n-ary (see [`super::ast`]).

use pest::iterators::Pair;
use pest::pratt_parser::{Assoc, Op, PrattParser};
use pest::Parser;

use super::ast::{
    Binding, DeltaSpec, DomainLimit, ExprKind, ExprNode, Ident, InitialAst, ModelAst, ProductOp,
    SafeSpec, Span, Statement, StatementKind, SumOp,
};
use super::syntax::{Rule, SdeParser, SyntaxFailure};
use super::Interpretation;

/// Deepest nesting of parentheses, `^` and unary minus accepted in one line.
///
/// ```
/// let deep = format!("{}1{}", "(".repeat(300), ")".repeat(300));
/// assert!(deep.len() > fpsolve::model::MAX_NESTING);
/// assert!(fpsolve::model::parse_expr(&deep).is_err());
/// ```
pub const MAX_NESTING: usize = 200;
/// Longest line accepted, in bytes.
///
/// ```
/// let long = "1+".repeat(fpsolve::model::MAX_LINE_BYTES) + "1";
/// assert!(fpsolve::model::parse_expr(&long).is_err());
/// ```
pub const MAX_LINE_BYTES: usize = 65_536;
/// Largest model source accepted, in bytes.
///
/// ```
/// let huge = " ".repeat(fpsolve::model::MAX_SOURCE_BYTES + 1);
/// let err = fpsolve::model::parse_model(&huge, None).unwrap_err();
/// assert!(matches!(err, fpsolve::model::ModelError::TooLarge { .. }));
/// ```
pub const MAX_SOURCE_BYTES: usize = 1 << 20;

/// Rejects inputs whose parse tree would be deeper than [`MAX_NESTING`] or whose lines are
/// longer than [`MAX_LINE_BYTES`], pointing at the first place the limit is exceeded.
pub(crate) fn check_limits(source: &str) -> Result<(), SyntaxFailure> {
    let mut offset = 0;
    for line in source.split('\n') {
        if line.len() > MAX_LINE_BYTES {
            let first = line.chars().next().map_or(1, char::len_utf8);
            return Err(SyntaxFailure {
                span: Span::new(offset, offset + first),
                message: format!(
                    "line is too long ({} bytes; the limit is {MAX_LINE_BYTES})",
                    line.len()
                ),
            });
        }
        check_line_nesting(line, offset)?;
        offset += line.len() + 1;
    }
    Ok(())
}

/// Tracks, per open parenthesis level, how many `^` and unary minus operators have been seen
/// since the level opened (or since the last `,` `:` `=` at that level, which start a new
/// expression). Their sum plus the number of open levels bounds the tree depth from above.
fn check_line_nesting(line: &str, offset: usize) -> Result<(), SyntaxFailure> {
    let mut levels: Vec<usize> = vec![0];
    let mut depth = 1usize;
    let mut previous: Option<char> = None;
    let mut in_string = false;
    for (i, c) in line.char_indices() {
        if in_string {
            in_string = c != '"';
            continue;
        }
        let top = levels.len() - 1;
        match c {
            '#' => break,
            '"' => in_string = true,
            '(' => {
                levels.push(0);
                depth += 1;
            }
            ')' if levels.len() > 1 => {
                depth -= 1 + levels.pop().unwrap_or(0);
            }
            ',' | ':' | '=' => {
                depth -= levels[top];
                levels[top] = 0;
            }
            '^' => {
                levels[top] += 1;
                depth += 1;
            }
            '-' if matches!(
                previous,
                None | Some('(' | ',' | ':' | '=' | '+' | '-' | '*' | '/' | '^' | '>')
            ) =>
            {
                levels[top] += 1;
                depth += 1;
            }
            _ => {}
        }
        if depth > MAX_NESTING {
            return Err(SyntaxFailure {
                span: Span::new(offset + i, offset + i + c.len_utf8()),
                message: format!(
                    "expression nested too deeply (more than {MAX_NESTING} levels of \
                     parentheses, `^` and unary minus)"
                ),
            });
        }
        if !c.is_whitespace() {
            previous = Some(c);
        }
    }
    Ok(())
}

/// Parses a whole model file into its syntax tree.
pub(crate) fn parse_file(source: &str) -> Result<ModelAst, SyntaxFailure> {
    check_limits(source)?;
    let pairs = SdeParser::parse(Rule::file, source).map_err(SyntaxFailure::from_pest)?;
    let mut statements = Vec::new();
    for pair in pairs {
        if pair.as_rule() == Rule::statement {
            if let Some(inner) = pair.into_inner().next() {
                statements.push(build_statement(inner));
            }
        }
    }
    Ok(ModelAst { statements })
}

/// Parses a lone expression (a `--set` value).
pub(crate) fn parse_lone_expr(source: &str) -> Result<ExprNode, SyntaxFailure> {
    check_limits(source)?;
    let mut pairs = SdeParser::parse(Rule::lone_expr, source).map_err(SyntaxFailure::from_pest)?;
    let expr = pairs.find(|p| p.as_rule() == Rule::expr);
    match expr {
        Some(e) => Ok(build_expr(e)),
        // The grammar makes this unreachable; an error is still better than a panic.
        None => Err(SyntaxFailure {
            span: Span::new(0, 0),
            message: "expected an expression".into(),
        }),
    }
}

fn span_of(pair: &Pair<'_, Rule>) -> Span {
    let s = pair.as_span();
    Span::new(s.start(), s.end())
}

fn ident(pair: Pair<'_, Rule>) -> Ident {
    Ident {
        span: span_of(&pair),
        name: pair.as_str().to_string(),
    }
}

/// The children of a statement that carry content (keywords and punctuation dropped).
fn content(pair: Pair<'_, Rule>) -> impl Iterator<Item = Pair<'_, Rule>> {
    pair.into_inner().filter(|p| {
        !matches!(
            p.as_rule(),
            Rule::colon
                | Rule::comma
                | Rule::equals
                | Rule::arrow
                | Rule::lparen
                | Rule::rparen
                | Rule::kw_model
                | Rule::kw_param
                | Rule::kw_state
                | Rule::kw_drift
                | Rule::kw_noise
                | Rule::kw_intensity
                | Rule::kw_correlate
                | Rule::kw_diffusion
                | Rule::kw_interpretation
                | Rule::kw_impact
                | Rule::kw_observe
                | Rule::kw_domain
                | Rule::kw_periodic
                | Rule::kw_delta
                | Rule::kw_gaussian
                | Rule::kw_safe
                | Rule::kw_initial
                | Rule::kw_point
                | Rule::kw_start_gaussian
                | Rule::kw_mean
                | Rule::kw_cov
        )
    })
}

/// The content children of a statement, in order. The grammar fixes their number and kind,
/// so a missing one is a bug in this file, not a user error.
struct Parts<'i> {
    pairs: std::vec::IntoIter<Pair<'i, Rule>>,
}

impl<'i> Parts<'i> {
    fn new(pair: Pair<'i, Rule>) -> Parts<'i> {
        Parts {
            pairs: content(pair).collect::<Vec<_>>().into_iter(),
        }
    }

    fn next(&mut self) -> Pair<'i, Rule> {
        self.pairs
            .next()
            .expect("the grammar guarantees every part of a statement")
    }

    fn ident(&mut self) -> Ident {
        ident(self.next())
    }

    fn expr(&mut self) -> ExprNode {
        build_expr(self.next())
    }

    fn rest(self) -> std::vec::IntoIter<Pair<'i, Rule>> {
        self.pairs
    }
}

fn build_statement(pair: Pair<'_, Rule>) -> Statement {
    let span = span_of(&pair);
    let keyword = pair
        .clone()
        .into_inner()
        .next()
        .map_or(span, |k| span_of(&k));
    let rule = pair.as_rule();
    let mut parts = Parts::new(pair);
    let kind = match rule {
        Rule::model_stmt => {
            let name = parts.ident();
            let description = parts
                .rest()
                .next()
                .map(|d| {
                    let s = d.as_str();
                    s[1..s.len() - 1].to_string()
                })
                .unwrap_or_default();
            StatementKind::Model { name, description }
        }
        Rule::param_stmt => StatementKind::Param(parts.rest().map(build_binding).collect()),
        Rule::observe_stmt => StatementKind::Observe(parts.rest().map(build_binding).collect()),
        Rule::state_stmt => StatementKind::State(parts.rest().map(ident).collect()),
        Rule::drift_stmt => StatementKind::Drift {
            state: parts.ident(),
            expr: parts.expr(),
        },
        Rule::noise_stmt => StatementKind::Noise {
            name: parts.ident(),
            intensity: parts.expr(),
        },
        Rule::correlate_stmt => StatementKind::Correlate {
            a: parts.ident(),
            b: parts.ident(),
            coefficient: parts.expr(),
        },
        Rule::diffusion_stmt => StatementKind::Diffusion {
            state: parts.ident(),
            expr: parts.expr(),
        },
        Rule::interpretation_stmt => StatementKind::Interpretation(match parts.next().as_rule() {
            Rule::ito => Interpretation::Ito,
            _ => Interpretation::Stratonovich,
        }),
        Rule::impact_stmt => StatementKind::Impact {
            state: parts.ident(),
            at: parts.expr(),
            other: parts.ident(),
            map: parts.expr(),
        },
        Rule::domain_stmt => build_domain(parts.next()),
        Rule::safe_stmt => StatementKind::Safe(build_safe(parts.next())),
        Rule::initial_stmt => StatementKind::Initial(build_initial(parts.next())),
        _ => {
            let spec = parts.next();
            StatementKind::Delta(match spec.as_rule() {
                Rule::gaussian => DeltaSpec::Gaussian(Parts::new(spec).expr()),
                _ => DeltaSpec::Exact,
            })
        }
    };
    Statement {
        kind,
        span,
        keyword,
    }
}

/// `rest`, `point BINDINGS` or `gaussian mean BINDINGS cov ENTRIES`.
fn build_initial(pair: Pair<'_, Rule>) -> InitialAst {
    match pair.as_rule() {
        Rule::initial_point => {
            InitialAst::Point(Parts::new(pair).rest().map(build_binding).collect())
        }
        Rule::initial_gaussian => {
            let (mut mean, mut covariance) = (Vec::new(), Vec::new());
            for part in Parts::new(pair).rest() {
                match part.as_rule() {
                    Rule::binding => mean.push(build_binding(part)),
                    _ => covariance.push(build_expr(part)),
                }
            }
            let span = match (covariance.first(), covariance.last()) {
                (Some(a), Some(b)) => a.span.to(b.span),
                _ => Span::new(0, 0),
            };
            InitialAst::Gaussian {
                mean,
                covariance,
                span,
            }
        }
        _ => InitialAst::Rest,
    }
}

/// `safe LOW < q < HIGH`, `safe q < HIGH` or `safe q > LOW`.
fn build_safe(pair: Pair<'_, Rule>) -> SafeSpec {
    let range = pair.as_rule() == Rule::safe_range;
    let mut parts: Vec<Pair<'_, Rule>> = pair.into_inner().collect();
    let limit = |op: &Pair<'_, Rule>, at: Pair<'_, Rule>| DomainLimit {
        strict: !op.as_str().ends_with('='),
        at: build_expr(at),
    };
    let at = parts.pop().expect("the grammar's bound");
    let op = parts.pop().expect("the grammar's comparison");
    let quantity = build_expr(parts.pop().expect("the grammar's quantity"));
    let bound = Some(limit(&op, at));
    if range {
        let lower_op = parts.pop().expect("the grammar's `<`");
        let lower_at = parts.pop().expect("the grammar's lower bound");
        return SafeSpec {
            quantity,
            lower: Some(limit(&lower_op, lower_at)),
            upper: bound,
        };
    }
    let (lower, upper) = match op.as_rule() {
        Rule::above => (bound, None),
        _ => (None, bound),
    };
    SafeSpec {
        quantity,
        lower,
        upper,
    }
}

/// Parses a lone initial state (an `--initial` value).
pub(crate) fn parse_lone_initial(source: &str) -> Result<InitialAst, SyntaxFailure> {
    check_limits(source)?;
    let pairs = SdeParser::parse(Rule::lone_initial, source).map_err(SyntaxFailure::from_pest)?;
    match pairs.into_iter().find(|p| {
        matches!(
            p.as_rule(),
            Rule::kw_rest | Rule::initial_point | Rule::initial_gaussian
        )
    }) {
        Some(p) => Ok(build_initial(p)),
        // The grammar makes this unreachable; an error is still better than a panic.
        None => Err(SyntaxFailure {
            span: Span::new(0, 0),
            message: "expected an initial state".into(),
        }),
    }
}

/// Parses a lone safe set (a `--safe` value).
pub(crate) fn parse_lone_safe(source: &str) -> Result<SafeSpec, SyntaxFailure> {
    check_limits(source)?;
    let pairs = SdeParser::parse(Rule::lone_safe, source).map_err(SyntaxFailure::from_pest)?;
    match pairs
        .into_iter()
        .find(|p| matches!(p.as_rule(), Rule::safe_range | Rule::safe_bound))
    {
        Some(p) => Ok(build_safe(p)),
        // The grammar makes this unreachable; an error is still better than a panic.
        None => Err(SyntaxFailure {
            span: Span::new(0, 0),
            message: "expected a safe set".into(),
        }),
    }
}

/// `domain a <= y <= b` or `domain y >= a` / `domain y <= b`.
fn build_domain(pair: Pair<'_, Rule>) -> StatementKind {
    if pair.as_rule() == Rule::domain_periodic {
        let mut parts = Parts::new(pair);
        let state = parts.ident();
        return StatementKind::Periodic {
            state,
            period: parts.expr(),
        };
    }
    let range = pair.as_rule() == Rule::domain_range;
    let mut parts: Vec<Pair<'_, Rule>> = pair.into_inner().collect();
    let limit = |op: &Pair<'_, Rule>, at: Pair<'_, Rule>| DomainLimit {
        strict: !op.as_str().ends_with('='),
        at: build_expr(at),
    };
    if range {
        let upper_at = parts.pop().expect("the grammar's upper bound");
        let upper_op = parts.pop().expect("the grammar's `<=`");
        let state = ident(parts.pop().expect("the grammar's state"));
        let lower_op = parts.pop().expect("the grammar's `<=`");
        let lower_at = parts.pop().expect("the grammar's lower bound");
        return StatementKind::Domain {
            state,
            lower: Some(limit(&lower_op, lower_at)),
            upper: Some(limit(&upper_op, upper_at)),
        };
    }
    let at = parts.pop().expect("the grammar's bound");
    let op = parts.pop().expect("the grammar's comparison");
    let state = ident(parts.pop().expect("the grammar's state"));
    let bound = Some(limit(&op, at));
    if op.as_rule() == Rule::above {
        StatementKind::Domain {
            state,
            lower: bound,
            upper: None,
        }
    } else {
        StatementKind::Domain {
            state,
            lower: None,
            upper: bound,
        }
    }
}

fn build_binding(pair: Pair<'_, Rule>) -> Binding {
    let mut parts = Parts::new(pair);
    Binding {
        name: parts.ident(),
        value: parts.expr(),
    }
}

fn pratt() -> PrattParser<Rule> {
    PrattParser::new()
        .op(Op::infix(Rule::add, Assoc::Left) | Op::infix(Rule::sub, Assoc::Left))
        .op(Op::infix(Rule::mul, Assoc::Left) | Op::infix(Rule::div, Assoc::Left))
        .op(Op::prefix(Rule::neg))
        .op(Op::infix(Rule::pow, Assoc::Right))
}

/// Builds an expression node from an `expr` pair.
pub(crate) fn build_expr(pair: Pair<'_, Rule>) -> ExprNode {
    let pratt = pratt();
    build_expr_with(&pratt, pair)
}

fn build_expr_with(pratt: &PrattParser<Rule>, pair: Pair<'_, Rule>) -> ExprNode {
    // The grammar keeps `neg* primary` in an `operand` rule so that a missing operand is
    // reported as "expected an expression"; the Pratt parser wants the flat sequence.
    let flat: Vec<Pair<'_, Rule>> = pair
        .into_inner()
        .flat_map(|p| {
            if p.as_rule() == Rule::operand {
                p.into_inner().collect::<Vec<_>>()
            } else {
                vec![p]
            }
        })
        .collect();
    pratt
        .map_primary(|p| build_primary(pratt, p))
        .map_prefix(|op, rhs| ExprNode {
            span: span_of(&op).to(rhs.span),
            kind: ExprKind::Neg(Box::new(rhs)),
        })
        .map_infix(|lhs, op, rhs| {
            let span = lhs.span.to(rhs.span);
            let kind = match op.as_rule() {
                Rule::add | Rule::sub => {
                    let sign = if op.as_rule() == Rule::add {
                        SumOp::Plus
                    } else {
                        SumOp::Minus
                    };
                    // Left-associative chains stay one n-ary node: the tree's height must not
                    // grow with the number of terms.
                    let mut terms = match lhs.kind {
                        ExprKind::Sum(t) => t,
                        _ => vec![(SumOp::Plus, lhs)],
                    };
                    terms.push((sign, rhs));
                    ExprKind::Sum(terms)
                }
                Rule::mul | Rule::div => {
                    let o = if op.as_rule() == Rule::mul {
                        ProductOp::Times
                    } else {
                        ProductOp::Divide
                    };
                    let mut factors = match lhs.kind {
                        ExprKind::Product(f) => f,
                        _ => vec![(ProductOp::Times, lhs)],
                    };
                    factors.push((o, rhs));
                    ExprKind::Product(factors)
                }
                _ => ExprKind::Pow(Box::new(lhs), Box::new(rhs)),
            };
            ExprNode { kind, span }
        })
        .parse(flat.into_iter())
}

fn build_primary(pratt: &PrattParser<Rule>, pair: Pair<'_, Rule>) -> ExprNode {
    let span = span_of(&pair);
    let kind = match pair.as_rule() {
        Rule::paren => {
            let inner = content(pair).next();
            return build_expr_with(pratt, inner.expect("the grammar guarantees `( expr )`"));
        }
        Rule::call => {
            let mut it = content(pair);
            let func = ident(it.next().expect("the grammar guarantees a function name"));
            let args = it.map(|e| build_expr_with(pratt, e)).collect();
            ExprKind::Call { func, args }
        }
        Rule::number => match pair.as_str().parse::<f64>() {
            Ok(v) if v.is_finite() => ExprKind::Number(v),
            _ => ExprKind::MalformedNumber(pair.as_str().to_string()),
        },
        Rule::malformed_number => ExprKind::MalformedNumber(pair.as_str().to_string()),
        _ => ExprKind::Name(pair.as_str().to_string()),
    };
    ExprNode { kind, span }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_expr;
    use crate::symbolic::Expr;

    fn eval(src: &str, vars: &[(&str, f64)]) -> f64 {
        let e = parse_expr(src).unwrap();
        e.eval(&|s| vars.iter().find(|(n, _)| *n == s).map(|(_, v)| *v))
            .unwrap()
    }

    fn x() -> Expr {
        Expr::sym("x")
    }

    #[test]
    fn power_binds_tighter_than_unary_minus() {
        let e = parse_expr("-x^2").unwrap();
        assert_eq!(e, -Expr::pow(x(), Expr::num(2.0)));
        assert_eq!(eval("-x^2", &[("x", 3.0)]), -9.0);
    }

    #[test]
    fn unary_minus_is_allowed_right_after_power() {
        assert_eq!(
            parse_expr("2^-1").unwrap(),
            Expr::pow(Expr::num(2.0), Expr::num(-1.0))
        );
        assert_eq!(eval("2^-x*3", &[("x", 1.0)]), 1.5);
    }

    #[test]
    fn subtraction_and_division_are_left_associative() {
        let vars = [("a", 1.0), ("b", 2.0), ("c", 3.0)];
        assert_eq!(eval("a-b-c", &vars), -4.0);
        assert_eq!(eval("a-(b-c)", &vars), 2.0);
        assert_eq!(eval("c/b/a/2", &vars), 0.75);
        let node = parse_lone_expr("a-b-c").unwrap();
        let ExprKind::Sum(terms) = node.kind else {
            panic!("a-b-c is one sum node")
        };
        let ops: Vec<SumOp> = terms.iter().map(|t| t.0).collect();
        assert_eq!(ops, [SumOp::Plus, SumOp::Minus, SumOp::Minus]);
    }

    #[test]
    fn power_is_right_associative() {
        assert_eq!(
            parse_expr("x^y^z").unwrap(),
            Expr::pow(x(), Expr::pow(Expr::sym("y"), Expr::sym("z")))
        );
        assert_eq!(eval("2^3^2", &[]), 512.0);
    }

    #[test]
    fn numbers_in_every_accepted_form() {
        for (text, value) in [
            ("1", 1.0),
            ("0.5", 0.5),
            (".5", 0.5),
            ("1e-3", 1e-3),
            ("2.5E+4", 2.5e4),
            ("7.", 7.0),
        ] {
            assert_eq!(eval(text, &[]), value, "{text}");
        }
        assert_eq!(eval("pi", &[]), std::f64::consts::PI);
        assert_eq!(eval("e", &[]), std::f64::consts::E);
    }

    #[test]
    fn spans_cover_what_was_written() {
        let node = parse_lone_expr("  abs(v) * 2").unwrap();
        assert_eq!(node.span, Span::new(2, 12));
        let ExprKind::Product(f) = node.kind else {
            panic!("a product")
        };
        assert_eq!(f[0].1.span, Span::new(2, 8));
        assert_eq!(f[1].1.span, Span::new(11, 12));
    }

    #[test]
    fn nesting_is_bounded_before_parsing() {
        let ok = format!("{}x{}", "(".repeat(150), ")".repeat(150));
        assert!(check_limits(&ok).is_ok());
        let deep = format!("{}x{}", "(".repeat(10_000), ")".repeat(10_000));
        let err = check_limits(&deep).unwrap_err();
        assert!(err.message.contains("nested too deeply"), "{}", err.message);
        // The 200th `(` opens level 201, counting the top level.
        assert_eq!(err.span.start, MAX_NESTING - 1);
        let minus = format!("x = {}1", "-".repeat(300));
        assert!(check_limits(&minus).is_err());
        let power = format!("x = 2{}", "^2".repeat(300));
        assert!(check_limits(&power).is_err());
        // Binary minus and long sums do not deepen the tree.
        let sum = format!("x = 1{}", "-1".repeat(5000));
        assert!(check_limits(&sum).is_ok());
        assert!(parse_lone_expr(&sum[4..]).is_ok());
        // Parentheses inside a comment or the description do not count.
        let comment = format!("model m \"{}\" # {}", "(".repeat(300), "(".repeat(300));
        assert!(check_limits(&comment).is_ok());
    }

    #[test]
    fn the_deepest_accepted_nesting_parses_on_a_small_stack() {
        let depth = MAX_NESTING - 1;
        let src = format!("{}x{}", "(".repeat(depth), ")".repeat(depth));
        // Test threads have small stacks; 1 MiB is half the default.
        let handle = std::thread::Builder::new()
            .stack_size(1 << 20)
            .spawn(move || parse_expr(&src).map(|e| e.to_string()))
            .unwrap();
        assert_eq!(handle.join().unwrap().unwrap(), "x");
    }

    #[test]
    fn long_lines_are_rejected() {
        let line = format!("# {}", "x".repeat(MAX_LINE_BYTES));
        let err = check_limits(&line).unwrap_err();
        assert!(err.message.contains("too long"));
        assert_eq!(err.span.start, 0);
    }

    #[test]
    fn syntax_errors_name_what_was_expected() {
        let msg = |src: &str| parse_file(src).unwrap_err().message;
        assert_eq!(msg("drift v -c*v"), "expected `:`");
        assert_eq!(msg("drift v: x**2"), "expected an expression");
        assert_eq!(msg("drift v: (x + 1"), "expected an operator or `)`");
        assert_eq!(msg("drift v: x +"), "expected an expression");
        assert_eq!(msg("drift v: x y"), "expected an operator or end of line");
        assert!(msg("foo bar").starts_with("expected a statement (model, param"));
        assert_eq!(
            msg("param a = 1 b = 2"),
            "expected an operator, `,`, or end of line"
        );
        assert_eq!(
            msg("interpretation: itoh"),
            "expected `stratonovich` or `ito`"
        );
    }

    #[test]
    fn a_comment_takes_every_character_to_the_end_of_its_line() {
        let model = |src: &str| crate::model::parse_model(src, None).map(|m| m.to_string());
        let lines = [
            "model m",
            "state z, v",
            "drift z: v",
            "drift v: -v - z",
            "noise xi: intensity 2",
        ];
        let plain = model(&(lines.join("\n") + "\ndiffusion v: xi\n")).unwrap();
        // Every character but a line break: `\u{b}` and `\u{c}` between `\n` and `\r`, the
        // last char, quotes and `#`; `\r`, `\r\n` and `\n` each end a comment.
        let odd = "\u{0}\u{1}\t\u{b}\u{c}\u{e}\u{7f}é中\u{10ffff}#\"";
        for end in ["\n", "\r\n", "\r"] {
            let src = format!(
                "# {odd}{end}{} # {odd}{end}diffusion v: xi #",
                lines.join(&format!(" #{odd}{end}"))
            );
            assert_eq!(model(&src).unwrap(), plain, "{end:?}");
        }
        // What follows a line break is not the comment's.
        let err = parse_file("state z # a\rdrift z -z\n").unwrap_err();
        assert_eq!(err.message, "expected `:`");
    }
}
