//! How an [`Expr`] prints: the shortest text that parses back to the same tree, with
//! precedence-aware parentheses and fractions (`a - b/c`), numbers written so that they read
//! back exactly (`{:#}` rounds them for people instead).

use std::fmt;

use super::Expr;

/// Binding strength used by the printer: higher binds tighter.
fn precedence(e: &Expr) -> u8 {
    match e {
        Expr::Add(_) => 1,
        Expr::Mul(_) => 2,
        Expr::Num(v) if *v < 0.0 => 2,
        Expr::Pow(..) => 4,
        _ => 5,
    }
}

/// Splits a product into its leading sign, numerator factors and denominator factors
/// (`b^(-k)` factors go below the line as `b^k`).
fn split_fraction(factors: &[Expr]) -> (bool, Vec<Expr>, Vec<Expr>) {
    let mut negative = false;
    let mut num = Vec::new();
    let mut den = Vec::new();
    for f in factors {
        match f {
            Expr::Num(v) if *v == -1.0 => negative = !negative,
            Expr::Num(v) if *v < 0.0 => {
                negative = !negative;
                num.push(Expr::Num(-v));
            }
            Expr::Pow(b, e) if matches!(**e, Expr::Num(k) if k < 0.0) => {
                let k = -e.as_num().expect("number");
                den.push(if k == 1.0 {
                    (**b).clone()
                } else {
                    Expr::pow((**b).clone(), Expr::Num(k))
                });
            }
            other => num.push(other.clone()),
        }
    }
    (negative, num, den)
}

fn fmt_number(v: f64, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    if v.is_finite() && v.fract() == 0.0 && v.abs() < 1e15 {
        write!(f, "{}", v as i64)
    } else {
        if f.alternate() {
            // Readable: 12 significant digits, trailing zeros dropped (0.1*0.1 prints 0.01).
            let text = format!("{v:.11e}");
            let (mantissa, exponent) = text.split_once('e').expect("exponent form");
            let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
            let exponent: i32 = exponent.parse().expect("integer exponent");
            let value: f64 = format!("{mantissa}e{exponent}").parse().expect("number");
            if (-4..12).contains(&exponent) {
                write!(f, "{value}")
            } else {
                write!(f, "{mantissa}e{exponent}")
            }
        } else {
            // `{:?}` prints the shortest text that reads back to the same f64.
            write!(f, "{v:?}")
        }
    }
}

/// Prints a sub-expression, keeping the alternate (`{:#}`, readable numbers) flag.
fn fmt_child(e: &Expr, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    if f.alternate() {
        write!(f, "{e:#}")
    } else {
        write!(f, "{e}")
    }
}

fn fmt_operand(e: &Expr, min_prec: u8, f: &mut fmt::Formatter<'_>) -> fmt::Result {
    if precedence(e) < min_prec {
        f.write_str("(")?;
        fmt_child(e, f)?;
        f.write_str(")")
    } else {
        fmt_child(e, f)
    }
}

fn fmt_factors(factors: &[Expr], f: &mut fmt::Formatter<'_>) -> fmt::Result {
    for (i, x) in factors.iter().enumerate() {
        if i > 0 {
            f.write_str("*")?;
        }
        fmt_operand(x, 3, f)?;
    }
    Ok(())
}

/// `{}` prints numbers so that they read back exactly; `{:#}` prints them with 12 significant
/// digits, for people (`0.1*0.1` folded shows as `0.01`).
impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expr::Num(v) => fmt_number(*v, f),
            Expr::Sym(s) => f.write_str(s),
            Expr::Add(terms) => {
                for (i, t) in terms.iter().enumerate() {
                    let (negative, body) = match t {
                        Expr::Num(v) if *v < 0.0 && i > 0 => (true, Expr::Num(-v)),
                        Expr::Mul(fs) if i > 0 => {
                            let (neg, num, den) = split_fraction(fs);
                            if neg {
                                (true, Expr::product(unsplit(num, den)))
                            } else {
                                (false, t.clone())
                            }
                        }
                        _ => (false, t.clone()),
                    };
                    if i > 0 {
                        f.write_str(if negative { " - " } else { " + " })?;
                    }
                    // A sum inside a sum (not canonical, but printable) needs parentheses.
                    fmt_operand(&body, 2, f)?;
                }
                Ok(())
            }
            Expr::Mul(factors) => {
                let (negative, num, den) = split_fraction(factors);
                if negative {
                    f.write_str("-")?;
                }
                if num.is_empty() {
                    f.write_str("1")?;
                } else {
                    fmt_factors(&num, f)?;
                }
                if !den.is_empty() {
                    f.write_str("/")?;
                    if den.len() == 1 && precedence(&den[0]) > 3 {
                        fmt_child(&den[0], f)?;
                    } else if den.len() == 1 {
                        f.write_str("(")?;
                        fmt_child(&den[0], f)?;
                        f.write_str(")")?;
                    } else {
                        // One product below the line, flattened: a denominator factor that
                        // is itself a product (`a/b/(c*d)`) prints as `a/(b*c*d)`, the text
                        // the parser reads back as one flat product.
                        f.write_str("(")?;
                        fmt_child(&Expr::product(den), f)?;
                        f.write_str(")")?;
                    }
                }
                Ok(())
            }
            Expr::Pow(b, e) => {
                // `^` is right-associative and binds tighter than unary minus: (a^b)^c and
                // (-2)^x need parentheses on the left, a^(b^c) does not on the right.
                fmt_operand(b, 5, f)?;
                f.write_str("^")?;
                match &**e {
                    Expr::Num(v) if *v < 0.0 => {
                        f.write_str("(")?;
                        fmt_number(*v, f)?;
                        f.write_str(")")
                    }
                    other => fmt_operand(other, 4, f),
                }
            }
            Expr::Call(func, args) => {
                write!(f, "{}(", func.name())?;
                for (i, a) in args.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    fmt_child(a, f)?;
                }
                f.write_str(")")
            }
        }
    }
}

/// Puts a split fraction back together as a product (used to print `a - b/c`).
fn unsplit(num: Vec<Expr>, den: Vec<Expr>) -> Vec<Expr> {
    let mut out = num;
    for d in den {
        out.push(match d {
            Expr::Pow(b, e) => Expr::pow(*b, -*e),
            other => Expr::pow(other, Expr::Num(-1.0)),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inverse(e: Expr) -> Expr {
        Expr::pow(e, Expr::num(-1.0))
    }

    /// `a/b/(c*d)` built with a product below a product (as division builds it) prints as
    /// the flat `a/(b*c*d)`, the same text as the flat tree the parser makes of that text:
    /// printing then reparsing is a fixed point (the fuzz test's `0/(0.01*(2*pi))` case).
    #[test]
    fn a_product_in_a_denominator_prints_flat() {
        let (a, b, c, d) = (
            Expr::sym("a"),
            Expr::sym("b"),
            Expr::sym("c"),
            Expr::sym("d"),
        );
        let nested = Expr::Mul(vec![
            a.clone(),
            inverse(b.clone()),
            inverse(Expr::product(vec![c.clone(), d.clone()])),
        ]);
        let flat = Expr::Mul(vec![a, inverse(Expr::product(vec![b, c, d]))]);
        assert_eq!(nested.to_string(), "a/(b*c*d)");
        assert_eq!(flat.to_string(), "a/(b*c*d)");
    }

    /// A power of a product below the line keeps its parentheses.
    #[test]
    fn a_power_of_a_product_in_a_denominator_keeps_its_parentheses() {
        let (a, b) = (Expr::sym("a"), Expr::sym("b"));
        let two_pi = Expr::product(vec![Expr::num(2.0), Expr::sym("pi")]);
        let e = Expr::Mul(vec![a, inverse(b), Expr::pow(two_pi, Expr::num(-2.0))]);
        assert_eq!(e.to_string(), "a/(b*(2*pi)^2)");
    }
}
