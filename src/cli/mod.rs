//! The command line's parts beside `main.rs`: flags read into the library's settings, the
//! job's plan, the console, progress bars and the allocator's settings of the process.
//! Everything here parses, prints or plans; the work itself is the library's.

pub(crate) mod allocator;
pub(crate) mod console;
pub(crate) mod domain_flag;
pub(crate) mod job_plan;
pub(crate) mod mc_flags;
pub(crate) mod progress;
pub(crate) mod reliability;
pub(crate) mod sweep_flags;
#[cfg(test)]
mod tests;
pub(crate) mod transient;
