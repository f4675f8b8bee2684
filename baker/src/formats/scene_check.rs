//! Whether a coefficient file belongs to a scene: its vertex (or texel) count and the scene's
//! fingerprint, and the transfer kind its reader understands. Every consumer of a file with a
//! scene (relight, export, the viewer) asks here before it reads a coefficient.

use std::path::Path;

use crate::formats::coefficient_file::{CoefficientFile, LightmapBlock};
use crate::formats::header::AtlasSource;
use crate::scene::{AUTO_MIN_TRIANGLES, Hierarchy, Instancing, Scene};
use crate::support::error::{Error, Result};

impl CoefficientFile {
    /// Loads the scene at `path` as this file's bake traced it (every reader with a scene
    /// loads it here, then checks it below): with the shared meshes that no object of which
    /// receives traced through instances, as `bake --instances auto` (the default) and `on`
    /// do, or flat (`off`, and every bake that cannot instance), whichever the file's
    /// fingerprint names; with or without back sheets ([`Self::match_back_sheets`]). A bake
    /// of a ground under 20,000 instanced trees is read without flattening the trees, which
    /// would need gigabytes; the readers then see the receivers and the flat occluders, not
    /// the instanced ones. The scene's warnings are printed. A scene no way of loading
    /// matches is returned as `auto` loads it, and the checks say why it does not belong.
    pub fn load_scene(&self, path: &Path) -> Result<Scene> {
        let nobody = |_: &Hierarchy, _: u32, _: &str| false;
        let mut first: Option<(Scene, Vec<String>)> = None;
        // auto, on, off: a load without instances makes the later ones (fewer instances)
        // the same scene, so the search stops there.
        for min_triangles in [AUTO_MIN_TRIANGLES, 0, u64::MAX] {
            let instancing = Instancing {
                receives: &nobody,
                min_triangles,
            };
            let chosen = (min_triangles != u64::MAX).then_some(&instancing);
            let (mut scene, warnings) = Scene::load_instanced(path, chosen)?;
            self.match_back_sheets(&mut scene);
            let flat = scene.instances.is_empty();
            if scene.fingerprint() == self.header.scene_fingerprint {
                first = Some((scene, warnings));
                break;
            }
            if first.is_none() {
                first = Some((scene, warnings));
            }
            if flat && min_triangles == 0 {
                break;
            }
        }
        let (scene, warnings) = first.expect("one load at least");
        for warning in warnings {
            eprintln!("warning: {}: {warning}", path.display());
        }
        Ok(scene)
    }

    /// Drops `scene`'s back sheets (docs/guides/production-assets.md, "Two-sided surfaces") where the file was
    /// baked without them (`bake --double-sided off`, or before they existed): the scene
    /// fingerprint records which, so every reader calls this before its checks below.
    pub fn match_back_sheets(&self, scene: &mut Scene) {
        if scene.first_back_sheet().is_none()
            || self.header.scene_fingerprint == scene.fingerprint()
        {
            return;
        }
        scene.drop_back_sheets();
        if self.header.scene_fingerprint != scene.fingerprint() {
            // Another scene either way: the check that follows says so of the whole one.
            scene
                .add_back_sheets()
                .expect("the same back sheets as loaded");
        }
    }

    /// Refuses a file baked for a different scene (or a changed version of this one), and a
    /// transfer-matrix bake: every reader of transfer vectors only (the glTF and EXR exports,
    /// the viewer's per-texel path) checks its file here, so none of them misreads a matrix as
    /// vectors; readers of both kinds call [`CoefficientFile::check_scene_of_any_transfer`].
    pub fn check_scene(&self, path: &Path, scene: &Scene) -> Result<()> {
        self.refuse_matrix(path)?;
        self.check_scene_of_any_transfer(path, scene)
    }

    /// Refuses a transfer-matrix bake (`bake --transfer matrix`) with the reason.
    pub fn refuse_matrix(&self, path: &Path) -> Result<()> {
        if self.header.transfer == crate::formats::header::TransferKind::Matrix {
            return Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message: "a transfer-matrix bake (--transfer matrix), which this command does \
                          not read yet (`export --npz`, `inspect`, `relight` and `prt-view` do)"
                    .into(),
            });
        }
        Ok(())
    }

    /// [`CoefficientFile::check_scene`] for readers of both transfer vectors and matrices.
    pub fn check_scene_of_any_transfer(&self, path: &Path, scene: &Scene) -> Result<()> {
        let mismatch = |message: String| {
            Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message,
            })
        };
        if let Some(l) = &self.lightmap {
            return mismatch(format!(
                "a lightmap bake ({}×{} texels), which this reader does not read (only \
                 `export` reads lightmap bakes so far)",
                l.width, l.height
            ));
        }
        if let Some(p) = &self.probes {
            return mismatch(format!(
                "a probe bake ({} probes), which this reader does not read (`export --npz`, \
                 `inspect` and the probe readers do)",
                p.positions.len()
            ));
        }
        let Some(receivers) = &self.header.receivers else {
            return self.check_fingerprint(path, scene, self.header.vertex_count);
        };
        // A bake of some objects (`bake --receivers`): the scene's, with as many objects.
        if receivers.object_count as usize != scene.objects.len() {
            return mismatch(format!(
                "baked for a scene with {} objects, but {} has {}",
                receivers.object_count,
                scene.path.display(),
                scene.objects.len()
            ));
        }
        self.check_fingerprint(path, scene, scene.vertex_count() as u64)?;
        let expected = receivers.vertex_count(scene);
        if self.header.vertex_count != expected {
            return mismatch(format!(
                "holds {} vertices, but its {} receiving objects have {expected} in {}",
                self.header.vertex_count,
                receivers.objects.len(),
                scene.path.display()
            ));
        }
        Ok(())
    }

    /// Refuses a probe bake made for a different scene, or a file that is not a probe bake;
    /// returns its probe block.
    pub fn check_probe_scene(
        &self,
        path: &Path,
        scene: &Scene,
    ) -> Result<&crate::formats::probe_block::ProbeBlock> {
        let Some(p) = &self.probes else {
            return Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message: "not a probe bake (bake --probes)".into(),
            });
        };
        self.check_fingerprint(path, scene, scene.vertex_count() as u64)?;
        Ok(p)
    }

    /// Refuses a lightmap bake made for a different scene, or a vertex bake.
    pub fn check_lightmap_scene(&self, path: &Path, scene: &Scene) -> Result<&LightmapBlock> {
        self.refuse_matrix(path)?;
        let Some(l) = &self.lightmap else {
            return Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message: "a per-vertex bake, not a lightmap bake".into(),
            });
        };
        if l.scene_triangle_count != scene.triangles.len() as u64 {
            return Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message: format!(
                    "baked for a scene with {} triangles, but {} has {}",
                    l.scene_triangle_count,
                    scene.path.display(),
                    scene.triangles.len()
                ),
            });
        }
        self.check_fingerprint(path, scene, l.scene_vertex_count)?;
        if l.source == AtlasSource::PerObject && l.objects.len() != scene.objects.len() {
            return Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message: format!(
                    "its atlas places {} objects, but {} has {}",
                    l.objects.len(),
                    scene.path.display(),
                    scene.objects.len()
                ),
            });
        }
        Ok(l)
    }

    fn check_fingerprint(&self, path: &Path, scene: &Scene, vertex_count: u64) -> Result<()> {
        let mismatch = |message: String| {
            Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message,
            })
        };
        if vertex_count != scene.vertex_count() as u64 {
            return mismatch(format!(
                "baked for a scene with {} vertices, but {} has {}",
                vertex_count,
                scene.path.display(),
                scene.vertex_count()
            ));
        }
        let fingerprint = scene.fingerprint();
        if self.header.scene_fingerprint != fingerprint {
            return mismatch(format!(
                "baked for another scene: fingerprint {:016x}, but {} has {fingerprint:016x}",
                self.header.scene_fingerprint,
                scene.path.display()
            ));
        }
        Ok(())
    }
}
