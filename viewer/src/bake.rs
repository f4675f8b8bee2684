//! A scene and its coefficient file, loaded together.
//!
//! The viewer works in the z-up frame that rigs are written in: a y-up bake's scene is turned
//! by the inverse of [`Up::from_z_up`] on loading (its positions and normals; the transfer
//! stays in the scene's coordinates, and [`crate::lights::Lights::for_up`] turns the light to
//! meet it). The camera, its framing, the θ/φ controls and the default rig then need no
//! notion of up, and a z-up OBJ and the y-up glTF of the same geometry look the same.

use std::path::{Path, PathBuf};

use prt_baker::formats::coefficient_file::LightmapBlock;
use prt_baker::formats::cpca_block;
use prt_baker::formats::header::TransferKind;
use prt_baker::math::cpca::Cpca;
use prt_baker::scene::Up;
use prt_baker::{CoefficientFile, Scene};

use crate::error::Result;

/// A scene and a bake of it, checked to belong together.
#[derive(Clone, Debug)]
pub struct Bake {
    pub scene: Scene,
    pub file: CoefficientFile,
    /// Where the coefficient file came from, for messages.
    pub file_path: PathBuf,
    /// A compressed (version 2) file's clusters, bases and weights, as stored; `file` then
    /// holds their reconstruction. The glossy path renders a compressed matrix bake from
    /// these (the light projected per cluster, not per vertex).
    pub cpca: Option<Cpca>,
}

impl Bake {
    /// Loads the scene with the baker's own loader (so the vertex order is the one the file
    /// was baked in) and the coefficient file, and refuses a file whose vertex count or
    /// geometry fingerprint is not the scene's.
    pub fn load(scene: &Path, coefficients: &Path) -> Result<Bake> {
        let bytes = prt_baker::support::limits::read_file(coefficients)?;
        let parsed = if cpca_block::is_compressed(&bytes) {
            cpca_block::from_bytes(&bytes).map(|c| (c.file, Some(c.cpca)))
        } else {
            CoefficientFile::from_bytes(&bytes).map(|file| (file, None))
        };
        let (file, cpca) =
            parsed.map_err(|message| prt_baker::Error::coefficient_file(coefficients, message))?;
        let scene = file.load_scene(scene)?;
        let mut bake = Bake::new(scene, file, coefficients)?;
        bake.cpca = cpca;
        Ok(bake)
    }

    /// A bake already in memory (tests), with the same check as [`Bake::load`]; the scene is
    /// then turned to z-up (see the module's documentation). A lightmap (texel) bake is
    /// checked against the scene's vertex and triangle counts and fingerprint recorded in
    /// its texel block.
    pub fn new(mut scene: Scene, file: CoefficientFile, file_path: &Path) -> Result<Bake> {
        if file.lightmap.is_some() {
            file.check_lightmap_scene(file_path, &scene)?;
        } else {
            // Transfer vectors (diffuse PRT) and matrices (glossy PRT) both render.
            file.check_scene_of_any_transfer(file_path, &scene)?;
        }
        // A bake of some objects (`bake --receivers`): the others are drawn unshadowed.
        let file = file.spread_to_scene(file_path, &scene)?.into_owned();
        turn_to_z_up(&mut scene, file.header.up);
        Ok(Bake {
            scene,
            file,
            file_path: file_path.to_path_buf(),
            cpca: None,
        })
    }

    /// A transfer-matrix bake (`prt-bake bake --transfer matrix`): rendered as glossy PRT.
    pub fn is_matrix(&self) -> bool {
        self.file.header.transfer == TransferKind::Matrix
    }

    /// The SH order n of the transfer (n² coefficients per channel).
    pub fn order(&self) -> usize {
        self.file.header.order as usize
    }

    /// The scene's up axis, as the bake recorded it.
    pub fn up(&self) -> Up {
        self.file.header.up
    }

    /// 1 (grey transfer) or 3 (R, G, B).
    pub fn channels(&self) -> usize {
        self.file.header.channels as usize
    }

    /// The texel block of a lightmap bake (the file's "vertices" are then its W×H texels);
    /// `None` for a per-vertex bake.
    pub fn lightmap(&self) -> Option<&LightmapBlock> {
        self.file.lightmap.as_ref()
    }
}

/// Turns a scene of up axis `up` to the viewer's z-up frame (its positions and normals).
pub fn turn_to_z_up(scene: &mut Scene, up: Up) {
    if up != Up::Z {
        let to_z_up = up.from_z_up().transpose().as_mat3();
        for p in &mut scene.positions {
            *p = to_z_up * *p;
        }
        for n in &mut scene.normals {
            *n = (to_z_up * *n).normalize();
        }
    }
}
