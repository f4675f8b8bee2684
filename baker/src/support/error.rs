//! The library's error type. Every variant names the file it is about and, where the problem
//! sits on a line of a text file, the line, so a user can go straight to it.

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

/// A place in an input file: `path` or `path:line`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    pub path: PathBuf,
    pub line: Option<usize>,
}

impl Location {
    pub fn file(path: impl Into<PathBuf>) -> Location {
        Location {
            path: path.into(),
            line: None,
        }
    }

    pub fn line(path: impl Into<PathBuf>, line: usize) -> Location {
        Location {
            path: path.into(),
            line: Some(line),
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}", self.path.display()),
            None => write!(f, "{}", self.path.display()),
        }
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be opened, read, written or renamed.
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: io::Error },

    /// Scene input (scene file, OBJ, MTL, texture) that cannot be used as it is.
    #[error("{location}: {message}")]
    Scene { location: Location, message: String },

    /// A light rig (TOML) or an environment map that cannot be used as it is; rig errors name
    /// the line and the key.
    #[error("{location}: {message}")]
    Light { location: Location, message: String },

    /// A path an input names that the input-path policy refuses: outside the asset's folder
    /// or absolute (without `--allow-outside-uris`), or not a regular file (a device, FIFO,
    /// socket or directory); see [`crate::support::input_path`].
    #[error("{location}: {message}")]
    InputPath { location: Location, message: String },

    /// A coefficient file that is truncated, corrupted or of an unknown kind.
    #[error("{}: {message}", path.display())]
    CoefficientFile { path: PathBuf, message: String },

    /// A well-formed coefficient file that does not belong to the scene it is used with.
    #[error("{}: {message}", path.display())]
    SceneMismatch { path: PathBuf, message: String },

    /// An output path the output policy refuses (an input of the run, a directory, a block
    /// device…; see [`crate::support::output`]): a bad command line.
    #[error("{}: {message}", path.display())]
    Output { path: PathBuf, message: String },

    /// Input or work larger than the memory limit allows (`--max-memory`; see
    /// [`crate::support::limits`]): refused before anything is allocated.
    #[error("{what}: {message}")]
    TooLarge { what: String, message: String },

    /// Shard parts that do not make up one bake (missing, duplicated or foreign parts), or a
    /// checkpoint folder of another bake; the message names the files.
    #[error("{0}")]
    Shards(String),

    /// Options that cannot be honoured (an order out of range, zero samples, …).
    #[error("{0}")]
    InvalidOption(String),

    /// The ray-tracing backend failed (for Embree: device creation, BVH build).
    #[error("{backend} backend: {message}")]
    Tracer {
        backend: &'static str,
        message: String,
    },
}

impl Error {
    pub fn io(path: &Path, source: io::Error) -> Error {
        Error::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    pub fn scene(location: Location, message: impl Into<String>) -> Error {
        Error::Scene {
            location,
            message: message.into(),
        }
    }

    pub fn light(location: Location, message: impl Into<String>) -> Error {
        Error::Light {
            location,
            message: message.into(),
        }
    }

    pub fn coefficient_file(path: &Path, message: impl Into<String>) -> Error {
        Error::CoefficientFile {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    /// Whether the error is about the user's input (as opposed to the machine or the backend);
    /// the CLI maps this to its exit code.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            Error::Scene { .. }
                | Error::Light { .. }
                | Error::InputPath { .. }
                | Error::CoefficientFile { .. }
                | Error::SceneMismatch { .. }
                | Error::TooLarge { .. }
                | Error::Shards(_)
        ) || matches!(self, Error::Io { source, .. } if source.kind() == io::ErrorKind::NotFound)
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
