//! Per-texel transfer: SH lightmaps over a lightmap UV atlas (`prt-bake bake --lightmap`).
//!
//! [`atlas`] says where each triangle lies in the lightmap (the scene's own lightmap UVs, or
//! charts unwrapped by `uvunwrap` or planar projection), [`texels`] turns covered texels into
//! sample points, and the bake runs the same estimator as vertex bakes over those points as
//! [`Receivers`]: same directions, tracing, sums and determinism. `docs/guides/lightmaps.md` describes what exists and what not.
//!
//! Part of [`crate::bake`]: may import what it may.

pub mod atlas;
pub mod dilation;
mod footprint;
pub mod leaks;
pub mod objects;
pub mod receiving;
pub mod stitch;
pub mod stitch_factor;
mod stitch_system;
pub mod texels;
pub mod translucent;

use std::time::Instant;

use rayon::prelude::*;

pub use atlas::{Atlas, AtlasSource};
pub use texels::Texels;

use crate::bake::transfer::{
    BakeOptions, Baked, BounceTargets, Estimator, Receivers, Transfer, Visibility, bake_receivers,
};
use crate::support::cpu_time::{process_cpu_seconds, thread_cpu_seconds};
use crate::support::error::Result;
use crate::support::progress::Progress;
use crate::trace::{Backend, Tracer};

pub use dilation::DILATION;

/// A texel bake: the atlas, its sample points, and the transfer of all W×H texels
/// (`transfer.vertex_count` = W·H). Texels within [`DILATION`] of a chart hold dilated
/// values; the rest hold zero transfer, zero accessibility and a +z bent normal.
#[derive(Clone, Debug)]
pub struct LightmapBake {
    pub atlas: Atlas,
    /// The texels; only their size and mask after a bake with [`TexelPoints::Released`].
    pub texels: Texels,
    pub transfer: Transfer,
    /// Per texel: not baked, but filled from baked neighbours.
    pub dilated: Vec<bool>,
    /// Leaking texels moved out to a point of their footprint that does not leak ([`leaks`];
    /// shadowed mode only).
    pub moved: usize,
    /// Covered texels left out as leaking ([`leaks`]; shadowed mode only).
    pub leaking: usize,
    /// The chart seams stitched ([`stitch`]).
    pub seams: SeamReport,
    /// Wall seconds of each stage, in order (`prt-bake bake --verbose` prints them).
    pub stages: Stages,
}

/// A texel bake's stages in the order they ran: (stage, wall seconds, CPU seconds of all
/// threads). The CPU time is the process's, so it counts only this bake's work on a shared
/// machine (0 where it cannot be read).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stages(pub Vec<(&'static str, f64, f64)>);

impl Stages {
    /// Runs `f` as stage `name`, recording its wall and CPU time.
    pub fn time<T>(&mut self, name: &'static str, f: impl FnOnce() -> T) -> T {
        let (started, cpu) = (Instant::now(), process_cpu_seconds());
        let out = f();
        let cpu = match (cpu, process_cpu_seconds()) {
            (Some(before), Some(after)) => after - before,
            _ => 0.0,
        };
        self.0.push((name, started.elapsed().as_secs_f64(), cpu));
        out
    }

    /// One line: "stage 1.23 s (CPU 2.40 s), …".
    pub fn line(&self) -> String {
        let parts: Vec<String> = self
            .0
            .iter()
            .map(|(name, wall, cpu)| format!("{name} {wall:.2} s (CPU {cpu:.2} s)"))
            .collect();
        parts.join(", ")
    }
}

/// A texel bake's receivers before any transfer is baked: the atlas, and its texels after
/// the leak test moved leaking texels out or left them out ([`leaks::settle`]). It is a pure
/// function of the scene, the atlas, the tracer's backend and the seed, so every shard of a
/// texel bake computes the same one ([`crate::distribute`] checks it by fingerprint).
#[derive(Clone, Debug)]
pub struct Prepared {
    pub atlas: Atlas,
    pub texels: Texels,
    pub settled: leaks::Settled,
    /// The atlas's smooth seams, to stitch ([`stitch::seam_partners`]).
    pub seams: Vec<[u32; 3]>,
    /// Which baked texels' ray origins are seam points for the preparation's tracer (in
    /// [`Texels::valid_indices`] order; [`Texels::watertight_known`]), `None` where it does
    /// not route rays by origin or cast none.
    pub seam_points: Option<Vec<bool>>,
    /// The preparation's stage times.
    pub stages: Stages,
}

/// Rasterises `atlas` and, when rays are cast (`tracer`), settles leaking texels.
pub fn prepare(
    scene: &crate::Scene,
    tracer: Option<&dyn Tracer>,
    seed: u64,
    atlas: Atlas,
) -> Result<Prepared> {
    Ok(prepare_traced(scene, tracer, seed, atlas)?.0)
}

/// [`prepare`], and the tracer watertight for the final texels' origins
/// ([`Texels::watertight`]; `None` where `tracer` already is, or casts no rays). Where the
/// leak test moved nothing and left nothing out, that is the leak test's own (the origins are
/// the same), not made twice.
///
/// The seam partners need only the atlas, and the tracer's seam index only the scene: both
/// are sequential for the most part, so they run beside the rasterisation (and the partners
/// beside the seam texels and the leak test too) instead of leaving a core idle. The stages
/// say so: "rasterise + seam index" is both, the seam partners' CPU time is their thread's,
/// and the stages they ran beside count the process's CPU, theirs included.
pub fn prepare_traced<'t>(
    scene: &crate::Scene,
    tracer: Option<&'t dyn Tracer>,
    seed: u64,
    atlas: Atlas,
) -> Result<(Prepared, Option<Box<dyn Tracer + 't>>)> {
    let ((seams, partners_time), traced) = rayon::join(
        || {
            let (started, cpu) = (Instant::now(), thread_cpu_seconds());
            let seams = stitch::seam_partners(scene, &atlas);
            let cpu = match (cpu, thread_cpu_seconds()) {
                (Some(before), Some(after)) => after - before,
                _ => 0.0,
            };
            (seams, (started.elapsed().as_secs_f64(), cpu))
        },
        || rasterise_settled(scene, tracer, seed, &atlas),
    );
    let (texels, settled, (watertight, seam_points), mut stages) = traced?;
    let (wall, cpu) = partners_time;
    stages
        .0
        .push(("seam partners (beside the stages before)", wall, cpu));
    let prepared = Prepared {
        atlas,
        texels,
        settled,
        seams,
        seam_points,
        stages,
    };
    Ok((prepared, watertight))
}

/// The rasterised texels after the leak test, the tracer watertight for them, and the stages.
type Traced<'t> = (Texels, leaks::Settled, texels::Watertight<'t>, Stages);

/// [`prepare_traced`]'s texels: rasterised (beside the tracer's seam index), made
/// watertight and settled by the leak test.
fn rasterise_settled<'t>(
    scene: &crate::Scene,
    tracer: Option<&'t dyn Tracer>,
    seed: u64,
    atlas: &Atlas,
) -> Result<Traced<'t>> {
    let mut stages = Stages::default();
    let (mut texels, ()) = stages.time("rasterise + seam index", || {
        rayon::join(
            || Texels::rasterise(scene, atlas),
            || tracer.map_or((), |t| t.prepare_points(scene)),
        )
    });
    let mut settled = leaks::Settled::default();
    let mut watertight = (None, None);
    if let Some(tracer) = tracer {
        watertight = stages.time("seam texels", || texels.watertight_keeping(scene, tracer))?;
        let view = watertight.0.as_deref().unwrap_or(tracer);
        settled = stages.time("leak test", || {
            leaks::settle(scene, atlas, &mut texels, view, seed)
        })?;
        if settled != leaks::Settled::default() {
            // Texels moved out or left out: watertight for the final origins.
            watertight = stages.time("seam texels", || texels.watertight_keeping(scene, tracer))?;
        }
        tracer.release_points();
    }
    Ok((texels, settled, watertight, stages))
}

/// Bakes the transfer of every texel of `atlas` that a triangle covers, in any mode: the
/// valid texels are the receivers of [`crate::bake::transfer::bake_receivers`], and in
/// interreflected mode a bounce hit reads the previous bounce from the lightmap around its
/// lightmap UV ([`BounceTargets::texels`]).
pub fn bake(
    scene: &crate::Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    atlas: Atlas,
    progress: &dyn Progress,
) -> Result<LightmapBake> {
    bake_translucent(scene, tracer, options, atlas, &[], progress)
}

/// [`bake`], the texels of materials with a medium in `media` (per scene material; empty:
/// none) baked as subsurface receivers ([`translucent`]) before placing; the bake is then RGB.
pub fn bake_translucent(
    scene: &crate::Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    atlas: Atlas,
    media: &[Option<crate::math::medium::Medium>],
    progress: &dyn Progress,
) -> Result<LightmapBake> {
    bake_texels(
        scene,
        tracer,
        options,
        atlas,
        media,
        TexelPoints::Kept,
        progress,
    )
}

/// Whether a texel bake's result keeps its texels' points. `Released`: the points move into
/// the bake's receivers instead of being copied, and [`LightmapBake::texels`] keeps only its
/// size and mask, which lowers the peak by 52 bytes a texel (218 MB at 2048²; `prt-bake
/// bake`, which writes no point). Subsurface texels need their points to the end, so with a
/// medium they are kept either way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexelPoints {
    Kept,
    Released,
}

/// [`bake_translucent`], keeping the texels' points or not.
pub fn bake_texels(
    scene: &crate::Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    atlas: Atlas,
    media: &[Option<crate::math::medium::Medium>],
    points: TexelPoints,
    progress: &dyn Progress,
) -> Result<LightmapBake> {
    let tracer = crate::bake::transfer::tracer_for(options, tracer)?;
    if options.transfer == crate::bake::options::TransferKind::Matrix {
        return Err(crate::Error::InvalidOption(
            "--transfer matrix with --lightmap is not supported yet: texel bakes store \
             transfer vectors"
                .into(),
        ));
    }
    let started = Instant::now();
    let (prepared, watertight) = prepare_traced(scene, tracer, options.seed, atlas)?;
    let Prepared {
        atlas,
        mut texels,
        settled,
        seams,
        mut stages,
        ..
    } = prepared;
    // Watertight for the final texel origins (moved-out ones included).
    let tracer = watertight.as_deref().or(tracer);
    // The denoiser's guides read the texels' points, which the receivers may take.
    let mut guides = match (options.denoise, tracer) {
        (true, Some(_)) => Some(crate::bake::denoise::texel_guides(
            scene,
            &atlas,
            &texels,
            Vec::new(),
        )),
        _ => None,
    };
    // Only subsurface texels read their points after this.
    let receivers: Receivers = match points {
        TexelPoints::Released if media.iter().all(Option::is_none) => {
            Receivers::take_texels(&mut texels)
        }
        _ => Receivers::texels(&texels),
    };
    let estimator = Estimator::for_receivers(receivers, options)?;
    let targets = BounceTargets::texels(&atlas, &texels);
    let stitching = Stitching {
        partners: &seams,
        uv1: &atlas.uv1,
    };
    // Where the seams read depends only on which texels will hold a value (baked, or dilated
    // from baked ones), not on the values: the seam samples are found now, and the stitch's
    // system (its ordering and factorisation are sequential: about 2 CPU-s on a 720,000-triangle
    // heightfield's planar atlas) is factored beside the bake's rays, by whichever worker is
    // free, instead of after them while the other cores wait. The bits are the same.
    let samples = stages.time("seam points", || {
        let dilated = dilation::dilate_rings(&texels, |_| {});
        seam_samples(&texels, &dilated, &stitching)
    });
    // An adaptive bake denoised samples until its denoised estimate is within the target,
    // and denoises as it goes ([`crate::bake::adaptive_denoised`]). Its texels take different
    // rays and its filter is formed every pass, so it keeps the 3 × 3 clusters whatever
    // `--samples` says (`Settings::texels` is for fixed bakes; adaptive bakes have no parts),
    // with the order's range term.
    let adaptive_guides = guides
        .take_if(|_| crate::bake::adaptive_denoised::applies(options, tracer))
        .zip(tracer);
    let (mut baked, (factored, factor_seconds)) = stages.time("bake", || {
        rayon::join(
            || match adaptive_guides {
                Some((guides, tracer)) => crate::bake::transfer::denoised_adaptive(
                    &estimator,
                    tracer,
                    guides,
                    crate::bake::denoise::Settings::TEXELS.at_order(options.order),
                    progress,
                ),
                None => bake_receivers(scene, tracer, &estimator, &targets, progress),
            },
            || {
                let started = Instant::now();
                let factored = stitch::factor(&samples);
                (factored, started.elapsed().as_secs_f64())
            },
        )
    });
    // Its wall time stands for its CPU time: the ordering and factorisation, most of it, are
    // sequential (the assembly is parallel).
    stages.0.push((
        "stitch factor (beside the bake)",
        factor_seconds,
        factor_seconds,
    ));
    if let (true, Some(tracer)) = (media.iter().any(Option::is_some), tracer) {
        stages.time("subsurface", || {
            translucent::apply_to_texels(
                scene, tracer, media, options, &texels, &targets, &mut baked, progress,
            )
        })?;
    }
    if let Some(guides) = guides {
        stages.time("denoise", || {
            crate::bake::denoise::stage::denoise_baked(
                guides,
                crate::bake::denoise::Settings::texels(options.samples, options.order),
                options,
                &mut baked.coefficients,
                baked.channels,
                &mut baked.visibility,
            )
        });
    }
    let width = baked.channels * crate::math::sh::coeff_count(options.order);
    let backend = tracer.map_or(Backend::None, |t| t.backend());
    // No more rays: the watertight tracer's acceleration structure goes before the
    // stitch, the bake's peak of memory (docs/guides/lightmaps.md, "At scale").
    let casts_rays = tracer.is_some();
    drop((watertight, estimator, targets));
    let visibility = casts_rays.then_some(baked.visibility.as_slice());
    let placed = place_unstitched(&texels, width, &baked.coefficients, visibility, &mut stages);
    let placed = stitch_placed(placed, width, &samples, Some(&factored), &mut stages);
    let transfer = Transfer::from_direct(
        options,
        backend,
        texels.valid.len(),
        Baked {
            coefficients: placed.coefficients,
            visibility: placed.visibility,
            ..baked
        },
        started.elapsed().as_secs_f64(),
    );
    Ok(LightmapBake {
        atlas,
        dilated: placed.dilated,
        seams: placed.seams,
        moved: settled.moved,
        leaking: settled.leaking,
        texels,
        transfer,
        stages,
    })
}

/// The valid texels' values put in place in the W×H lightmap and dilated.
pub struct Placed {
    /// `width` floats per texel, W·H texels; empty texels hold zeros.
    pub coefficients: Vec<f32>,
    /// Per texel (empty where no visibility was given); empty texels hold accessibility 0
    /// and a +z bent normal.
    pub visibility: Vec<Visibility>,
    /// Per texel: filled by dilation.
    pub dilated: Vec<bool>,
    /// What stitching the seams did.
    pub seams: SeamReport,
}

/// The seams [`place`] stitches: per triangle and edge its partner
/// ([`stitch::seam_partners`]), and the atlas's UVs per triangle.
pub struct Stitching<'a> {
    pub partners: &'a [[u32; 3]],
    pub uv1: &'a [[glam::Vec2; 3]],
}

/// What [`stitch`] did to a lightmap: its seam samples, and the step across them (RMS over
/// the samples of the first coefficient's difference) before and after.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SeamReport {
    pub samples: usize,
    pub step_before: f64,
    pub step_after: f64,
    /// Nonzeros of the stitching system's Cholesky factor (0: nothing stitched).
    pub factor_nonzeros: usize,
}

/// Places the receivers' values (`width` floats each, in row-major order of the valid
/// texels) and their visibility (if any) in the W×H lightmap of `texels`, dilates them and
/// stitches the seams ([`stitch`]): what a whole bake, the merge of its shard parts and a
/// checkpointed bake all end with.
pub fn place(
    texels: &Texels,
    width: usize,
    receivers: &[f32],
    receiver_visibility: Option<&[Visibility]>,
    stitching: &Stitching<'_>,
    stages: &mut Stages,
) -> Placed {
    let placed = place_unstitched(texels, width, receivers, receiver_visibility, stages);
    let samples = stages.time("seam points", || {
        seam_samples(texels, &placed.dilated, stitching)
    });
    stitch_placed(placed, width, &samples, None, stages)
}

/// Stitches `placed` along `samples`: with their system if it was `factored` already, else
/// factoring it here.
fn stitch_placed(
    mut placed: Placed,
    width: usize,
    samples: &[stitch::SeamSample],
    factored: Option<&stitch::Factored>,
    stages: &mut Stages,
) -> Placed {
    let (coefficients, visibility) = (&mut placed.coefficients, &mut placed.visibility);
    let step_before = stitch::seam_step(samples, coefficients, width, 0).0;
    let factor_nonzeros = stages.time("stitch", || {
        let mut ao: Vec<f32> = visibility.iter().map(|v| v.accessibility).collect();
        let ao_width = usize::from(!ao.is_empty());
        let fields = &mut [(&mut coefficients[..], width), (&mut ao[..], ao_width)];
        let factor_nonzeros = match factored {
            Some(factored) => stitch::stitch_factored(factored, fields),
            None => stitch::stitch_fields(samples, fields),
        };
        // Least squares may overshoot a little; accessibility is a fraction.
        for (v, a) in visibility.iter_mut().zip(ao) {
            v.accessibility = clamp_accessibility(a);
        }
        factor_nonzeros
    });
    placed.seams = SeamReport {
        samples: samples.len(),
        step_before,
        step_after: stitch::seam_step(samples, coefficients, width, 0).0,
        factor_nonzeros,
    };
    placed
}

/// A stitched accessibility made a fraction again (least squares may overshoot a little).
pub fn clamp_accessibility(a: f32) -> f32 {
    a.clamp(0.0, 1.0)
}

/// The seam samples [`place`] stitches along: the seams of `stitching` over the texels that
/// hold a value (baked, or filled by dilation: `dilated`).
pub fn seam_samples(
    texels: &Texels,
    dilated: &[bool],
    stitching: &Stitching<'_>,
) -> Vec<stitch::SeamSample> {
    let filled: Vec<bool> = texels
        .valid
        .iter()
        .zip(dilated)
        .map(|(v, d)| *v || *d)
        .collect();
    stitch::seam_samples(
        stitching.partners,
        stitching.uv1,
        texels.width,
        texels.height,
        &filled,
    )
}

/// [`place`] without stitching: the values placed and dilated, `seams` empty. A sharded
/// bake stitches apart, a few columns per shard (`prt-bake stitch`).
pub fn place_unstitched(
    texels: &Texels,
    width: usize,
    receivers: &[f32],
    receiver_visibility: Option<&[Visibility]>,
    stages: &mut Stages,
) -> Placed {
    let texel_count = texels.valid.len();
    let mut coefficients = vec![0.0f32; texel_count * width];
    let mut visibility = Vec::new();
    if receiver_visibility.is_some() {
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
            .copy_from_slice(&receivers[k * width..(k + 1) * width]);
        if let Some(from) = receiver_visibility {
            visibility[i] = from[k];
        }
    }
    let dilated = stages.time("dilate", || {
        dilate(texels, width, &mut coefficients, &mut visibility)
    });
    Placed {
        coefficients,
        visibility,
        dilated,
        seams: SeamReport::default(),
    }
}

/// Spreads baked texels' coefficients (`n` per texel) and visibility (if any) into the
/// empty texels around them ([`dilation`]). Returns which texels were filled.
pub fn dilate(
    texels: &Texels,
    n: usize,
    coefficients: &mut [f32],
    visibility: &mut [Visibility],
) -> Vec<bool> {
    let w = texels.width as usize;
    dilation::dilate_rings(texels, |ring| {
        dilation::mean_ring(ring, w, n, coefficients);
        if visibility.is_empty() {
            return;
        }
        for block in ring.chunks(dilation::RING_BLOCK) {
            let source = &*visibility;
            let means: Vec<(f32, glam::Vec3)> = block
                .par_iter()
                .map(|f| {
                    let (sources, count) = f.sources(w);
                    let (mut ao, mut bent) = (0.0f32, glam::Vec3::ZERO);
                    for &j in &sources[..count] {
                        ao += source[j].accessibility;
                        bent += source[j].bent_normal;
                    }
                    let bent = bent.try_normalize().unwrap_or(glam::Vec3::Z);
                    (ao / count as f32, bent)
                })
                .collect();
            for (f, (ao, bent)) in block.iter().zip(means) {
                let v = &mut visibility[f.texel as usize];
                v.accessibility = ao;
                v.bent_normal = bent;
            }
        }
    })
}
