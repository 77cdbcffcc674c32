//! The names of the methods as the command line and reports spell them (`epc`, `epc-impact`,
//! `grid`), and a set of them (`--method epc,grid`).

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

/// A method by name, without its settings (degree, cells): what `--method` chooses.
///
/// ```
/// use fpsolve::solve::MethodName;
/// let m: MethodName = "epc-impact".parse()?;
/// assert_eq!(m, MethodName::EpcImpact);
/// assert_eq!(m.to_string(), "epc-impact");
/// # Ok::<(), fpsolve::solve::MethodNameError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodName {
    /// Exponential-polynomial closure of the FPK equation as the model gives it (the paper's
    /// method; an impact enters through the δ term of the Zhuravlev form).
    Epc,
    /// Exponential-polynomial closure with the exact impact condition, on the domain of the
    /// original coordinates.
    EpcImpact,
    /// The finite-volume stationary FPK solver, impacts located exactly.
    Grid,
}

impl MethodName {
    /// Every method, in the order reports list them.
    pub const ALL: [MethodName; 3] = [MethodName::Epc, MethodName::EpcImpact, MethodName::Grid];

    /// The name as written on the command line.
    ///
    /// ```
    /// assert_eq!(fpsolve::solve::MethodName::Grid.as_str(), "grid");
    /// ```
    pub fn as_str(self) -> &'static str {
        match self {
            MethodName::Epc => "epc",
            MethodName::EpcImpact => "epc-impact",
            MethodName::Grid => "grid",
        }
    }

    /// Whether the method is solved at a ladder of degrees (`--degree`).
    ///
    /// ```
    /// use fpsolve::solve::MethodName;
    /// assert!(MethodName::EpcImpact.has_degrees() && !MethodName::Grid.has_degrees());
    /// ```
    pub fn has_degrees(self) -> bool {
        self.method().has_degrees()
    }
}

impl fmt::Display for MethodName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Why a `--method` argument is not a set of methods.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MethodNameError {
    /// A name that is not a method.
    #[error("`{name}` is not a method (expected one of: epc, epc-impact, grid)")]
    Unknown {
        /// The name as given.
        name: String,
    },
    /// The same method twice.
    #[error("`{name}` is given twice")]
    Repeated {
        /// The name as given.
        name: String,
    },
    /// Nothing given.
    #[error("no method given (expected a comma-separated list of epc, epc-impact, grid)")]
    Empty,
}

impl FromStr for MethodName {
    type Err = MethodNameError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let name = s.trim();
        MethodName::ALL
            .into_iter()
            .find(|m| m.as_str() == name)
            .ok_or_else(|| MethodNameError::Unknown { name: name.into() })
    }
}

/// A non-empty set of distinct methods, in the order [`MethodName::ALL`] lists them.
///
/// ```
/// use fpsolve::solve::{MethodName, MethodSet};
/// let set: MethodSet = "grid, epc".parse()?;
/// assert_eq!(set.names(), &[MethodName::Epc, MethodName::Grid]);
/// assert!(set.contains(MethodName::Grid) && !set.contains(MethodName::EpcImpact));
/// assert!("epc,epc".parse::<MethodSet>().is_err());
/// # Ok::<(), fpsolve::solve::MethodNameError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(transparent)]
pub struct MethodSet(Vec<MethodName>);

impl MethodSet {
    /// A set from names (sorted, duplicates refused).
    ///
    /// # Errors
    /// [`MethodNameError::Empty`] for no names, [`MethodNameError::Repeated`] for a repeat.
    ///
    /// ```
    /// use fpsolve::solve::{MethodName, MethodSet};
    /// let set = MethodSet::new(vec![MethodName::Grid])?;
    /// assert_eq!(set.to_string(), "grid");
    /// # Ok::<(), fpsolve::solve::MethodNameError>(())
    /// ```
    pub fn new(mut names: Vec<MethodName>) -> Result<MethodSet, MethodNameError> {
        if names.is_empty() {
            return Err(MethodNameError::Empty);
        }
        names.sort();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(MethodNameError::Repeated {
                name: w[0].to_string(),
            });
        }
        Ok(MethodSet(names))
    }

    /// The methods, in the order [`MethodName::ALL`] lists them.
    pub fn names(&self) -> &[MethodName] {
        &self.0
    }

    /// Whether `name` is in the set.
    pub fn contains(&self, name: MethodName) -> bool {
        self.0.contains(&name)
    }
}

impl fmt::Display for MethodSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = self.0.iter().map(|m| m.as_str()).collect();
        f.write_str(&names.join(","))
    }
}

impl FromStr for MethodSet {
    type Err = MethodNameError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.trim().is_empty() {
            return Err(MethodNameError::Empty);
        }
        MethodSet::new(s.split(',').map(str::parse).collect::<Result<_, _>>()?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_reads_back() {
        for m in MethodName::ALL {
            assert_eq!(m.as_str().parse::<MethodName>(), Ok(m));
        }
    }

    #[test]
    fn bad_sets_are_refused_with_their_reason() {
        assert_eq!("".parse::<MethodSet>(), Err(MethodNameError::Empty));
        assert_eq!(
            "epc,mc".parse::<MethodSet>(),
            Err(MethodNameError::Unknown { name: "mc".into() })
        );
        assert_eq!(
            "grid,epc,grid".parse::<MethodSet>(),
            Err(MethodNameError::Repeated {
                name: "grid".into()
            })
        );
    }
}
