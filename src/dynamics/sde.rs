//! The equations as the model writes them, for a method that simulates them rather than
//! solving their FPK equation: the drift f, the noise matrix G, the intensities S of the
//! sources, the interpretation; and the Itô form with independent unit sources that a
//! sampling scheme steps.

use crate::model::{BoundModel, Interpretation};
use crate::symbolic::{diff, simplify, Expr, Symbol, SymbolicError};

/// dX = f(X) dt + G(X)·dW with E[dW dWᵀ] = S dt, as written (Itô or Stratonovich).
///
/// ```
/// let bound = fpsolve::model::parse_model("model m\nstate z, v\ndrift z: v\n\
///     drift v: -v - z\nnoise xi: intensity 2\ndiffusion v: xi\n", None)?.bind(&[])?;
/// let dynamics = fpsolve::dynamics::Dynamics::read(&bound);
/// let sde = dynamics.sde();
/// assert_eq!(sde.drift()[0].to_string(), "v");
/// assert_eq!(sde.intensity(), [vec![2.0]]);
/// assert_eq!(sde.noise_matrix()[0][0].as_num(), Some(0.0)); // no noise in z' = v
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct Sde {
    drift: [Expr; 2],
    noise_matrix: [Vec<Expr>; 2],
    intensity: Vec<Vec<f64>>,
    noise_names: Vec<Symbol>,
    interpretation: Interpretation,
}

impl Sde {
    pub(super) fn read(model: &BoundModel) -> Sde {
        Sde {
            drift: model.drift().clone(),
            noise_matrix: model.noise_matrix().clone(),
            intensity: model.intensity().to_vec(),
            noise_names: model.noise_names().to_vec(),
            interpretation: model.interpretation(),
        }
    }

    /// The drift f as written (without the Wong–Zakai correction of a Stratonovich model).
    pub fn drift(&self) -> &[Expr; 2] {
        &self.drift
    }

    /// G, `[state][source]`.
    pub fn noise_matrix(&self) -> &[Vec<Expr>; 2] {
        &self.noise_matrix
    }

    /// S, the sources' intensity matrix.
    pub fn intensity(&self) -> &[Vec<f64>] {
        &self.intensity
    }

    /// The sources' names.
    pub fn noise_names(&self) -> &[Symbol] {
        &self.noise_names
    }

    /// Itô or Stratonovich.
    pub fn interpretation(&self) -> Interpretation {
        self.interpretation
    }

    /// The Itô form with independent unit sources, for `l` a square root of S (S = L·Lᵀ,
    /// row-major, lower triangular): the drift (Wong–Zakai corrected for a Stratonovich
    /// model, ½ Σ_j Σ_r b̃_rj ∂_r b̃_ij, which equals the FPK operator's
    /// ½ Σ_kl S_kl G_jl ∂_j G_ik because S = L·Lᵀ) and the columns b̃ = G·L, `[row][column]`.
    ///
    /// # Errors
    /// A [`SymbolicError`] when a column has no derivative (δ of a state).
    pub(crate) fn unit_columns(
        &self,
        states: &[Symbol; 2],
        l: &[f64],
    ) -> Result<([Expr; 2], [Vec<Expr>; 2]), SymbolicError> {
        let m = self.noise_names.len();
        let g = &self.noise_matrix;
        let columns: [Vec<Expr>; 2] = std::array::from_fn(|i| {
            (0..m)
                .map(|j| {
                    let terms: Vec<Expr> = (j..m)
                        .filter(|&k| l[k * m + j] != 0.0)
                        .map(|k| Expr::num(l[k * m + j]) * g[i][k].clone())
                        .collect();
                    simplify(&Expr::sum(terms))
                })
                .collect()
        });
        let mut drift = self.drift.clone();
        if self.interpretation == Interpretation::Stratonovich {
            let states = [&*states[0], &*states[1]];
            for i in 0..2 {
                let mut terms = Vec::new();
                for (j, column) in columns[i].iter().enumerate() {
                    for (r, s) in states.iter().enumerate() {
                        if columns[r][j].as_num() == Some(0.0) {
                            continue;
                        }
                        let d = diff(column, s)?;
                        if d.as_num() != Some(0.0) {
                            terms.push(Expr::num(0.5) * columns[r][j].clone() * d);
                        }
                    }
                }
                if !terms.is_empty() {
                    drift[i] = simplify(&(drift[i].clone() + Expr::sum(terms)));
                }
            }
        }
        Ok((drift, columns))
    }
}
