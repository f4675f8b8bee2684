//! Interreflected transfer: light that reaches a receiver (a vertex or a lightmap texel) after bouncing off other surfaces, in
//! colour (Green's bounce method; the thesis's step beyond shadows).
//!
//! Bounce k at vertex x integrates, over the rays from x whose first hit h(s) lies on a front
//! face,
//!
//! ```text
//!     T_k(x) = (1/π) ∫ max(n·s, 0) · ρ(h) · T̃_{k−1}(h) ds
//! ```
//!
//! where ρ(h) is the hit surface's albedo (Kd × texture at the hit's uv, per channel) and
//! T̃_{k−1}(h) the previous bounce's transfer at the hit: interpolated with the hit's
//! barycentrics in a vertex bake (over the triangle's corners that are not embedded in other
//! geometry, renormalised: [`crate::bake::bounce_rows::Embedded`]), sampled bilinearly at the hit's
//! lightmap UV in a texel bake ([`crate::bake::receivers::BounceTargets`]);
//! T_0 is the shadowed transfer and the result is T_0 + T_1 + … + T_B. The SH basis never
//! appears in a bounce: it is carried by T_0, so a bounce is a weighted gather of vertex
//! transfers over the first hits.
//!
//! *Front face* means the side the hit's interpolated shading normal points to — the side
//! whose transfer was baked. A ray that reaches a back face is blocked (it counts as
//! occluded in T_0) and adds nothing: light does not pass through or reflect off the inside
//! of a closed object. Scenes must be wound (or have normals) accordingly.
//!
//! Transfer becomes three channels (R, G, B) unless every albedo in the scene is grey.
//!
//! # Bounce rows, and memory
//!
//! A bounce is linear in the previous bounce's *vertex* values: T_k(x) = Σ_v w(x, v) ⊙ T_{k−1}(v),
//! where w(x, v) sums, over the bounce rays of x whose front hit lands on a triangle of v,
//! the estimator weight × albedo × v's barycentric weight. The direct pass folds each
//! vertex's hits into this sparse *bounce row* once: hits cluster on shared vertices, so a
//! row is far shorter than three entries per hit, and every bounce is then a cheap gather
//! with no rays. An entry is 16 bytes (vertex u32, RGB weight 3 × f32).
//!
//! In a texel bake the entries name texels instead (the 4 around the hit's lightmap UV, by
//! bilinear weight), and the previous bounce's values are those of the whole lightmap: the
//! valid texels' values put in place and dilated, as the final lightmap is, so that a hit
//! near a chart's edge reads what a renderer would read there
//! ([`crate::bake::receivers::BounceTargets::slot_values`]). Rows, re-tracing and determinism
//! are the same code as for vertices; the cache differs: a texel's hits almost never share a
//! texel, so its folded row (2.6 entries, 42 bytes, per bounce ray) would outweigh the hits
//! themselves, and the cache keeps each front hit (12 bytes) and folds it again in every
//! bounce pass, bit for bit as the direct pass would have ([`JobRows`]).
//!
//! # Bounce samples
//!
//! Closest-hit rays cost two to four times as much as occlusion rays, and bounced light is
//! dimmer and smoother than direct light. So only the first M of a vertex's N directions —
//! the first points of its sample sequence, a stratified set of their own; M = N/4 unless
//! `--bounce-samples` says otherwise — are traced for their closest hits, each weighted
//! N/M; the other N − M stay occlusion rays. All N still estimate T_0, the accessibility and
//! the bent normal. The bounce estimate is unbiased, with the error of M samples.
//!
//! If the rows would exceed `BakeOptions::hit_cache_limit` they are dropped, and each
//! bounce pass re-traces the (deterministic) rays to rebuild one row at a time: the same
//! result with memory O(vertices × coefficients), at the cost of a tracing pass per bounce.

use glam::Vec3;
use rayon::prelude::*;

use std::borrow::Cow;
use std::sync::Arc;

use crate::bake::bounce_rows::{Embedded, HitCache, HitRecorder, JobRows, RowBuilder};
use crate::bake::estimator::{Estimator, Scratch, Visibility, direct_pass};
use crate::bake::options::BakeOptions;
use crate::bake::receivers::BounceTargets;
use crate::bake::receivers::RECEIVERS_PER_JOB;
use crate::math::sh;
use crate::scene::Scene;
use crate::support::progress::Progress;
use crate::trace::Tracer;

pub use crate::bake::bounce_rows::{BYTES_PER_ENTRY, BYTES_PER_HIT, Rows, decode_entry};

/// What an interreflected bake produces.
pub(crate) struct Bounced {
    /// `coefficients[(v · channels + c) · n² + j]`, the sum over bounces 0..=B.
    pub coefficients: Vec<f32>,
    pub channels: usize,
    pub visibility: Vec<Visibility>,
    /// Bytes of cached bounce rows, or `None` when the bounces re-traced.
    pub hit_cache_bytes: Option<u64>,
}

/// Whether every albedo in the scene is grey (R = G = B), so one channel suffices.
pub fn albedo_is_grey(scene: &Scene) -> bool {
    let grey = |c: Vec3| c.x == c.y && c.y == c.z;
    scene
        .materials
        .iter()
        .all(|m| grey(m.kd) && m.texture.is_none_or(|t| scene.textures[t].is_grey()))
}

/// The interreflected bake of the estimator's receivers, whose bounce hits read `targets`:
/// the direct pass (recording hits), then `bounces` gather passes.
pub(crate) fn bake(
    scene: &Scene,
    tracer: &dyn Tracer,
    estimator: &Estimator,
    targets: &BounceTargets,
    progress: &dyn Progress,
) -> Bounced {
    let options = &estimator.options;
    let channels = if albedo_is_grey(scene) { 1 } else { 3 };
    let receivers = estimator.receiver_count();
    let recorder = HitRecorder::new(scene, targets, receivers, options.hit_cache_limit);
    let direct = direct_pass(
        estimator,
        Some(tracer),
        Some(&recorder),
        0..receivers,
        progress,
    );
    let embedded = recorder.embedded();
    let cache = recorder.into_cache();
    let hit_cache_bytes = cache.as_ref().map(|(_, bytes)| *bytes);
    let cache = cache.map(|(jobs, _)| jobs);
    let rows = match &cache {
        Some(jobs) => RowSource::Jobs(jobs),
        None => RowSource::Retrace {
            scene,
            tracer,
            estimator,
            targets,
            embedded: &embedded,
        },
    };
    Bounced {
        coefficients: add_bounces(
            direct.coefficients,
            channels,
            options,
            &rows,
            targets,
            progress,
        ),
        channels,
        visibility: direct.visibility,
        hit_cache_bytes,
    }
}

/// Where a bounce pass finds each receiver's bounce row.
pub(crate) enum RowSource<'a> {
    /// The direct pass's rows, job by job ([`RECEIVERS_PER_JOB`] receivers each).
    Jobs(&'a HitCache<'a>),
    /// Rows in memory, one per receiver in order (checkpoint blocks joined, or a shard part
    /// the merge has read).
    Flat(&'a Rows),
    /// Rows as a part file stores them, read in place (a shard's gather).
    Packed(&'a PackedRows),
    /// Re-trace each receiver's bounce samples (the rows were over the hit-cache budget).
    Retrace {
        scene: &'a Scene,
        tracer: &'a dyn Tracer,
        estimator: &'a Estimator,
        targets: &'a BounceTargets<'a>,
        /// The direct pass's embedded vertices ([`Embedded`]), shared.
        embedded: &'a Arc<Embedded>,
    },
}

/// The interreflected transfer from the direct pass's `t0` (one channel, every receiver) and
/// the bounce rows, read through `targets`: T_0 broadcast to `channels`, plus
/// `options.bounces` gathers. The single-machine bake and the merge of checkpoint blocks end
/// here; the merge of shard parts ends in [`sum_bounces`] with the same [`bounce_pass`]: the
/// same sums of the same floats in the same order, so they agree bit for bit.
///
/// Memory: every bounce holds two receiver-sized arrays, not three (so that a 2048² texel
/// bake of a million triangles peaks under 1.5 GB). The
/// slots are built in place from the previous bounce ([`BounceTargets::into_slot_values`]);
/// bounce 1 in one channel reads T_0 from the total itself, which is given back, bit for bit,
/// after the gather ([`BounceTargets::from_slot_values`]); and the last bounce is added to
/// the total receiver by receiver instead of into an array of its own.
pub(crate) fn add_bounces(
    t0: Vec<f32>,
    channels: usize,
    options: &BakeOptions,
    rows: &RowSource,
    targets: &BounceTargets,
    progress: &dyn Progress,
) -> Vec<f32> {
    let n = sh::coeff_count(options.order);
    let norm = Estimator::norm_of(options) as f32;
    let rays = match rows {
        RowSource::Retrace { .. } => u64::from(options.samples),
        _ => 0,
    };
    let receivers = t0.len() / n;
    let (mut total, mut previous) = broadcast_t0(t0, channels, n);
    let mut previous_channels = 1;
    for k in 1..=options.bounces {
        progress.begin(&format!("bounce {k}"), receivers as u64, rays);
        // Bounce 1 in one channel: T_0 is the total so far, lent to the slots.
        let lent = previous.is_none();
        let values = previous
            .take()
            .unwrap_or_else(|| std::mem::take(&mut total));
        let slots = targets.into_slot_values(values, previous_channels * n);
        let pass = |next: &mut [f32], add: bool| {
            bounce_pass_into(
                rows,
                norm,
                n,
                &slots,
                previous_channels,
                channels,
                (next, add),
                progress,
            )
        };
        if k == options.bounces && !lent {
            pass(&mut total, true);
            progress.finish();
            break;
        }
        let mut next = vec![0.0f32; receivers * channels * n];
        pass(&mut next, false);
        progress.finish();
        if lent {
            total = targets.from_slot_values(slots, n);
        } else {
            drop(slots);
        }
        for (t, b) in total.iter_mut().zip(&next) {
            *t += b;
        }
        previous = Some(next);
        previous_channels = channels;
    }
    total
}

/// The total's start, T_0 (one channel) broadcast to `channels`, and T_0 itself where the
/// total is a copy of it (`None`: in one channel the total is T_0).
fn broadcast_t0(t0: Vec<f32>, channels: usize, n: usize) -> (Vec<f32>, Option<Vec<f32>>) {
    if channels == 1 {
        return (t0, None);
    }
    let mut total = vec![0.0f32; t0.len() * channels];
    for (v, t0) in t0.chunks_exact(n).enumerate() {
        for c in 0..channels {
            total[(v * channels + c) * n..][..n].copy_from_slice(t0);
        }
    }
    (total, Some(t0))
}

/// T_0 (`t0`, one channel, every vertex) broadcast to `channels`, plus `options.bounces`
/// bounces, each of which `bounce` writes into a zeroed array from the previous one (and its
/// channel count). `rays_per_vertex` is for the progress bar.
///
/// `bounce` gets the previous bounce to keep or drop: a texel bake drops it once it has
/// placed it in its lightmap, and in one channel T_0 is the total itself rather than a copy,
/// so a bounce holds three arrays of the receivers' size, not five (so that a 2048² texel
/// bake of a million triangles peaks under 1.5 GB).
pub(crate) fn sum_bounces<E, F>(
    t0: Vec<f32>,
    channels: usize,
    options: &BakeOptions,
    rays_per_vertex: u64,
    progress: &dyn Progress,
    mut bounce: F,
) -> Result<Vec<f32>, E>
where
    F: FnMut(Cow<[f32]>, usize, &mut [f32]) -> Result<(), E>,
{
    let n = sh::coeff_count(options.order);
    let vertex_count = t0.len() / n;
    // Total = T_0 (grey) broadcast to every channel, plus each bounce.
    let (mut total, mut previous) = broadcast_t0(t0, channels, n);
    let mut previous_channels = 1;
    for k in 1..=options.bounces {
        progress.begin(&format!("bounce {k}"), vertex_count as u64, rays_per_vertex);
        let mut next = vec![0.0f32; vertex_count * channels * n];
        let from = match previous.take() {
            Some(previous) => Cow::Owned(previous),
            // Bounce 1 in one channel: T_0 is the total so far.
            None => Cow::Borrowed(&total[..]),
        };
        bounce(from, previous_channels, &mut next)?;
        progress.finish();
        for (t, b) in total.iter_mut().zip(&next) {
            *t += b;
        }
        previous = Some(next);
        previous_channels = channels;
    }
    Ok(total)
}

/// One bounce: T_k(x) = norm · Σ_v w(x, v) ⊙ T_{k−1}(v) for every receiver x whose row
/// `rows` holds (the k-th receiver's result goes to `next`'s k-th `channels × n²` floats;
/// `previous` holds the previous bounce at every slot). The bake, the merge of checkpoint
/// blocks and the merge of shard parts (one part's rows at a time) all gather here.
#[allow(clippy::too_many_arguments)]
pub(crate) fn bounce_pass(
    rows: &RowSource,
    norm: f32,
    n: usize,
    previous: &[f32],
    previous_channels: usize,
    channels: usize,
    next: &mut [f32],
    progress: &dyn Progress,
) {
    bounce_pass_into(
        rows,
        norm,
        n,
        previous,
        previous_channels,
        channels,
        (next, false),
        progress,
    );
}

/// [`bounce_pass`] into `next` as it is, or, with `add`, added to it receiver by receiver:
/// each receiver's bounce is the same floats either way, and `next += bounce` the same sum
/// a whole array of the bounce would have added.
#[allow(clippy::too_many_arguments)]
fn bounce_pass_into(
    rows: &RowSource,
    norm: f32,
    n: usize,
    previous: &[f32],
    previous_channels: usize,
    channels: usize,
    (next, add): (&mut [f32], bool),
    progress: &dyn Progress,
) {
    let width = channels * n;
    next.par_chunks_mut(RECEIVERS_PER_JOB * width)
        .enumerate()
        .for_each_init(
            || (Scratch::new(n), RowBuilder::default(), vec![0.0f32; width]),
            |(scratch, builder, bounce), (job, next)| {
                let first = job * RECEIVERS_PER_JOB;
                for (k, next) in next.chunks_mut(width).enumerate() {
                    let out = if add { &mut bounce[..] } else { &mut next[..] };
                    let gather = |vertices: &[u32], weights: &[[f32; 3]], out: &mut [f32]| {
                        let entries = vertices.iter().copied().zip(weights.iter().copied());
                        gather(entries, previous, previous_channels, channels, n, out)
                    };
                    match rows {
                        RowSource::Packed(rows) => {
                            let entries = rows.row(first + k);
                            self::gather(entries, previous, previous_channels, channels, n, out);
                        }
                        RowSource::Jobs(jobs) => {
                            let (vertices, weights) = jobs.row(job, k, builder);
                            gather(vertices, weights, out);
                        }
                        RowSource::Flat(rows) => {
                            let range = rows.vertex(first + k);
                            gather(&rows.vertices[range.clone()], &rows.weights[range], out);
                        }
                        RowSource::Retrace {
                            scene,
                            tracer,
                            estimator,
                            targets,
                            embedded,
                        } => {
                            // Same rays as the direct pass, so the same row.
                            let mut fresh = JobRows::new(scene, targets, Arc::clone(embedded));
                            estimator.bounce_row(first + k, *tracer, scratch, &mut fresh);
                            let (vertices, weights) = fresh.row(0, builder);
                            gather(vertices, weights, out);
                        }
                    }
                    for o in out.iter_mut() {
                        *o *= norm;
                    }
                    if add {
                        for (t, b) in next.iter_mut().zip(bounce.iter()) {
                            *t += b;
                        }
                    }
                }
                progress.advance((next.len() / width) as u64);
            },
        );
}

/// `out` = Σ over a row's entries of weight ⊙ the previous bounce's transfer at the entry's
/// slot.
fn gather(
    entries: impl Iterator<Item = (u32, [f32; 3])>,
    previous: &[f32],
    previous_channels: usize,
    channels: usize,
    n: usize,
    out: &mut [f32],
) {
    out.fill(0.0);
    for (vertex, weight) in entries {
        let vertex = vertex as usize;
        for c in 0..channels {
            let from = if previous_channels == 1 { 0 } else { c };
            let row = &previous[(vertex * previous_channels + from) * n..][..n];
            for (o, t) in out[c * n..(c + 1) * n].iter_mut().zip(row) {
                *o += weight[c] * t;
            }
        }
    }
}

/// Bounce rows as a shard part stores them, read where they lie in the file's bytes: per
/// receiver its entry count (u32), then 16-byte entries (slot u32, RGB weight 3 × f32, little
/// endian), or 8-byte ones (slot, one weight for all three channels) where every weight is
/// grey. A gather reads each row once, so copying them into [`Rows`] first would only
/// double the memory it touches (a part's rows are hundreds of megabytes at 2048²).
pub struct PackedRows {
    /// The file's bytes: in memory, or mapped.
    bytes: Box<dyn std::ops::Deref<Target = [u8]> + Send + Sync>,
    /// Where the first entry starts in `bytes`.
    at: usize,
    /// Entries of receiver k are `starts[k]..starts[k + 1]`.
    starts: Vec<u64>,
    /// Entries of one weight ([`GREY_BYTES_PER_ENTRY`] bytes each).
    grey: bool,
}

/// Bytes per grey bounce-row entry of a part: slot and one weight for R, G and B.
pub const GREY_BYTES_PER_ENTRY: u64 = 4 + 4;

impl PackedRows {
    /// The rows whose entries start at byte `at` of `bytes`, with `starts` as in [`Rows`]
    /// (the caller has checked that `bytes` holds them all); `grey`: 8-byte entries.
    pub fn new(
        bytes: impl std::ops::Deref<Target = [u8]> + Send + Sync + 'static,
        at: usize,
        starts: Vec<u64>,
        grey: bool,
    ) -> PackedRows {
        PackedRows {
            bytes: Box::new(bytes),
            at,
            starts,
            grey,
        }
    }

    /// The whole file's bytes the rows were read from.
    pub fn file_bytes(&self) -> &[u8] {
        &self.bytes
    }

    fn entry_bytes(&self) -> usize {
        match self.grey {
            true => GREY_BYTES_PER_ENTRY as usize,
            false => BYTES_PER_ENTRY as usize,
        }
    }

    /// The first entry (index, slot, weight) whose slot is `slots` or more or whose weight
    /// is not finite: what a file's reader refuses.
    pub fn first_invalid(&self, slots: u64) -> Option<(usize, u32, [f32; 3])> {
        let entries = self.starts.last().copied().unwrap_or(0) as usize;
        (0..entries)
            .map(|e| {
                let (slot, weight) = self.entry(e);
                (e, slot, weight)
            })
            .find(|(_, slot, weight)| {
                u64::from(*slot) >= slots || !weight.iter().all(|w| w.is_finite())
            })
    }

    fn entry(&self, e: usize) -> (u32, [f32; 3]) {
        let size = self.entry_bytes();
        decode_packed(&self.bytes[self.at + e * size..][..size])
    }

    /// Receiver k's entries, in order (one bounds test per row, not per entry; each entry
    /// size a constant, so that decoding one tests no bounds).
    pub fn row(&self, k: usize) -> impl Iterator<Item = (u32, [f32; 3])> + '_ {
        let size = self.entry_bytes();
        let at = |e: u64| self.at + e as usize * size;
        let bytes = &self.bytes[at(self.starts[k])..at(self.starts[k + 1])];
        let (grey, rgb) = match self.grey {
            true => (bytes, &[][..]),
            false => (&[][..], bytes),
        };
        let grey = grey.chunks_exact(GREY_BYTES_PER_ENTRY as usize);
        let rgb = rgb.chunks_exact(BYTES_PER_ENTRY as usize);
        let grey = grey.map(|b| decode_grey(b.try_into().expect("8 bytes")));
        grey.chain(rgb.map(|b| decode_entry(b.try_into().expect("16 bytes"))))
    }

    /// Receivers whose rows these are.
    pub fn receiver_count(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }
}

/// A grey entry: its one weight read for all three channels.
fn decode_grey(b: &[u8; GREY_BYTES_PER_ENTRY as usize]) -> (u32, [f32; 3]) {
    let [s0, s1, s2, s3, w0, w1, w2, w3] = *b;
    let w = f32::from_le_bytes([w0, w1, w2, w3]);
    (u32::from_le_bytes([s0, s1, s2, s3]), [w; 3])
}

/// A packed entry of either size ([`PackedRows::first_invalid`]).
fn decode_packed(b: &[u8]) -> (u32, [f32; 3]) {
    match (<&[u8; 16]>::try_from(b), <&[u8; 8]>::try_from(b)) {
        (Ok(entry), _) => decode_entry(entry),
        (_, Ok(entry)) => decode_grey(entry),
        _ => unreachable!("entries are 8 or 16 bytes"),
    }
}
