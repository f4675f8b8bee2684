//! `prt-view --probes … --mover … --mover-occluder OCC`: the mover's shadow on the scene's
//! vector bake, per vertex or per lightmap texel (docs/guides/occluders.md).
//!
//! Each frame the mover is placed and its occluder spheres go with it. **Per vertex**, every
//! scene vertex within their reach gets T′ = Γ(T, V), the order-n projection of its transfer
//! times the spheres' SH visibility (`prt_baker::math::occlusion`); the transfer buffer is
//! rewritten, and the unchanged shader relights it, ∫ L·T·V. The work is on the CPU, per
//! vertex in reach: a few hundred multiply-adds per sphere at order 4 (the Cornell room's
//! 2,944 vertices take 1.5 ms for one ball), and one upload of the transfer. **Per texel**
//! that would be hundreds of times the work and a 50 MB upload a frame for a 512² lightmap,
//! so only the spheres are uploaded and the lightmap's radiance pass evaluates the same
//! product per texel ([`crate::texel_occluders`], which says why).

use glam::{DQuat, Vec3};
use prt_baker::formats::header::TransferKind;
use prt_baker::formats::occluder_file::OccluderFile;
use prt_baker::math::occlusion::{Occlusion, Sphere};

use crate::bake::Bake;
use crate::error::{Error, Result};
use crate::texel_occluders;

/// A mover's occluder and the scene's receivers it darkens.
#[derive(Clone, Debug)]
pub struct MoverShadow {
    occluder: OccluderFile,
    /// The vertices' transfer, darkened here; `None` for a lightmap (darkened on the device).
    vertices: Option<VertexReceivers>,
}

/// A per-vertex bake's receivers and their baked transfer.
#[derive(Clone, Debug)]
struct VertexReceivers {
    occlusion: Occlusion,
    /// The scene's own transfer, `(v · channels + c) · n² + j`.
    base: Vec<f32>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    channels: usize,
}

impl MoverShadow {
    /// For a vector bake, per vertex or per texel (up to [`texel_occluders::MAX_SPHERES`]
    /// spheres and order [`texel_occluders::MAX_ORDER`]); a transfer-matrix bake is refused.
    pub fn new(bake: &Bake, occluder: OccluderFile) -> Result<MoverShadow> {
        if bake.file.header.transfer != TransferKind::Vector {
            return Err(Error::Baker(prt_baker::Error::InvalidOption(format!(
                "{}: --mover-occluder darkens a vector bake (not a transfer-matrix bake in \
                 prt-view)",
                bake.file_path.display()
            ))));
        }
        if bake.lightmap().is_some() {
            let spheres = occluder.spheres.len();
            if spheres > texel_occluders::MAX_SPHERES || bake.order() > texel_occluders::MAX_ORDER {
                return Err(Error::InvalidOption(format!(
                    "{}: --mover-occluder shadows a lightmap with up to {} spheres at order up to {} (this occluder has {spheres}, the bake is order {})",
                    bake.file_path.display(),
                    texel_occluders::MAX_SPHERES,
                    texel_occluders::MAX_ORDER,
                    bake.order()
                )));
            }
            return Ok(MoverShadow {
                occluder,
                vertices: None,
            });
        }
        let vertices = VertexReceivers {
            occlusion: Occlusion::new(bake.order()),
            base: bake.file.coefficients.clone(),
            positions: bake.scene.positions.clone(),
            normals: bake.scene.normals.clone(),
            channels: bake.channels(),
        };
        Ok(MoverShadow {
            occluder,
            vertices: Some(vertices),
        })
    }

    /// Whether the receivers are lightmap texels (darkened by the radiance pass).
    pub fn is_texel(&self) -> bool {
        self.vertices.is_none()
    }

    /// The occluder's spheres with the mover at `(position, rotation)`.
    pub fn spheres(&self, (position, rotation): (Vec3, DQuat)) -> Vec<Sphere> {
        self.occluder.placed(position.as_dvec3(), rotation)
    }

    /// The scene's transfer darkened by the occluder at `placement` (per-vertex bakes).
    pub fn transfer(&self, placement: (Vec3, DQuat)) -> Vec<f32> {
        self.transfer_for(&self.spheres(placement))
    }

    /// The scene's per-vertex transfer darkened by `spheres` (placed in the scene); a
    /// lightmap bake's shadow is not computed here (empty).
    pub fn transfer_for(&self, spheres: &[Sphere]) -> Vec<f32> {
        let Some(receivers) = &self.vertices else {
            return Vec::new();
        };
        receivers.transfer(spheres)
    }
}

impl VertexReceivers {
    fn transfer(&self, spheres: &[Sphere]) -> Vec<f32> {
        let n = self.occlusion.order() * self.occlusion.order();
        let mut out = self.base.clone();
        let (mut v, mut t, mut product) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for (r, (p, normal)) in self.positions.iter().zip(&self.normals).enumerate() {
            let (p, normal) = (p.as_dvec3(), normal.as_dvec3());
            if !self.occlusion.visibility(p, normal, spheres, &mut v) {
                continue;
            }
            for c in 0..self.channels {
                let at = (r * self.channels + c) * n;
                for (x, y) in t.iter_mut().zip(&self.base[at..at + n]) {
                    *x = f64::from(*y);
                }
                self.occlusion.gaunt().product(&t, &v, &mut product);
                for (o, x) in out[at..at + n].iter_mut().zip(&product) {
                    *o = *x as f32;
                }
            }
        }
        out
    }
}
