//! Bounce rows: each receiver's first hits folded into a sparse row of weights over the
//! *slots* the previous bounce's transfer is read from ([`BounceTargets`]: vertices with
//! barycentric weights, or lightmap texels with bilinear ones). See
//! [`crate::interreflection`] for what the rows are for and why they pay.

use std::ops::Range;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::{Vec2, Vec3};

use crate::receivers::{BounceTargets, RECEIVERS_PER_JOB};
use crate::scene::Scene;
use crate::trace::Hit;

/// Bytes per bounce-row entry: vertex index and RGB weight.
pub const BYTES_PER_ENTRY: u64 = 4 + 3 * 4;

/// A thread's dense accumulator for one receiver's bounce row: weights by slot, and the
/// slots touched so far in first-touch order (which fixes the summation order).
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

/// The bounce rows of a run of consecutive receivers.
pub struct JobRows<'a> {
    scene: &'a Scene,
    targets: &'a BounceTargets<'a>,
    /// Index of each begun receiver's first entry.
    starts: Vec<u32>,
    /// Slot of each entry.
    pub(crate) vertices: Vec<u32>,
    pub(crate) weights: Vec<[f32; 3]>,
}

impl<'a> JobRows<'a> {
    pub(crate) fn new(scene: &'a Scene, targets: &'a BounceTargets<'a>) -> JobRows<'a> {
        JobRows {
            scene,
            targets,
            starts: Vec::new(),
            vertices: Vec::new(),
            weights: Vec::new(),
        }
    }

    /// Starts the next receiver's row (receivers are recorded in order).
    pub(crate) fn begin_vertex(&mut self, builder: &mut RowBuilder) {
        builder
            .dense
            .resize(self.targets.slot_count(self.scene), [0.0; 3]);
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
        let mut slots = [(0, 0.0); 4];
        let count = self
            .targets
            .lookup(scene, hit.triangle, barycentric, &mut slots);
        for &(slot, b) in &slots[..count] {
            let w = albedo * b;
            if w != Vec3::ZERO {
                builder.add(slot, w);
            }
        }
    }

    /// Ends the current receiver's row: moves the builder's entries into the job.
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

    /// The entries of the `k`-th receiver recorded.
    pub(crate) fn vertex(&self, k: usize) -> Range<usize> {
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

    /// The entries of the `k`-th receiver.
    pub(crate) fn vertex(&self, k: usize) -> Range<usize> {
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
    targets: &'a BounceTargets<'a>,
    jobs: Vec<Mutex<Option<JobRows<'a>>>>,
    bytes: AtomicU64,
    limit: u64,
    overflowed: AtomicBool,
}

impl<'a> HitRecorder<'a> {
    /// A recorder for a direct pass over `receivers` consecutive receivers.
    pub(crate) fn new(
        scene: &'a Scene,
        targets: &'a BounceTargets<'a>,
        receivers: usize,
        limit: u64,
    ) -> HitRecorder<'a> {
        let jobs = receivers.div_ceil(RECEIVERS_PER_JOB);
        HitRecorder {
            scene,
            targets,
            jobs: (0..jobs).map(|_| Mutex::new(None)).collect(),
            bytes: AtomicU64::new(0),
            limit,
            overflowed: AtomicBool::new(false),
        }
    }

    /// An empty set of rows for the next job.
    pub(crate) fn job(&self) -> JobRows<'a> {
        JobRows::new(self.scene, self.targets)
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
