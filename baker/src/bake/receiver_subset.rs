//! A vertex bake of some objects only (`bake --receivers`): the receiving objects' vertices
//! are baked, every triangle of the scene occludes. Each receiver samples the random stream of
//! its scene vertex, so its transfer is bit for bit the whole bake's at that vertex.
//!
//! Interreflected bakes gather bounced light at the hits of the receivers' rays, which land
//! on the other objects too: those need their own transfer of the previous bounce, so an
//! interreflected subset bakes every vertex and keeps the receivers' rows (the same time as
//! the whole bake; the file is the smaller). Unshadowed and shadowed subsets cast the
//! receivers' rays only.

use std::time::Instant;

use crate::bake::options::{BakeOptions, Mode};
use crate::bake::receivers::{BounceTargets, Receivers};
use crate::bake::subsurface::apply_to_rows;
use crate::bake::transfer::{Estimator, Transfer, bake, bake_receivers, tracer_for};
use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::receiver_section::ReceiverObjects;
use crate::math::medium::Medium;
use crate::scene::Scene;
use crate::support::error::Result;
use crate::support::progress::Progress;
use crate::trace::{Backend, Tracer};

/// Bakes the vertices of `objects` (ascending object indices of `scene`); the transfer's
/// receivers are those vertices in scene order.
pub fn bake_objects(
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    objects: &[u32],
    progress: &dyn Progress,
) -> Result<Transfer> {
    bake_objects_translucent(scene, tracer, options, objects, &[], progress)
}

/// [`bake_objects`], the receivers on materials with a medium in `media` (per scene material;
/// empty: none) given their subsurface transfer ([`crate::bake::subsurface`]; the bake is then
/// RGB). Interreflected: every translucent vertex walks, in the whole bake its walks' bounce
/// light comes from, before the receivers' rows are kept.
pub fn bake_objects_translucent(
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    objects: &[u32],
    media: &[Option<Medium>],
    progress: &dyn Progress,
) -> Result<Transfer> {
    let rows = ReceiverObjects {
        object_count: scene.objects.len() as u32,
        objects: objects.to_vec(),
    }
    .vertices(scene);
    let walker = tracer.filter(|_| media.iter().any(Option::is_some));
    if options.mode == Mode::Interreflected {
        let mut whole = bake(scene, tracer, options, progress)?;
        if let Some(tracer) = walker {
            apply_to_rows(scene, tracer, media, &mut whole, None, progress)?;
        }
        return Ok(keep_rows(whole, &rows));
    }
    let tracer = tracer_for(options, tracer)?;
    let started = Instant::now();
    let all = Receivers::vertices(scene, options);
    let pick = |values: &[glam::Vec3]| rows.iter().map(|&v| values[v as usize]).collect();
    let receivers = Receivers {
        origins: pick(&all.origins),
        normals: pick(&all.normals),
        horizons: None,
        streams: Some(rows.iter().map(|&v| u64::from(v)).collect()),
        strata: all
            .strata
            .as_ref()
            .map(|s| rows.iter().map(|&v| s[v as usize]).collect()),
    };
    let estimator = Estimator::for_receivers(receivers, options)?;
    let baked = bake_receivers(
        scene,
        tracer,
        &estimator,
        &BounceTargets::Vertices,
        progress,
    );
    let mut transfer = Transfer::from_direct(
        options,
        tracer.map_or(Backend::None, |t| t.backend()),
        rows.len(),
        baked,
        started.elapsed().as_secs_f64(),
    );
    if let Some(tracer) = walker {
        apply_to_rows(scene, tracer, media, &mut transfer, Some(&rows), progress)?;
        transfer.seconds = started.elapsed().as_secs_f64();
    }
    Ok(transfer)
}

/// A whole-scene transfer reduced to the vertices `rows` (its rays and time unchanged).
fn keep_rows(mut whole: Transfer, rows: &[u32]) -> Transfer {
    let width = whole.channels
        * whole
            .options
            .transfer
            .floats_per_channel(whole.options.order);
    let mut coefficients = Vec::with_capacity(rows.len() * width);
    for &v in rows {
        let start = v as usize * width;
        coefficients.extend_from_slice(&whole.coefficients[start..start + width]);
    }
    whole.coefficients = coefficients;
    if !whole.visibility.is_empty() {
        whole.visibility = rows.iter().map(|&v| whole.visibility[v as usize]).collect();
    }
    whole.receiver_count = rows.len();
    whole
}

impl CoefficientFile {
    /// Packages a bake of the vertices of `objects` ([`bake_objects`]): the whole file's
    /// header with the receiver section.
    pub fn from_object_bake(
        scene: &Scene,
        transfer: &Transfer,
        objects: &[u32],
    ) -> CoefficientFile {
        let mut file = CoefficientFile::from_bake(scene, transfer);
        file.header.receivers = Some(ReceiverObjects {
            object_count: scene.objects.len() as u32,
            objects: objects.to_vec(),
        });
        file
    }
}
