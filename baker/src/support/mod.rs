//! What every layer leans on: the crate's error type, memory limits and bounded file reads,
//! progress reporting, and the output policy (atomic writes that never destroy an input).
//!
//! May import: std and external crates only.

pub mod atomic;
pub mod cpu_time;
pub mod digest;
pub mod error;
pub mod input_path;
pub mod limits;
pub mod output;
pub mod progress;
pub mod toml_file;
