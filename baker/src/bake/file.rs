//! A bake packaged as a coefficient file: the header that records how it was made
//! ([`Header::for_bake`]) and the arrays. The file format ([`crate::formats`]) knows nothing
//! of bakes; this is where the two meet.

use crate::bake::adaptive::PILOT_BLOCKS;
use crate::bake::lightmap::LightmapBake;
use crate::bake::options::BakeOptions;
use crate::bake::transfer::Transfer;
use crate::formats::coefficient_file::{CoefficientFile, LightmapBlock};
use crate::formats::header::{Adaptive, Header, VERSION};
use crate::scene::Scene;
use crate::trace::Backend;

impl Header {
    /// The header of a bake of `scene` with `options` on `backend`: `channels` coefficient
    /// vectors per receiver, `receivers` of them, `rays_cast` in all (adaptive bakes record
    /// it). The up axis is the scene's (set [`Header::up`] afterwards to override it).
    pub fn for_bake(
        scene: &Scene,
        options: &BakeOptions,
        backend: Backend,
        channels: usize,
        receivers: usize,
        rays_cast: u64,
    ) -> Header {
        Header {
            version: VERSION,
            order: options.order as u32,
            channels: channels as u32,
            vertex_count: receivers as u64,
            samples_per_vertex: options.samples,
            mode: options.mode,
            transfer: options.transfer,
            bounces: options.bounces,
            bounce_samples: options.effective_bounce_samples(),
            backend,
            sampling: options.sampling,
            seed: options.seed,
            scene_fingerprint: scene.fingerprint(),
            aux: options.aux,
            up: scene.up,
            checksum: 0,
            adaptive: options.target_error.map(|target_error| Adaptive {
                target_error,
                replicates: PILOT_BLOCKS as u32,
                rays_cast,
                // Denoised adaptive bakes sample to their denoised error
                // ([`crate::bake::adaptive_denoised`]).
                after_denoise: options.denoise,
            }),
            receivers: None,
            denoised: options.denoise,
        }
    }
}

impl CoefficientFile {
    /// Packages a bake of `scene` with the settings it was made with; the up axis is the
    /// scene's (set [`Header::up`] afterwards to override it).
    pub fn from_bake(scene: &Scene, transfer: &Transfer) -> CoefficientFile {
        CoefficientFile::from_bake_with(scene, transfer, transfer.coefficients.clone())
    }

    /// [`CoefficientFile::from_bake`] with `coefficients` (the transfer's own) given.
    fn from_bake_with(
        scene: &Scene,
        transfer: &Transfer,
        coefficients: Vec<f32>,
    ) -> CoefficientFile {
        let options = &transfer.options;
        CoefficientFile {
            header: Header::for_bake(
                scene,
                options,
                transfer.backend,
                transfer.channels,
                transfer.receiver_count,
                transfer.rays_cast,
            ),
            coefficients,
            ao: options.aux.ao.then(|| {
                transfer
                    .visibility
                    .iter()
                    .map(|v| v.accessibility)
                    .collect()
            }),
            bent_normal: options
                .aux
                .bent_normal
                .then(|| transfer.visibility.iter().map(|v| v.bent_normal).collect()),
            rays: options
                .target_error
                .map(|_| transfer.visibility.iter().map(|v| v.rays).collect()),
            error_estimate: options.target_error.map(|_| {
                transfer
                    .visibility
                    .iter()
                    .map(|v| v.error_estimate)
                    .collect()
            }),
            lightmap: None,
            probes: None,
        }
    }

    /// Packages a texel bake of `scene`, its arrays moved, not copied (a 2048² lightmap's
    /// coefficients alone are 150 MB of fresh memory to copy into). Returns the
    /// file and the bake's transfer, which no longer holds coefficients.
    pub fn from_lightmap_bake_owned(
        scene: &Scene,
        bake: LightmapBake,
    ) -> (CoefficientFile, Transfer) {
        let LightmapBake {
            atlas,
            texels,
            mut transfer,
            dilated,
            ..
        } = bake;
        let coefficients = std::mem::take(&mut transfer.coefficients);
        let mut file = CoefficientFile::from_bake_with(scene, &transfer, coefficients);
        file.lightmap = Some(LightmapBlock {
            width: atlas.width,
            height: atlas.height,
            scene_vertex_count: scene.vertex_count() as u64,
            scene_triangle_count: scene.triangles.len() as u64,
            texel_size: atlas.texel_size.unwrap_or(0.0),
            source: atlas.source,
            valid: texels.valid,
            dilated,
            uv1: atlas.uv1,
            objects: atlas.objects,
        });
        (file, transfer)
    }

    /// Packages a texel bake of `scene` (a copy: [`CoefficientFile::from_lightmap_bake_owned`]
    /// moves it).
    pub fn from_lightmap_bake(scene: &Scene, bake: &LightmapBake) -> CoefficientFile {
        let mut file = CoefficientFile::from_bake(scene, &bake.transfer);
        file.lightmap = Some(LightmapBlock {
            width: bake.atlas.width,
            height: bake.atlas.height,
            scene_vertex_count: scene.vertex_count() as u64,
            scene_triangle_count: scene.triangles.len() as u64,
            texel_size: bake.atlas.texel_size.unwrap_or(0.0),
            source: bake.atlas.source,
            valid: bake.texels.valid.clone(),
            dilated: bake.dilated.clone(),
            uv1: bake.atlas.uv1.clone(),
            objects: bake.atlas.objects.clone(),
        });
        file
    }
}
