//! `prt-view --probes … --mover … --mover-occluder OCC`: the mover's shadow on a per-vertex
//! vector bake of the scene (docs/guides/occluders.md).
//!
//! Each frame the mover is placed, its occluder spheres go with it, and every scene vertex
//! within their reach gets T′ = Γ(T, V), the order-n projection of its transfer times the
//! spheres' SH visibility (`prt_baker::math::occlusion`); the transfer buffer is rewritten,
//! and the unchanged shader relights it, ∫ L·T·V. The work is on the CPU, per vertex in
//! reach: a few hundred multiply-adds per sphere at order 4 (the Cornell room's 2,944
//! vertices take 1.5 ms for one ball), and one upload of the transfer.

use glam::{DQuat, Vec3};
use prt_baker::formats::header::TransferKind;
use prt_baker::formats::occluder_file::OccluderFile;
use prt_baker::math::occlusion::Occlusion;

use crate::bake::Bake;
use crate::error::{Error, Result};

/// A mover's occluder and the scene's receivers it darkens.
#[derive(Clone, Debug)]
pub struct MoverShadow {
    occluder: OccluderFile,
    occlusion: Occlusion,
    /// The scene's own transfer, `(v · channels + c) · n² + j`.
    base: Vec<f32>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    channels: usize,
}

impl MoverShadow {
    /// For a vector bake per vertex; a lightmap or transfer-matrix bake is refused.
    pub fn new(bake: &Bake, occluder: OccluderFile) -> Result<MoverShadow> {
        if bake.lightmap().is_some() || bake.file.header.transfer != TransferKind::Vector {
            return Err(Error::Baker(prt_baker::Error::InvalidOption(format!(
                "{}: --mover-occluder darkens a per-vertex vector bake (not yet a lightmap or \
                 transfer-matrix bake in prt-view; `prt-bake relight --occluder` does texels)",
                bake.file_path.display()
            ))));
        }
        Ok(MoverShadow {
            occluder,
            occlusion: Occlusion::new(bake.order()),
            base: bake.file.coefficients.clone(),
            positions: bake.scene.positions.clone(),
            normals: bake.scene.normals.clone(),
            channels: bake.channels(),
        })
    }

    /// The scene's transfer darkened by the occluder at `(position, rotation)`.
    pub fn transfer(&self, (position, rotation): (Vec3, DQuat)) -> Vec<f32> {
        let spheres = self.occluder.placed(position.as_dvec3(), rotation);
        let n = self.occlusion.order() * self.occlusion.order();
        let mut out = self.base.clone();
        let (mut v, mut t, mut product) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for (r, (p, normal)) in self.positions.iter().zip(&self.normals).enumerate() {
            let (p, normal) = (p.as_dvec3(), normal.as_dvec3());
            if !self.occlusion.visibility(p, normal, &spheres, &mut v) {
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
