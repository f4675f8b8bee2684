//! Per-texel transfer: SH lightmaps over a lightmap UV atlas (`prt-bake bake --lightmap`).
//!
//! [`atlas`] says where each triangle lies in the lightmap (the scene's own lightmap UVs, or
//! charts unwrapped by `uvunwrap` or planar projection), [`texels`] turns covered texels into
//! sample points, and the bake runs the same estimator as vertex bakes over those points as
//! [`Receivers`]: same directions, tracing, sums and determinism. `docs/lightmaps.md` describes what exists and what not.

pub mod atlas;
pub mod leaks;
pub mod texels;

use std::time::Instant;

pub use atlas::{Atlas, AtlasSource};
pub use texels::Texels;

use crate::error::Result;
use crate::progress::Progress;
use crate::trace::{Backend, Tracer};
use crate::transfer::{
    BakeOptions, Baked, BounceTargets, Estimator, Receivers, Transfer, Visibility, bake_receivers,
};

/// Padding texels around each chart that [`dilate`] fills: bilinear filtering at a chart's
/// edge reads one texel beyond it, mipmapping further.
pub const DILATION: usize = 2;

/// A texel bake: the atlas, its sample points, and the transfer of all W×H texels
/// (`transfer.vertex_count` = W·H). Texels within [`DILATION`] of a chart hold dilated
/// values; the rest hold zero transfer, zero accessibility and a +z bent normal.
#[derive(Clone, Debug)]
pub struct LightmapBake {
    pub atlas: Atlas,
    pub texels: Texels,
    pub transfer: Transfer,
    /// Per texel: not baked, but filled from baked neighbours.
    pub dilated: Vec<bool>,
    /// Leaking texels moved out to a point of their footprint that does not leak ([`leaks`];
    /// shadowed mode only).
    pub moved: usize,
    /// Covered texels left out as leaking ([`leaks`]; shadowed mode only).
    pub leaking: usize,
}

/// Bakes the transfer of every texel of `atlas` that a triangle covers, in any mode: the
/// valid texels are the receivers of [`crate::transfer::bake_receivers`], and in
/// interreflected mode a bounce hit reads the previous bounce from the lightmap around its
/// lightmap UV ([`BounceTargets::texels`]).
pub fn bake(
    scene: &crate::Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    atlas: Atlas,
    progress: &dyn Progress,
) -> Result<LightmapBake> {
    let tracer = crate::transfer::tracer_for(options, tracer)?;
    let started = Instant::now();
    let mut texels = Texels::rasterise(scene, &atlas);
    let mut settled = leaks::Settled::default();
    if let Some(tracer) = tracer {
        let watertight = texels.watertight(scene, tracer)?;
        let tracer = watertight.as_deref().unwrap_or(tracer);
        settled = leaks::settle(scene, &atlas, &mut texels, tracer, options.seed)?;
    }
    // Watertight for the final texel origins (moved-out ones included).
    let watertight = match tracer {
        Some(t) => texels.watertight(scene, t)?,
        None => None,
    };
    let tracer = watertight.as_deref().or(tracer);
    let receivers: Receivers = texels.receivers();
    let estimator = Estimator::for_receivers(receivers, options)?;
    let targets = BounceTargets::texels(&atlas, &texels);
    let baked = bake_receivers(scene, tracer, &estimator, &targets, progress);
    // In place in the W×H lightmap.
    let width = baked.channels * crate::sh::coeff_count(options.order);
    let texel_count = texels.valid.len();
    let mut coefficients = vec![0.0f32; texel_count * width];
    let mut visibility = Vec::new();
    if tracer.is_some() {
        visibility = vec![
            Visibility {
                accessibility: 0.0,
                bent_normal: glam::Vec3::Z,
                ..Default::default()
            };
            texel_count
        ];
    }
    let valid_indices = texels
        .valid
        .iter()
        .enumerate()
        .filter(|(_, v)| **v)
        .map(|(i, _)| i);
    for (k, i) in valid_indices.enumerate() {
        coefficients[i * width..(i + 1) * width]
            .copy_from_slice(&baked.coefficients[k * width..(k + 1) * width]);
        if tracer.is_some() {
            visibility[i] = baked.visibility[k];
        }
    }
    let dilated = dilate(&texels, width, &mut coefficients, &mut visibility);
    let transfer = Transfer::from_direct(
        options,
        tracer.map_or(Backend::None, |t| t.backend()),
        texel_count,
        Baked {
            coefficients,
            visibility,
            ..baked
        },
        started.elapsed().as_secs_f64(),
    );
    Ok(LightmapBake {
        atlas,
        dilated,
        moved: settled.moved,
        leaking: settled.leaking,
        texels,
        transfer,
    })
}

/// Spreads baked texels into the empty texels around them, [`DILATION`] rings deep: each
/// pass gives every empty texel that touches (8-neighbourhood) a texel filled before the
/// pass the mean of those neighbours. Charts are packed at least [`atlas::PADDING`] = 2
/// texels apart, so the first ring of one chart never mixes in its neighbour. Returns which
/// texels were filled.
pub fn dilate(
    texels: &Texels,
    n: usize,
    coefficients: &mut [f32],
    visibility: &mut [Visibility],
) -> Vec<bool> {
    let (w, h) = (texels.width as usize, texels.height as usize);
    let mut filled = texels.valid.clone();
    let mut dilated = vec![false; w * h];
    for _ in 0..DILATION {
        let before = filled.clone();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if before[i] {
                    continue;
                }
                let mut sum = vec![0.0f32; n];
                let (mut count, mut ao, mut bent) = (0u32, 0.0f32, glam::Vec3::ZERO);
                for (dx, dy) in NEIGHBOURS {
                    let (nx, ny) = (x as isize + dx, y as isize + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if !before[j] {
                        continue;
                    }
                    count += 1;
                    for (s, c) in sum.iter_mut().zip(&coefficients[j * n..(j + 1) * n]) {
                        *s += c;
                    }
                    if let Some(v) = visibility.get(j) {
                        ao += v.accessibility;
                        bent += v.bent_normal;
                    }
                }
                if count == 0 {
                    continue;
                }
                for (c, s) in coefficients[i * n..(i + 1) * n].iter_mut().zip(&sum) {
                    *c = s / count as f32;
                }
                if let Some(v) = visibility.get_mut(i) {
                    v.accessibility = ao / count as f32;
                    v.bent_normal = bent.try_normalize().unwrap_or(glam::Vec3::Z);
                }
                filled[i] = true;
                dilated[i] = true;
            }
        }
    }
    dilated
}

const NEIGHBOURS: [(isize, isize); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];
