//! Bounce rows: each receiver's first hits folded into a sparse row of weights over the
//! *slots* the previous bounce's transfer is read from ([`BounceTargets`]: vertices with
//! barycentric weights, or lightmap texels with bilinear ones). See
//! [`crate::bake::interreflection`] for what the rows are for and why they pay.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use glam::{Vec2, Vec3};

pub(crate) use crate::bake::embedded::CornerProbe;
pub use crate::bake::embedded::{
    EMBEDDING_FRACTION, EMBEDDING_RAYS, EMBEDDING_SCREEN_RAYS, Embedded,
};
use crate::bake::hit_cache::{FrozenJob, RowData};
use crate::bake::receivers::BounceTargets;
use crate::bake::receivers::RECEIVERS_PER_JOB;
use crate::scene::Scene;
use crate::trace::Hit;

/// Bytes per bounce-row entry: vertex index and RGB weight.
pub const BYTES_PER_ENTRY: u64 = 4 + 3 * 4;

/// A bounce-row entry as a part file stores it ([`BYTES_PER_ENTRY`] little-endian bytes):
/// the slot, then the RGB weight.
pub fn decode_entry(b: &[u8; BYTES_PER_ENTRY as usize]) -> (u32, [f32; 3]) {
    let word = |o: usize| [b[o], b[o + 1], b[o + 2], b[o + 3]];
    let f = |o: usize| f32::from_le_bytes(word(o));
    (u32::from_le_bytes(word(0)), [f(4), f(8), f(12)])
}

/// Bytes per cached texel hit ([`JobRows`]): triangle and barycentrics u, v as f32, exactly as
/// traced, so that the row folded from them in every gather is the one the direct pass would
/// have folded. A ray's estimator weight adds 4 bytes only where the weights differ
/// (`--sampling thesis-random`).
pub const BYTES_PER_HIT: u64 = 4 + 2 * 4;

/// A thread's accumulator for one receiver's bounce row: the slots touched so far in
/// first-touch order (which fixes the output order) with their sums, and where each slot's sum
/// is. Sparse, so a thread's memory is bounded by a row's length (at most 4 slots a bounce ray)
/// rather than the slot count: a dense array over a 16,384² lightmap's texels took 3 GiB a
/// thread.
#[derive(Default)]
pub struct RowBuilder {
    index: HashMap<u32, u32, BuildHasherDefault<SlotHasher>>,
    touched: Vec<u32>,
    sums: Vec<[f32; 3]>,
}

impl RowBuilder {
    fn add(&mut self, slot: u32, weight: Vec3) {
        let next = self.touched.len() as u32;
        let i = *self.index.entry(slot).or_insert(next) as usize;
        if i == self.touched.len() {
            self.touched.push(slot);
            self.sums.push([0.0; 3]);
        }
        self.sums[i] = (Vec3::from_array(self.sums[i]) + weight).to_array();
    }

    fn clear(&mut self) {
        self.touched.clear();
        self.sums.clear();
        self.index.clear();
    }
}

/// Fibonacci hashing of a slot index: the standard library's SipHash guards against keys
/// chosen by an attacker, which slot indices are not, at several times the cost.
#[derive(Default)]
struct SlotHasher(u64);

impl SlotHasher {
    fn mix(&mut self, value: u64) {
        self.0 = (self.0 ^ value).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }
}

impl Hasher for SlotHasher {
    /// Not used by `u32` keys; here for the trait.
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.mix(u64::from(b));
        }
    }

    fn write_u32(&mut self, slot: u32) {
        self.mix(u64::from(slot));
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// The bounce rows of a run of consecutive receivers.
///
/// Vertex targets keep each receiver's row folded (its hits share corners: about one
/// 16-byte entry per bounce ray). Texel targets keep the front *hits* instead and fold them
/// into a row in every gather ([`JobRows::row`]): a hit reads up to 4 texels that the
/// receiver's other hits almost never share, so its folded entries took 2.64 × 16 bytes per
/// bounce ray against [`BYTES_PER_HIT`]; the fold is the same code on the same floats in
/// the same order, so the row, and the bake, are bit for bit what folding at once gave.
pub struct JobRows<'a> {
    scene: &'a Scene,
    targets: &'a BounceTargets<'a>,
    /// Vertex targets: which corners a hit must not read ([`Embedded`]).
    embedded: Arc<Embedded>,
    /// Index of each begun receiver's first entry (vertex targets) or hit (texel targets).
    starts: Vec<u32>,
    /// Vertex targets: slot of each entry.
    vertices: Vec<u32>,
    weights: Vec<[f32; 3]>,
    /// Texel targets: each front hit's triangle and barycentrics u, v (f32 bits).
    hits: Vec<[u32; 3]>,
    /// Each hit's estimator weight; empty while every weight so far is `uniform`.
    hit_weights: Vec<f32>,
    uniform: f32,
}

impl<'a> JobRows<'a> {
    pub(crate) fn new(
        scene: &'a Scene,
        targets: &'a BounceTargets<'a>,
        embedded: Arc<Embedded>,
    ) -> JobRows<'a> {
        JobRows {
            scene,
            targets,
            embedded,
            starts: Vec::new(),
            vertices: Vec::new(),
            weights: Vec::new(),
            hits: Vec::new(),
            hit_weights: Vec::new(),
            uniform: f32::NAN,
        }
    }

    /// Whether hits are kept rather than folded rows (texel targets).
    pub(crate) fn keeps_hits(&self) -> bool {
        matches!(self.targets, BounceTargets::Texels(_))
    }

    /// Starts the next receiver's row (receivers are recorded in order).
    pub(crate) fn begin_vertex(&mut self) {
        let len = if self.keeps_hits() {
            self.hits.len()
        } else {
            self.vertices.len()
        };
        self.starts.push(len as u32);
    }

    /// Adds a closest hit of a ray along `dir` with estimator weight `weight`, if the ray
    /// reached a front face. `probe` tests vertex targets' corners for [`Embedded`].
    pub(crate) fn record(
        &mut self,
        hit: &Hit,
        dir: Vec3,
        weight: f32,
        builder: &mut RowBuilder,
        probe: &CornerProbe,
    ) {
        if self.keeps_hits() {
            if self.front_barycentric(hit, dir).is_some() {
                self.keep_hit(hit, weight);
            }
            return;
        }
        let mut slots = [(0, Vec3::ZERO); 4];
        let count = self.front_hit_slots(hit, dir, weight, probe, &mut slots);
        fold(builder, &slots[..count]);
    }

    /// Keeps a texel target's front hit with its estimator weight.
    fn keep_hit(&mut self, hit: &Hit, weight: f32) {
        self.hits
            .push([hit.triangle, hit.u.to_bits(), hit.v.to_bits()]);
        if self.hits.len() == 1 {
            self.uniform = weight;
        }
        if !self.hit_weights.is_empty() || weight.to_bits() != self.uniform.to_bits() {
            // The first weight that differs: from here on every hit carries its own.
            let kept = self.hits.len() - 1 - self.hit_weights.len();
            self.hit_weights
                .extend(std::iter::repeat_n(self.uniform, kept));
            self.hit_weights.push(weight);
        }
    }

    /// The slots a closest hit along `dir` reads the previous bounce from, with their RGB
    /// weights (`weight` × the hit's albedo × the slot's interpolation weight, embedded
    /// corners left out): what [`JobRows::record`] adds to a row, and what an interreflected
    /// transfer-matrix ray gathers ([`crate::bake::matrix_bounce`]). None (0) for a back face.
    pub(crate) fn front_hit_slots(
        &self,
        hit: &Hit,
        dir: Vec3,
        weight: f32,
        probe: &CornerProbe,
        out: &mut [(u32, Vec3); 4],
    ) -> usize {
        match self.front_barycentric(hit, dir) {
            Some(barycentric) => {
                self.hit_slots(hit.triangle, barycentric, weight, Some(probe), out)
            }
            None => 0, // a back face: blocks, reflects nothing
        }
    }

    /// The hit's barycentrics, if the ray along `dir` reached the front face (the side its
    /// interpolated shading normal points to).
    fn front_barycentric(&self, hit: &Hit, dir: Vec3) -> Option<[f32; 3]> {
        let scene = self.scene;
        let tri = scene.triangles[hit.triangle as usize];
        let barycentric = [1.0 - hit.u - hit.v, hit.u, hit.v];
        let normal: Vec3 = (0..3)
            .map(|k| scene.normals[tri[k] as usize] * barycentric[k])
            .sum();
        (normal.dot(dir) < 0.0).then_some(barycentric)
    }

    /// [`JobRows::front_hit_slots`] of a front hit on `triangle` at `barycentric`. `probe`
    /// may be `None` only for texel targets (no embedded corners).
    fn hit_slots(
        &self,
        triangle: u32,
        barycentric: [f32; 3],
        weight: f32,
        probe: Option<&CornerProbe>,
        out: &mut [(u32, Vec3); 4],
    ) -> usize {
        let embedded = probe.map(|probe| (&*self.embedded, probe));
        let at = (triangle, barycentric, weight);
        hit_slots(self.scene, self.targets, at, embedded, out)
    }

    /// Ends the current receiver's row: moves the builder's entries into the job.
    pub(crate) fn end_vertex(&mut self, builder: &mut RowBuilder) {
        self.vertices.extend(&builder.touched);
        self.weights.extend(&builder.sums);
        builder.clear();
    }

    /// Bytes the cache counts for the job (against `--hit-cache-mb`).
    pub(crate) fn bytes(&self) -> u64 {
        self.vertices.len() as u64 * BYTES_PER_ENTRY
            + self.hits.len() as u64 * BYTES_PER_HIT
            + self.hit_weights.len() as u64 * 4
            + self.starts.len() as u64 * 4
    }

    /// The job's rows as borrowed slices.
    pub(crate) fn data(&self) -> RowData<'_> {
        RowData {
            starts: &self.starts,
            vertices: &self.vertices,
            weights: &self.weights,
            hits: &self.hits,
            hit_weights: &self.hit_weights,
            uniform: self.uniform,
        }
    }

    /// The `k`-th receiver's bounce row (slots and RGB weights): its folded entries, or its
    /// hits folded into `builder` (cleared first) exactly as [`JobRows::record`] would have.
    pub(crate) fn row<'r>(
        &'r self,
        k: usize,
        builder: &'r mut RowBuilder,
    ) -> (&'r [u32], &'r [[f32; 3]]) {
        self.data().row(self.scene, self.targets, k, builder)
    }

    /// Empties the job for the next one (keeping its vectors' room: a thread's recording
    /// vectors serve job after job, and only the kept copy is sized to fit).
    pub(crate) fn clear(&mut self) {
        self.starts.clear();
        self.vertices.clear();
        self.weights.clear();
        self.hits.clear();
        self.hit_weights.clear();
        self.uniform = f32::NAN;
    }
}

/// The slots a front hit `(triangle, barycentric, weight)` reads, with their RGB weights
/// (`weight` × the hit's albedo × the slot's interpolation weight); with `embedded`, a vertex
/// target's embedded corners are left out.
fn hit_slots(
    scene: &Scene,
    targets: &BounceTargets,
    (triangle, barycentric, weight): (u32, [f32; 3], f32),
    embedded: Option<(&Embedded, &CornerProbe)>,
    out: &mut [(u32, Vec3); 4],
) -> usize {
    let tri = scene.triangles[triangle as usize];
    let uv: Vec2 = (0..3)
        .map(|k| scene.uvs[tri[k] as usize] * barycentric[k])
        .sum();
    let albedo = scene.albedo(scene.triangle_material(triangle as usize), uv) * weight;
    let mut slots = [(0, 0.0); 4];
    let count = targets.lookup(scene, triangle, barycentric, &mut slots);
    if let (BounceTargets::Vertices, Some((embedded, probe))) = (targets, embedded)
        && embedded.has_embedded_corner(triangle, tri, probe)
    {
        embedded.skip_embedded(&mut slots[..count], probe);
    }
    for (out, &(slot, b)) in out.iter_mut().zip(&slots[..count]) {
        *out = (slot, albedo * b);
    }
    count
}

impl<'r> RowData<'r> {
    /// The `k`-th receiver's bounce row (slots and RGB weights): its folded entries, or its
    /// hits folded into `builder` (cleared first) exactly as [`JobRows::record`] would have.
    pub(crate) fn row(
        self,
        scene: &Scene,
        targets: &BounceTargets,
        k: usize,
        builder: &'r mut RowBuilder,
    ) -> (&'r [u32], &'r [[f32; 3]]) {
        let keeps_hits = matches!(targets, BounceTargets::Texels(_));
        let len = if keeps_hits {
            self.hits.len()
        } else {
            self.vertices.len()
        };
        let start = self.starts[k] as usize;
        let end = self.starts.get(k + 1).map_or(len, |&e| e as usize);
        if !keeps_hits {
            return (&self.vertices[start..end], &self.weights[start..end]);
        }
        builder.clear();
        for i in start..end {
            let [triangle, u, v] = self.hits[i];
            let (u, v) = (f32::from_bits(u), f32::from_bits(v));
            let weight = self.hit_weights.get(i).copied().unwrap_or(self.uniform);
            let mut slots = [(0, Vec3::ZERO); 4];
            let at = (triangle, [1.0 - u - v, u, v], weight);
            let count = hit_slots(scene, targets, at, None, &mut slots);
            fold(builder, &slots[..count]);
        }
        (&builder.touched, &builder.sums)
    }
}

/// Adds a hit's slots to a row (zero weights add nothing).
fn fold(builder: &mut RowBuilder, slots: &[(u32, Vec3)]) {
    for &(slot, w) in slots {
        if w != Vec3::ZERO {
            builder.add(slot, w);
        }
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
    pub(crate) fn from_jobs(jobs: HitCache) -> Rows {
        let mut rows = Rows {
            starts: vec![0],
            ..Rows::default()
        };
        let mut builder = RowBuilder::default();
        for job in 0..jobs.job_count() {
            for k in 0..jobs.receiver_count(job) {
                let (vertices, weights) = jobs.row(job, k, &mut builder);
                rows.vertices.extend(vertices);
                rows.weights.extend(weights);
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

/// The direct pass's rows, job by job ([`RECEIVERS_PER_JOB`] receivers each), frozen
/// ([`crate::bake::hit_cache`]).
pub struct HitCache<'a> {
    scene: &'a Scene,
    targets: &'a BounceTargets<'a>,
    jobs: Vec<FrozenJob>,
}

impl HitCache<'_> {
    pub(crate) fn job_count(&self) -> usize {
        self.jobs.len()
    }

    /// Receivers of job `job`.
    pub(crate) fn receiver_count(&self, job: usize) -> usize {
        self.jobs[job].receiver_count()
    }

    /// The bounce row of job `job`'s `k`-th receiver, as [`JobRows::row`] gave it.
    pub(crate) fn row<'r>(
        &'r self,
        job: usize,
        k: usize,
        builder: &'r mut RowBuilder,
    ) -> (&'r [u32], &'r [[f32; 3]]) {
        let keeps_hits = matches!(self.targets, BounceTargets::Texels(_));
        self.jobs[job]
            .data(keeps_hits)
            .row(self.scene, self.targets, k, builder)
    }
}

/// Collects the direct pass's bounce rows job by job, within a memory budget.
pub(crate) struct HitRecorder<'a> {
    scene: &'a Scene,
    targets: &'a BounceTargets<'a>,
    embedded: Arc<Embedded>,
    jobs: Vec<Mutex<Option<FrozenJob>>>,
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
            embedded: Arc::new(Embedded::new(scene, targets)),
            jobs: (0..jobs).map(|_| Mutex::new(None)).collect(),
            bytes: AtomicU64::new(0),
            limit,
            overflowed: AtomicBool::new(false),
        }
    }

    /// An empty set of rows to record jobs into ([`JobRows::clear`] between them).
    pub(crate) fn job(&self) -> JobRows<'a> {
        JobRows::new(self.scene, self.targets, self.embedded.clone())
    }

    /// The embedded vertices found so far, shared (re-traced bounce rows test the rest).
    pub(crate) fn embedded(&self) -> Arc<Embedded> {
        self.embedded.clone()
    }

    /// Keeps a finished job's rows (a frozen copy), unless the budget is (or would be)
    /// exceeded.
    pub(crate) fn finish_job(&self, job: usize, hits: &JobRows<'a>) {
        let total = self.bytes.fetch_add(hits.bytes(), Ordering::Relaxed) + hits.bytes();
        if total > self.limit {
            self.overflowed.store(true, Ordering::Relaxed);
        }
        if !self.overflowed.load(Ordering::Relaxed) {
            *self.jobs[job]
                .lock()
                .expect("no job panicked holding the lock") =
                Some(FrozenJob::freeze(hits.data(), hits.keeps_hits()));
        }
    }

    /// The rows of every job, or `None` if the budget was exceeded.
    pub(crate) fn into_cache(self) -> Option<(HitCache<'a>, u64)> {
        if self.overflowed.into_inner() {
            return None;
        }
        let bytes = self.bytes.into_inner();
        let jobs = self.jobs.into_iter().map(|j| {
            j.into_inner()
                .expect("no poisoned lock")
                .expect("every job finished")
        });
        let cache = HitCache {
            scene: self.scene,
            targets: self.targets,
            jobs: jobs.collect(),
        };
        Some((cache, bytes))
    }
}

/// A hit on a random triangle of `scene` at random barycentrics: what the hit-cache tests
/// record.
#[cfg(test)]
pub(crate) fn random_hit(rng: &mut crate::math::sampling::Pcg32, scene: &Scene) -> Hit {
    let triangle = rng.next_u32() % scene.triangles.len() as u32;
    let (u, v) = (rng.next_f32(), rng.next_f32());
    let (u, v) = if u + v > 1.0 {
        (1.0 - u, 1.0 - v)
    } else {
        (u, v)
    };
    Hit {
        triangle,
        instance: None,
        u,
        v,
        t: 1.0,
        ng: Vec3::Z,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Pcg32;
    use crate::trace::{ObvhsOptions, ObvhsTracer};

    #[test]
    fn kept_texel_hits_fold_into_the_row_recording_would_have_folded() {
        // Hits on the Cornell room's triangles (some on back faces, which add nothing), in
        // three receivers, with one weight for the first and then a weight per hit: each
        // receiver's row folded from the kept hits must be, bit for bit, the row folded from
        // the hits as they came.
        let (scene, atlas, texels) = crate::bake::lightmap::texels::cornell_lightmap(64);
        let targets = BounceTargets::texels(&atlas, &texels);
        let embedded = Arc::new(Embedded::new(&scene, &targets));
        let tracer = ObvhsTracer::new(&scene, ObvhsOptions::default());
        let probe = CornerProbe {
            tracer: &tracer,
            origins: &[],
            normals: &[],
            seed: 1,
        };
        let mut kept = JobRows::new(&scene, &targets, embedded.clone());
        let mut rng = Pcg32::new(7, 0);
        let (mut builder, mut expected) = (RowBuilder::default(), Vec::new());
        for receiver in 0..3 {
            kept.begin_vertex();
            let mut direct = RowBuilder::default();
            for k in 0..400 {
                let hit = random_hit(&mut rng, &scene);
                let tri = scene.triangles[hit.triangle as usize];
                let normal = scene.normals[tri[0] as usize];
                let dir = if k % 5 == 0 { normal } else { -normal };
                let weight = match receiver {
                    0 => 4.0,
                    _ => 0.5 + rng.next_f32(),
                };
                kept.record(&hit, dir, weight, &mut builder, &probe);
                let mut slots = [(0, Vec3::ZERO); 4];
                let count = kept.front_hit_slots(&hit, dir, weight, &probe, &mut slots);
                fold(&mut direct, &slots[..count]);
            }
            kept.end_vertex(&mut builder);
            expected.push((direct.touched, direct.sums));
        }
        assert_eq!(kept.hit_weights.len(), kept.hits.len(), "per-hit weights");
        assert!(
            kept.hits.len() > 900,
            "front hits kept: {}",
            kept.hits.len()
        );
        for (k, (touched, sums)) in expected.iter().enumerate() {
            assert!(!touched.is_empty());
            let (slots, weights) = kept.row(k, &mut builder);
            assert!(slots == &touched[..], "receiver {k}'s slots differ");
            let bits = |w: &[[f32; 3]]| -> Vec<[u32; 3]> {
                w.iter().map(|w| w.map(f32::to_bits)).collect()
            };
            assert!(bits(weights) == bits(sums), "receiver {k}'s weights differ");
        }
    }

    #[test]
    fn a_row_sums_each_slot_in_record_order_and_lists_slots_by_first_touch() {
        let mut builder = RowBuilder::default();
        // Any slot index, however large: nothing is sized by the slot count.
        let far = 4_000_000_000;
        for (slot, w) in [(7, 1.0), (3, 0.5), (7, 0.25), (far, 2.0), (3, 0.125)] {
            builder.add(slot, Vec3::splat(w));
        }
        assert_eq!(builder.touched, [7, 3, far]);
        assert_eq!(builder.sums, [[1.25; 3], [0.625; 3], [2.0; 3]]);
    }
}
