//! A [`Model`] printed back in model-file syntax.

use std::fmt;

use super::{DeltaTreatment, Interpretation, Model};
use crate::symbolic::Expr;

/// Prints the model as a model file that parses back to an equal [`Model`].
///
/// ```
/// let src = "model m\nparam k = 2\nstate x, v\ndrift x: v\ndrift v: -k*x\n\
///            noise w: intensity 1\ndiffusion v: (1 + x^2)*w\n";
/// let model = fpsolve::model::parse_model(src, None).unwrap();
/// let printed = model.to_string();
/// assert!(printed.contains("diffusion v: (1 + x^2)*w"));
/// assert_eq!(fpsolve::model::parse_model(&printed, None).unwrap(), model);
/// ```
impl fmt::Display for Model {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "model {}", self.name)?;
        if !self.description.is_empty() {
            write!(f, " \"{}\"", self.description)?;
        }
        writeln!(f)?;
        for p in &self.params {
            writeln!(f, "param {} = {}", p.name, p.default)?;
        }
        writeln!(f, "state {}, {}", self.states[0], self.states[1])?;
        for (s, d) in self.states.iter().zip(&self.drift) {
            writeln!(f, "drift {s}: {d}")?;
        }
        for n in &self.noises {
            writeln!(f, "noise {}: intensity {}", n.name, n.intensity)?;
        }
        for c in &self.correlations {
            writeln!(
                f,
                "correlate {}, {}: {}",
                self.noises[c.a].name, self.noises[c.b].name, c.coefficient
            )?;
        }
        for (s, row) in self.states.iter().zip(&self.noise_matrix) {
            let terms: Vec<String> = row
                .iter()
                .zip(&self.noises)
                .filter(|(g, _)| **g != Expr::num(0.0))
                .map(|(g, n)| noise_term(g, &n.name))
                .collect();
            if !terms.is_empty() {
                writeln!(f, "diffusion {s}: {}", terms.join(" + "))?;
            }
        }
        let interpretation = match self.interpretation {
            Interpretation::Stratonovich => "stratonovich",
            Interpretation::Ito => "ito",
        };
        writeln!(f, "interpretation: {interpretation}")?;
        for law in &self.impacts {
            writeln!(
                f,
                "impact {} = {}: {} -> {}",
                self.states[law.state], law.at, self.states[law.other], law.map
            )?;
        }
        if let Some(domain) = &self.domain {
            writeln!(f, "domain {}", domain.text(&self.states))?;
        }
        if let Some(p) = &self.periodic {
            writeln!(f, "domain {} periodic {}", self.states[p.state], p.period)?;
        }
        if !self.observables.is_empty() {
            let list: Vec<String> = self
                .observables
                .iter()
                .map(|o| format!("{} = {}", o.name, o.expr))
                .collect();
            writeln!(f, "observe {}", list.join(", "))?;
        }
        match self.delta {
            DeltaTreatment::Exact => writeln!(f, "delta: exact"),
            DeltaTreatment::Gaussian { width } => writeln!(f, "delta: gaussian({width:?})"),
        }
    }
}

/// `coefficient*noise`, parenthesising a sum so that the coefficient reads back whole.
fn noise_term(coefficient: &Expr, noise: &str) -> String {
    match coefficient {
        Expr::Num(v) if *v == 1.0 => noise.to_string(),
        Expr::Add(_) => format!("({coefficient})*{noise}"),
        _ => format!("{coefficient}*{noise}"),
    }
}
