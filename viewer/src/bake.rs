//! A scene and its coefficient file, loaded together.

use std::path::{Path, PathBuf};

use prt_baker::{CoefficientFile, Scene};

use crate::error::Result;

/// A scene and a bake of it, checked to belong together.
#[derive(Clone, Debug)]
pub struct Bake {
    pub scene: Scene,
    pub file: CoefficientFile,
    /// Where the coefficient file came from, for messages.
    pub file_path: PathBuf,
}

impl Bake {
    /// Loads the scene with the baker's own loader (so the vertex order is the one the file
    /// was baked in) and the coefficient file, and refuses a file whose vertex count or
    /// geometry fingerprint is not the scene's.
    pub fn load(scene: &Path, coefficients: &Path) -> Result<Bake> {
        let file = CoefficientFile::read(coefficients)?;
        let scene = Scene::load(scene)?;
        Bake::new(scene, file, coefficients)
    }

    /// A bake already in memory (tests), with the same check as [`Bake::load`].
    pub fn new(scene: Scene, file: CoefficientFile, file_path: &Path) -> Result<Bake> {
        file.check_scene(file_path, &scene)?;
        Ok(Bake {
            scene,
            file,
            file_path: file_path.to_path_buf(),
        })
    }

    /// The SH order n of the transfer (n² coefficients per channel).
    pub fn order(&self) -> usize {
        self.file.header.order as usize
    }

    /// 1 (grey transfer) or 3 (R, G, B).
    pub fn channels(&self) -> usize {
        self.file.header.channels as usize
    }
}
