//! The native module `fpsolve._fpsolve` of the Python package `fpsolve`: thin wrappers of the
//! Rust library's front door (models, solves, Monte Carlo, sweeps, the main job). The Pythonic
//! API (keyword arguments, arrays, report dicts) is the pure-Python layer in `fpsolve/`.

use pyo3::prelude::*;

mod arguments;
mod errors;
mod interrupt;
mod job;
mod merge;
mod model;
mod passage;
mod pool;
mod solution;
mod sweep;
mod transient;

#[pymodule]
fn _fpsolve(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<model::PyModel>()?;
    m.add_class::<solution::PySolution>()?;
    m.add_function(wrap_pyfunction!(sweep::sweep_json, m)?)?;
    m.add_function(wrap_pyfunction!(job::run_job, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::merge_sweep_json, m)?)?;
    m.add_function(wrap_pyfunction!(merge::merge_mc_json, m)?)?;
    m.add_function(wrap_pyfunction!(passage::passage, m)?)?;
    m.add_class::<transient::PyTransient>()?;
    m.add_function(wrap_pyfunction!(transient::transient, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
