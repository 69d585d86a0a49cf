//! The ragdoll engine for Python: the native half of the `ragdoll_sim` package.
//!
//! The API is the library's, shaped for Python: `load()` / `Character.from_arrays()` for
//! characters, `build_ragdoll()` for editable specs, `World` for characters and events,
//! `Result` for numpy arrays, the report and the files, and `Simulation` for a world
//! stepped a piece at a time with ragdolls added and removed between steps. It calls the library directly
//! (no command-line tool in between), releases the interpreter's lock while it simulates,
//! and turns every library error into an exception whose class says its kind and whose
//! attributes carry the file, line, place and key; a Rust panic becomes one
//! `InternalError` instead of ending the Python process.

use pyo3::prelude::*;

mod arrays;
mod character;
mod errors;
mod events;
mod live;
mod result;
mod settings;
mod spec;
mod world;

/// Panics behind the same guard every entry point has: the test suite's proof that a
/// panic reaches Python as one `InternalError` and the process goes on.
#[pyfunction]
fn _panic_for_tests(message: &str) -> PyResult<()> {
    errors::guard(|| -> PyResult<()> { panic!("{message}") })
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    m.add_function(wrap_pyfunction!(character::load, m)?)?;
    m.add_function(wrap_pyfunction!(character::humanoid, m)?)?;
    m.add_function(wrap_pyfunction!(spec::build_ragdoll, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_tests, m)?)?;
    m.add_class::<character::Character>()?;
    m.add_class::<character::Roles>()?;
    m.add_class::<spec::Spec>()?;
    m.add_class::<spec::Body>()?;
    m.add_class::<spec::JointView>()?;
    m.add_class::<world::World>()?;
    m.add_class::<result::RunResult>()?;
    m.add_class::<live::Simulation>()?;
    Ok(())
}
