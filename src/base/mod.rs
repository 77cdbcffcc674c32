//! The tools every stage may use and that know nothing of models or methods: cooperative
//! cancellation, the profiling timeline, resource limits, input-file checks, number
//! formatting and the CPU's vector extensions.
//! It sits at the bottom of the stage order (`scripts/stages`): it imports no other folder.

pub mod cancel;
pub mod input_file;
pub mod limits;
pub mod number_text;
pub mod run;
pub mod simd;
pub mod timeline;
