//! The viewer's errors. Input problems (scene, coefficient file, rig) come from the baker
//! library unchanged, so they read exactly as `prt-bake`'s do; the rest are about the graphics
//! device, the window and the options.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A scene, coefficient file or light rig that cannot be used, or a coefficient file baked
    /// for another scene.
    #[error(transparent)]
    Baker(#[from] prt_baker::Error),

    /// No graphics adapter at all (not even Mesa's software lavapipe or llvmpipe).
    #[error("no graphics adapter: {0}")]
    NoAdapter(String),

    /// The adapter refused the device, or cannot do what the viewer needs.
    #[error("graphics device: {0}")]
    Device(String),

    /// Options that cannot be honoured (a malformed `--size` or `--camera`, …).
    #[error("{0}")]
    InvalidOption(String),

    /// A screenshot that could not be written.
    #[error("{}: {source}", path.display())]
    Image {
        path: PathBuf,
        source: image::ImageError,
    },

    /// The window system failed (no display, window creation).
    #[error("window: {0}")]
    Window(String),

    /// The GPU failed during a frame (a lost surface, a failed readback).
    #[error("GPU: {0}")]
    Gpu(String),
}

impl Error {
    /// Whether the user's input files or options are at fault; the binary maps this to its
    /// exit code, as `prt-bake` does.
    pub fn is_bad_input(&self) -> bool {
        match self {
            Error::Baker(err) => err.is_bad_input(),
            Error::InvalidOption(_) => true,
            _ => false,
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
