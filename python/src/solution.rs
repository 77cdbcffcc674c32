//! `fpsolve.Solution`'s native half: PDFs of states and observables and the joint density,
//! evaluated over NumPy arrays with the GIL released; marginals, moments, coefficients and the
//! typed report (the library's serde form, as JSON text the Python layer reads).

use fpsolve::report::Provenance;
use fpsolve::solve::Solution;
use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::errors::{self, Asked};
use crate::pool::on_pool;

/// An array the Python side receives.
type Array<'py> = Bound<'py, PyArrayDyn<f64>>;

/// Exponents (i, j) and coefficients a_ij of Q.
type Coefficients = (Vec<(usize, usize)>, Vec<f64>);

/// A solved stationary density.
#[pyclass(name = "_Solution", module = "fpsolve._fpsolve", frozen)]
pub(crate) struct PySolution {
    solution: Solution,
    method: String,
    degree: Option<usize>,
    /// Where it came from: made when it was solved, on the pool it was solved on.
    provenance: Provenance,
}

impl PySolution {
    pub(crate) fn new(
        solution: Solution,
        method: String,
        degree: Option<usize>,
        provenance: Provenance,
    ) -> PySolution {
        PySolution {
            solution,
            method,
            degree,
            provenance,
        }
    }

    fn asked(&self) -> Asked<'_> {
        Asked {
            method: &self.method,
            degree: self.degree,
        }
    }
}

/// A float64 array of `values` with `shape` (the values moved, not copied).
fn shaped<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    values.into_pyarray(py).reshape(shape.to_vec())
}

#[pymethods]
impl PySolution {
    #[getter]
    fn method(&self) -> &str {
        &self.method
    }

    #[getter]
    fn degree(&self) -> Option<usize> {
        self.degree
    }

    /// The states, then the observables.
    #[getter]
    fn quantities(&self) -> Vec<String> {
        self.solution
            .quantities()
            .iter()
            .map(|q| q.name.to_string())
            .collect()
    }

    /// The names of the joint density's two coordinates: the model's states, or, for a model
    /// in its own coordinates solved by the δ-term EPC, the Zhuravlev transform's (z, v).
    #[getter]
    fn joint_states(&self) -> Vec<String> {
        self.solution
            .joint_states()
            .iter()
            .map(|s| s.to_string())
            .collect()
    }

    /// The PDF of state or observable `name` at every point of `x` (C-contiguous float64),
    /// with `x`'s shape.
    fn pdf<'py>(
        &self,
        py: Python<'py>,
        name: &str,
        x: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let shape = x.shape().to_vec();
        let xs = x.as_slice()?;
        let p = on_pool(py, || self.solution.pdf(name, xs))?
            .map_err(|e| errors::solve_error(py, &e, &self.asked()))?;
        shaped(py, p, &shape)
    }

    /// The joint density of the two states at the points (x1, x2) (arrays of one shape).
    fn joint<'py>(
        &self,
        py: Python<'py>,
        x1: PyReadonlyArrayDyn<'py, f64>,
        x2: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        if x1.shape() != x2.shape() {
            return Err(errors::bad_argument(format!(
                "x1 and x2 have shapes {:?} and {:?}; they must be broadcast to one shape",
                x1.shape(),
                x2.shape()
            )));
        }
        let shape = x1.shape().to_vec();
        let (a, b) = (x1.as_slice()?, x2.as_slice()?);
        let joint = self.solution.joint();
        let p = on_pool(py, || {
            a.iter()
                .zip(b)
                .map(|(&u, &v)| joint.pdf([u, v]))
                .collect::<Vec<f64>>()
        })?;
        shaped(py, p, &shape)
    }

    /// The PDF of `name` on the grid the reports use: `(x, p)`.
    fn marginal<'py>(&self, py: Python<'py>, name: &str) -> PyResult<(Array<'py>, Array<'py>)> {
        let (x, p) = on_pool(py, || self.solution.marginal(name))?
            .map_err(|e| errors::solve_error(py, &e, &self.asked()))?;
        let n = x.len();
        Ok((shaped(py, x, &[n])?, shaped(py, p, &[n])?))
    }

    /// The moments of `name` as JSON (`QuantityMoments`' serde form; NaN is null).
    fn moments_json(&self, py: Python<'_>, name: &str) -> PyResult<String> {
        let m = on_pool(py, || self.solution.moments(name))?
            .map_err(|e| errors::solve_error(py, &e, &self.asked()))?;
        serde_json::to_string(&m).map_err(|e| errors::bad_argument(e.to_string()))
    }

    /// P(quantity > a); None where the density's support does not reach `a` reliably.
    fn tail_probability(&self, py: Python<'_>, name: &str, a: f64) -> PyResult<Option<f64>> {
        on_pool(py, || self.solution.tail_probability(name, a))?
            .map_err(|e| errors::solve_error(py, &e, &self.asked()))
    }

    /// The exponents (i, j) and coefficients a_ij of Q(x1, x2) = Σ a_ij x1^i x2^j (EPC and
    /// EPC-impact); a NotApplicableError for the grid, which has none.
    fn coefficients(&self, py: Python<'_>) -> PyResult<Coefficients> {
        match self.solution.polynomial() {
            Some((exponents, coefficients)) => Ok((exponents.to_vec(), coefficients.to_vec())),
            None => Err(errors::other::<errors::NotApplicableError>(
                py,
                "no_coefficients",
                format!(
                    "the {} solution is a density on cells; it has no polynomial coefficients",
                    self.method
                ),
            )),
        }
    }

    /// The typed outcome as JSON, opening with its `provenance` (version, schema, time,
    /// threads, the model's name, file and text): the EPC solution (coefficients, σ,
    /// iterations, residual, normalisation, timings, moments), the EPC-impact solution, or
    /// the grid's report.
    fn report_json(&self) -> PyResult<String> {
        self.solution
            .report_json()
            .and_then(|json| crate::model::provenance_first(&self.provenance, &json))
            .map_err(|e| errors::bad_argument(e.to_string()))
    }

    fn __repr__(&self) -> String {
        format!("<fpsolve.Solution {}>", self.solution.method())
    }
}
