//! The grid's box as `--domain x=a:b,v=c:d` gives it: parsed and checked (finite, a < b)
//! before any work; the model's walls are checked against it by the solver.

use std::str::FromStr;

use super::mesh::Domain;

/// Why a `--domain` value is refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DomainError {
    /// Not two `NAME=LO:HI` ranges separated by a comma.
    #[error("`{text}` is not x=LO:HI,v=LO:HI (the position's range, then the velocity's)")]
    Syntax {
        /// The text given.
        text: String,
    },
    /// A name that is neither the position (`x` or the model's first state) nor the
    /// velocity (`v` or the second), or one named twice.
    #[error("`{name}` in `{text}` is not one of {position}/x (position) and {velocity}/v (velocity), each once")]
    Name {
        /// The name given.
        name: String,
        /// The whole text.
        text: String,
        /// The model's position.
        position: String,
        /// The model's velocity.
        velocity: String,
    },
    /// A range that is not finite or not increasing.
    #[error("`{name}={lo}:{hi}`: {expected}")]
    Range {
        /// The state.
        name: String,
        /// The lower end given.
        lo: f64,
        /// The upper end given.
        hi: f64,
        /// What is accepted.
        expected: &'static str,
    },
}

impl Domain {
    /// Parses `x=a:b,v=c:d` (either order; `x` and `v` or the model's own state names
    /// `position`, `velocity`): finite ends, a < b, c < d. Whether the box suits the model
    /// (a mechanical form's velocity range holds 0; the walls) is the solver's check,
    /// [`GridSolver::check`](super::GridSolver::check), which knows the model's form.
    ///
    /// ```
    /// use fpsolve::grid::{Domain, DomainError};
    /// let d = Domain::parse_named("ydot=-12:12,y=0:8", ["y", "ydot"])?;
    /// assert_eq!(d, Domain { x: [0.0, 8.0], v: [-12.0, 12.0] });
    /// assert!(matches!(Domain::parse_named("y=3:1,v=-1:1", ["y", "ydot"]), Err(DomainError::Range { .. })));
    /// assert!(matches!(Domain::parse_named("q=0:1,v=-1:1", ["y", "ydot"]), Err(DomainError::Name { .. })));
    /// # Ok::<(), DomainError>(())
    /// ```
    ///
    /// # Errors
    /// [`DomainError`] saying what is wrong.
    pub fn parse_named(text: &str, [position, velocity]: [&str; 2]) -> Result<Domain, DomainError> {
        let syntax = || DomainError::Syntax {
            text: text.to_string(),
        };
        let (a, b) = text.split_once(',').ok_or_else(syntax)?;
        let mut ranges: [Option<[f64; 2]>; 2] = [None, None];
        for part in [a, b] {
            let (name, range) = part.split_once('=').ok_or_else(syntax)?;
            let name = name.trim();
            let (lo, hi) = range.split_once(':').ok_or_else(syntax)?;
            let lo: f64 = lo.trim().parse().map_err(|_| syntax())?;
            let hi: f64 = hi.trim().parse().map_err(|_| syntax())?;
            let axis = if name == "x" || name == position {
                0
            } else if name == "v" || name == velocity {
                1
            } else {
                usize::MAX
            };
            let bad_name = || DomainError::Name {
                name: name.to_string(),
                text: text.to_string(),
                position: position.to_string(),
                velocity: velocity.to_string(),
            };
            let slot = ranges.get_mut(axis).ok_or_else(bad_name)?;
            if slot.is_some() {
                return Err(bad_name());
            }
            let range = |expected| DomainError::Range {
                name: name.to_string(),
                lo,
                hi,
                expected,
            };
            if !(lo.is_finite() && hi.is_finite()) {
                return Err(range("both ends must be finite numbers"));
            }
            if lo >= hi {
                return Err(range("the lower end must be below the upper end"));
            }
            *slot = Some([lo, hi]);
        }
        match ranges {
            [Some(x), Some(v)] => Ok(Domain { x, v }),
            _ => Err(syntax()),
        }
    }
}

impl FromStr for Domain {
    type Err = DomainError;

    /// [`Domain::parse_named`] with the names `x` and `v` only.
    ///
    /// ```
    /// let d: fpsolve::grid::Domain = "x=-2:3,v=-4:4".parse()?;
    /// assert_eq!(d.x, [-2.0, 3.0]);
    /// assert!("x=-inf:3,v=-4:4".parse::<fpsolve::grid::Domain>().is_err());
    /// # Ok::<(), fpsolve::grid::DomainError>(())
    /// ```
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Domain::parse_named(s, ["x", "v"])
    }
}
