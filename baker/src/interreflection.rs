//! Interreflected transfer: light that reaches a vertex after bouncing off other surfaces, in
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
//! T̃_{k−1}(h) the previous bounce's transfer interpolated with the hit's barycentrics;
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

use std::ops::Range;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::progress::Progress;
use crate::scene::Scene;
use crate::sh;
use crate::trace::{Hit, Tracer};
use crate::transfer::{Estimator, Scratch, VERTICES_PER_JOB, Visibility, direct_pass};

/// Bytes per bounce-row entry: vertex index and RGB weight.
pub const BYTES_PER_ENTRY: u64 = 4 + 3 * 4;

/// What an interreflected bake produces.
pub(crate) struct Bounced {
    /// `coefficients[(v · channels + c) · n² + j]`, the sum over bounces 0..=B.
    pub coefficients: Vec<f32>,
    pub channels: usize,
    pub visibility: Vec<Visibility>,
    /// Bytes of cached bounce rows, or `None` when the bounces re-traced.
    pub hit_cache_bytes: Option<u64>,
}

/// A thread's dense accumulator for one vertex's bounce row: weights by vertex, and the
/// vertices touched so far in first-touch order (which fixes the summation order).
#[derive(Default)]
pub struct RowBuilder {
    dense: Vec<[f32; 3]>,
    touched: Vec<u32>,
}

impl RowBuilder {
    fn add(&mut self, vertex: u32, weight: Vec3) {
        let slot = &mut self.dense[vertex as usize];
        if *slot == [0.0; 3] {
            self.touched.push(vertex);
        }
        *slot = (Vec3::from_array(*slot) + weight).to_array();
    }
}

/// The bounce rows of a run of consecutive vertices.
pub struct JobRows<'a> {
    scene: &'a Scene,
    /// Index of each begun vertex's first entry.
    starts: Vec<u32>,
    vertices: Vec<u32>,
    weights: Vec<[f32; 3]>,
}

impl<'a> JobRows<'a> {
    fn new(scene: &'a Scene) -> JobRows<'a> {
        JobRows {
            scene,
            starts: Vec::new(),
            vertices: Vec::new(),
            weights: Vec::new(),
        }
    }

    /// Starts the next vertex's row (vertices are recorded in order).
    pub(crate) fn begin_vertex(&mut self, builder: &mut RowBuilder) {
        builder.dense.resize(self.scene.vertex_count(), [0.0; 3]);
        self.starts.push(self.vertices.len() as u32);
    }

    /// Adds a closest hit of a ray along `dir` with estimator weight `weight`, if the ray
    /// reached a front face.
    pub(crate) fn record(&mut self, hit: &Hit, dir: Vec3, weight: f32, builder: &mut RowBuilder) {
        let scene = self.scene;
        let tri = scene.triangles[hit.triangle as usize];
        let corner = |i: u32| i as usize;
        let barycentric = [1.0 - hit.u - hit.v, hit.u, hit.v];
        let normal: Vec3 = (0..3)
            .map(|k| scene.normals[corner(tri[k])] * barycentric[k])
            .sum();
        if normal.dot(dir) >= 0.0 {
            return; // a back face: blocks, reflects nothing
        }
        let uv: Vec2 = (0..3)
            .map(|k| scene.uvs[corner(tri[k])] * barycentric[k])
            .sum();
        let albedo = scene.albedo(scene.triangle_material(hit.triangle as usize), uv) * weight;
        for (&vertex, &b) in tri.iter().zip(&barycentric) {
            let w = albedo * b.max(0.0);
            if w != Vec3::ZERO {
                builder.add(vertex, w);
            }
        }
    }

    /// Ends the current vertex's row: moves the builder's entries into the job.
    pub(crate) fn end_vertex(&mut self, builder: &mut RowBuilder) {
        for &vertex in &builder.touched {
            let slot = &mut builder.dense[vertex as usize];
            self.vertices.push(vertex);
            self.weights.push(*slot);
            *slot = [0.0; 3];
        }
        builder.touched.clear();
    }

    fn bytes(&self) -> u64 {
        self.vertices.len() as u64 * BYTES_PER_ENTRY + self.starts.len() as u64 * 4
    }

    /// The entries of the `k`-th vertex recorded.
    fn vertex(&self, k: usize) -> Range<usize> {
        let start = self.starts[k] as usize;
        let end = self
            .starts
            .get(k + 1)
            .map_or(self.vertices.len(), |&e| e as usize);
        start..end
    }
}

/// The bounce rows of a run of consecutive vertices, in order: what a shard part or a
/// checkpoint block carries, and what the merge concatenates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rows {
    /// Entries of vertex k (of the run) are `starts[k]..starts[k + 1]`; `starts[0]` is 0.
    pub starts: Vec<u64>,
    /// Vertex of each entry (over the whole scene).
    pub vertices: Vec<u32>,
    /// RGB weight of each entry.
    pub weights: Vec<[f32; 3]>,
}

impl Rows {
    /// The rows of a direct pass's jobs, in order.
    pub(crate) fn from_jobs(jobs: Vec<JobRows>) -> Rows {
        let mut rows = Rows {
            starts: vec![0],
            ..Rows::default()
        };
        for job in jobs {
            for k in 0..job.starts.len() {
                let range = job.vertex(k);
                rows.vertices.extend(&job.vertices[range.clone()]);
                rows.weights.extend(&job.weights[range]);
                rows.starts.push(rows.vertices.len() as u64);
            }
        }
        rows
    }

    /// Vertices whose rows these are.
    pub fn vertex_count(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// Appends the rows of the vertices that follow.
    pub fn append(&mut self, next: &Rows) {
        if self.starts.is_empty() {
            self.starts.push(0);
        }
        let offset = self.vertices.len() as u64;
        self.starts
            .extend(next.starts.iter().skip(1).map(|s| s + offset));
        self.vertices.extend(&next.vertices);
        self.weights.extend(&next.weights);
    }

    /// The entries of the `k`-th vertex.
    fn vertex(&self, k: usize) -> Range<usize> {
        self.starts[k] as usize..self.starts[k + 1] as usize
    }

    /// Bytes in memory and in a part: entries, plus a u32 length per vertex.
    pub fn bytes(&self) -> u64 {
        self.vertices.len() as u64 * BYTES_PER_ENTRY + self.vertex_count() as u64 * 4
    }
}

/// Collects the direct pass's bounce rows job by job, within a memory budget.
pub(crate) struct HitRecorder<'a> {
    scene: &'a Scene,
    jobs: Vec<Mutex<Option<JobRows<'a>>>>,
    bytes: AtomicU64,
    limit: u64,
    overflowed: AtomicBool,
}

impl<'a> HitRecorder<'a> {
    /// A recorder for a direct pass over `vertices` consecutive vertices.
    pub(crate) fn new(scene: &'a Scene, vertices: usize, limit: u64) -> HitRecorder<'a> {
        let jobs = vertices.div_ceil(VERTICES_PER_JOB);
        HitRecorder {
            scene,
            jobs: (0..jobs).map(|_| Mutex::new(None)).collect(),
            bytes: AtomicU64::new(0),
            limit,
            overflowed: AtomicBool::new(false),
        }
    }

    /// An empty set of rows for the next job.
    pub(crate) fn job(&self) -> JobRows<'a> {
        JobRows::new(self.scene)
    }

    /// Keeps a finished job's rows, unless the budget is (or would be) exceeded.
    pub(crate) fn finish_job(&self, job: usize, hits: JobRows<'a>) {
        let total = self.bytes.fetch_add(hits.bytes(), Ordering::Relaxed) + hits.bytes();
        if total > self.limit {
            self.overflowed.store(true, Ordering::Relaxed);
        }
        if !self.overflowed.load(Ordering::Relaxed) {
            *self.jobs[job]
                .lock()
                .expect("no job panicked holding the lock") = Some(hits);
        }
    }

    /// The rows of every job, or `None` if the budget was exceeded.
    pub(crate) fn into_cache(self) -> Option<(Vec<JobRows<'a>>, u64)> {
        if self.overflowed.into_inner() {
            return None;
        }
        let bytes = self.bytes.into_inner();
        let jobs = self.jobs.into_iter().map(|j| {
            j.into_inner()
                .expect("no poisoned lock")
                .expect("every job finished")
        });
        Some((jobs.collect(), bytes))
    }
}

/// Whether every albedo in the scene is grey (R = G = B), so one channel suffices.
pub fn albedo_is_grey(scene: &Scene) -> bool {
    let grey = |c: Vec3| c.x == c.y && c.y == c.z;
    scene
        .materials
        .iter()
        .all(|m| grey(m.kd) && m.texture.is_none_or(|t| scene.textures[t].is_grey()))
}

/// The interreflected bake: the direct pass (recording hits), then `bounces` gather passes.
pub(crate) fn bake(
    scene: &Scene,
    tracer: &dyn Tracer,
    estimator: &Estimator,
    progress: &dyn Progress,
) -> Bounced {
    let options = &estimator.options;
    let channels = if albedo_is_grey(scene) { 1 } else { 3 };
    let vertex_count = scene.vertex_count();
    let recorder = HitRecorder::new(scene, vertex_count, options.hit_cache_limit);
    let direct = direct_pass(
        estimator,
        Some(tracer),
        Some(&recorder),
        0..vertex_count,
        progress,
    );
    let cache = recorder.into_cache();
    let hit_cache_bytes = cache.as_ref().map(|(_, bytes)| *bytes);
    let cache = cache.map(|(jobs, _)| jobs);
    let rows = match &cache {
        Some(jobs) => RowSource::Jobs(jobs),
        None => RowSource::Retrace {
            scene,
            tracer,
            estimator,
        },
    };
    Bounced {
        coefficients: add_bounces(direct.coefficients, channels, options, &rows, progress),
        channels,
        visibility: direct.visibility,
        hit_cache_bytes,
    }
}

/// Where a bounce pass finds each vertex's bounce row.
pub(crate) enum RowSource<'a> {
    /// The direct pass's rows, job by job ([`VERTICES_PER_JOB`] vertices each).
    Jobs(&'a [JobRows<'a>]),
    /// The rows of every vertex in order (checkpoint blocks joined).
    Flat(&'a Rows),
    /// Re-trace each vertex's bounce samples (the rows were over the hit-cache budget).
    Retrace {
        scene: &'a Scene,
        tracer: &'a dyn Tracer,
        estimator: &'a Estimator,
    },
}

/// The interreflected transfer from the direct pass's `t0` (one channel, every vertex) and
/// the bounce rows: T_0 broadcast to `channels`, plus `options.bounces` gathers. The
/// single-machine bake and the merge of checkpoint blocks end here; the merge of shard parts
/// ends in [`sum_bounces`] with the same gather, so they agree bit for bit.
pub(crate) fn add_bounces(
    t0: Vec<f32>,
    channels: usize,
    options: &crate::transfer::BakeOptions,
    rows: &RowSource,
    progress: &dyn Progress,
) -> Vec<f32> {
    let n = sh::coeff_count(options.order);
    let norm = Estimator::norm_of(options) as f32;
    let rays = match rows {
        RowSource::Retrace { .. } => u64::from(options.samples),
        _ => 0,
    };
    let pass = |previous: &[f32], previous_channels: usize, next: &mut [f32]| {
        bounce_pass(
            rows,
            norm,
            n,
            previous,
            previous_channels,
            channels,
            next,
            progress,
        );
        Ok::<(), std::convert::Infallible>(())
    };
    match sum_bounces(t0, channels, options, rays, progress, pass) {
        Ok(total) => total,
        Err(never) => match never {},
    }
}

/// T_0 (`t0`, one channel, every vertex) broadcast to `channels`, plus `options.bounces`
/// bounces, each of which `bounce` writes into a zeroed array from the previous one (and its
/// channel count). `rays_per_vertex` is for the progress bar.
pub(crate) fn sum_bounces<E, F>(
    t0: Vec<f32>,
    channels: usize,
    options: &crate::transfer::BakeOptions,
    rays_per_vertex: u64,
    progress: &dyn Progress,
    mut bounce: F,
) -> Result<Vec<f32>, E>
where
    F: FnMut(&[f32], usize, &mut [f32]) -> Result<(), E>,
{
    let n = sh::coeff_count(options.order);
    let vertex_count = t0.len() / n;
    // Total = T_0 (grey) broadcast to every channel, plus each bounce.
    let mut total = vec![0.0f32; vertex_count * channels * n];
    for (v, t0) in t0.chunks_exact(n).enumerate() {
        for c in 0..channels {
            total[(v * channels + c) * n..][..n].copy_from_slice(t0);
        }
    }
    let mut previous = t0;
    let mut previous_channels = 1;
    for k in 1..=options.bounces {
        progress.begin(&format!("bounce {k}"), vertex_count as u64, rays_per_vertex);
        let mut next = vec![0.0f32; vertex_count * channels * n];
        bounce(&previous, previous_channels, &mut next)?;
        progress.finish();
        for (t, b) in total.iter_mut().zip(&next) {
            *t += b;
        }
        previous = next;
        previous_channels = channels;
    }
    Ok(total)
}

/// One bounce at a run of consecutive vertices whose rows are `rows` (the k-th vertex's
/// result goes to `out`'s k-th `channels × n²` floats): what [`bounce_pass`] computes for
/// them, for a merge that holds one part's rows at a time.
#[allow(clippy::too_many_arguments)]
pub(crate) fn bounce_rows(
    rows: &Rows,
    norm: f32,
    n: usize,
    previous: &[f32],
    previous_channels: usize,
    channels: usize,
    out: &mut [f32],
    progress: &dyn Progress,
) {
    let width = channels * n;
    out.par_chunks_mut(VERTICES_PER_JOB * width)
        .enumerate()
        .for_each(|(job, out)| {
            for (k, out) in out.chunks_mut(width).enumerate() {
                let range = rows.vertex(job * VERTICES_PER_JOB + k);
                let (vertices, weights) = (&rows.vertices[range.clone()], &rows.weights[range]);
                gather(
                    vertices,
                    weights,
                    previous,
                    previous_channels,
                    channels,
                    n,
                    out,
                );
                for o in out.iter_mut() {
                    *o *= norm;
                }
            }
            progress.advance((out.len() / width) as u64);
        });
}

/// One bounce: T_k(x) = norm · Σ_v w(x, v) ⊙ T_{k−1}(v) for every vertex x.
#[allow(clippy::too_many_arguments)]
fn bounce_pass(
    rows: &RowSource,
    norm: f32,
    n: usize,
    previous: &[f32],
    previous_channels: usize,
    channels: usize,
    next: &mut [f32],
    progress: &dyn Progress,
) {
    let width = channels * n;
    next.par_chunks_mut(VERTICES_PER_JOB * width)
        .enumerate()
        .for_each_init(
            || Scratch::new(n),
            |scratch, (job, out)| {
                let first = job * VERTICES_PER_JOB;
                for (k, out) in out.chunks_mut(width).enumerate() {
                    let gather = |vertices: &[u32], weights: &[[f32; 3]], out: &mut [f32]| {
                        gather(
                            vertices,
                            weights,
                            previous,
                            previous_channels,
                            channels,
                            n,
                            out,
                        )
                    };
                    match rows {
                        RowSource::Jobs(jobs) => {
                            let range = jobs[job].vertex(k);
                            let rows = &jobs[job];
                            gather(&rows.vertices[range.clone()], &rows.weights[range], out);
                        }
                        RowSource::Flat(rows) => {
                            let range = rows.vertex(first + k);
                            gather(&rows.vertices[range.clone()], &rows.weights[range], out);
                        }
                        RowSource::Retrace {
                            scene,
                            tracer,
                            estimator,
                        } => {
                            // Same rays as the direct pass, so the same row.
                            let mut fresh = JobRows::new(scene);
                            estimator.bounce_row(first + k, *tracer, scratch, &mut fresh);
                            gather(&fresh.vertices, &fresh.weights, out);
                        }
                    }
                    for o in out.iter_mut() {
                        *o *= norm;
                    }
                }
                progress.advance((out.len() / width) as u64);
            },
        );
}

/// `out` = Σ over a row's entries of weight ⊙ the previous bounce's transfer at the entry's
/// vertex.
fn gather(
    vertices: &[u32],
    weights: &[[f32; 3]],
    previous: &[f32],
    previous_channels: usize,
    channels: usize,
    n: usize,
    out: &mut [f32],
) {
    out.fill(0.0);
    for (&vertex, weight) in vertices.iter().zip(weights) {
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
