//! Subsurface transfer per texel: a texel bake's translucent texels (those whose triangle's
//! material has a medium, from `bake --materials`) get the random-walk estimate of
//! [`crate::bake::subsurface`] at their point and normal, in place of their opaque transfer,
//! before the lightmap is placed, dilated and stitched (`docs/guides/subsurface.md`).
//!
//! The estimator is the vertex bake's own; only the receivers differ. A walk starts below the
//! texel's point, where its ray origin mirrored through the tangent plane lies (as a
//! vertex's does), and draws from the stream of its texel index y·W + x, so a texel's walks do
//! not depend on which other texels are baked nor on the thread count. In interreflected mode
//! a path that leaves and hits an opaque front face reads the final lightmap there (placed
//! and dilated, bilinear around the hit's lightmap UV), as the texel bake's bounces read it.

use crate::bake::options::Mode;
use crate::bake::receivers::BounceTargets;
use crate::bake::subsurface::{Bounced, Points, Walks, bake_points, check_media, to_rgb};
use crate::bake::transfer::{BakeOptions, Baked};
use crate::math::medium::Medium;
use crate::scene::Scene;
use crate::support::error::Result;
use crate::support::progress::Progress;
use crate::trace::Tracer;

use super::texels::Texels;

/// The valid texels of `texels` whose triangle's material has a medium, as subsurface
/// receivers (`receiver`: the texel index y·W + x), and each one's rank among the valid
/// texels (its row in a texel bake's receiver-ordered values).
pub fn texel_points(
    scene: &Scene,
    texels: &Texels,
    media: &[Option<Medium>],
) -> (Points, Vec<usize>) {
    let mut points = Points::default();
    let mut ranks = Vec::new();
    let valid = texels.valid.iter().enumerate().filter(|(_, v)| **v);
    for (rank, (i, _)) in valid.enumerate() {
        let triangle = texels.triangle[i] as usize;
        let material = scene.vertex_material[scene.triangles[triangle][0] as usize];
        if media.get(material as usize).is_none_or(Option::is_none) {
            continue;
        }
        let (p, n, origin) = (texels.positions[i], texels.normals[i], texels.origins[i]);
        points.receiver.push(i);
        points.position.push(p);
        points.normal.push(n);
        // The ray origin mirrored through the tangent plane, as for vertices.
        points.inside.push(origin - 2.0 * (origin - p).dot(n) * n);
        points.material.push(material);
        ranks.push(rank);
    }
    (points, ranks)
}

/// Replaces the transfer of `baked`'s translucent texels (one row per valid texel of
/// `texels`) by their subsurface transfer, making it RGB (a grey bake's channel is copied to
/// all three). Interreflected bakes' leaving paths read the lightmap through `targets`.
#[allow(clippy::too_many_arguments)]
pub fn apply_to_texels(
    scene: &Scene,
    tracer: &dyn Tracer,
    media: &[Option<Medium>],
    options: &BakeOptions,
    texels: &Texels,
    targets: &BounceTargets,
    baked: &mut Baked,
    progress: &dyn Progress,
) -> Result<()> {
    check_media(scene, media)?;
    let n = options.order * options.order;
    let (points, ranks) = texel_points(scene, texels, media);
    let slots = match options.mode {
        Mode::Interreflected => Some(targets.slot_values(&baked.coefficients, baked.channels * n)),
        _ => None,
    };
    let walks = Walks {
        scene,
        tracer,
        media,
        order: options.order,
        samples: options.samples,
        seed: options.seed,
        bounced: slots.as_deref().map(|slots| Bounced {
            slots,
            channels: baked.channels,
            targets,
        }),
    };
    let (walked, rays) = bake_points(&walks, &points, progress);
    let mut rgb = to_rgb(&baked.coefficients, baked.channels, n);
    for (i, &rank) in ranks.iter().enumerate() {
        rgb[rank * 3 * n..(rank + 1) * 3 * n].copy_from_slice(&walked[i * 3 * n..(i + 1) * 3 * n]);
    }
    baked.coefficients = rgb;
    baked.channels = 3;
    baked.rays_cast += rays;
    Ok(())
}
