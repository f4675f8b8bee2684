//! A job's bounce rows as the hit cache keeps them for the bounce passes
//! ([`crate::bake::bounce_rows::HitCache`]): frozen into one allocation of the exact size
//! ([`FrozenJob`]).
//!
//! A 2048² lightmap's bake keeps 524,288 jobs of 8 texels. Kept as recorded
//! (`bounce_rows::JobRows`: five vectors, scene and targets references and a shared
//! `Embedded`), each cost a 160-byte struct behind a lock, a second allocation for its 8 row
//! starts and the rounding of both: about 110 MB beside the 510 MiB of hits, held to the last
//! bounce. A frozen job is one boxed slice of words (16 bytes in the cache's
//! index, one allocation), and each thread records job after job into the same vectors, so
//! they grow only once.

/// A job's bounce rows as borrowed slices: a job being recorded, or a [`FrozenJob`]. Vertex targets fill `starts`, `vertices` and `weights`;
/// texel targets `starts`, `hits` and `hit_weights` (empty while every weight is `uniform`).
#[derive(Clone, Copy)]
pub(crate) struct RowData<'r> {
    pub starts: &'r [u32],
    pub vertices: &'r [u32],
    pub weights: &'r [[f32; 3]],
    pub hits: &'r [[u32; 3]],
    pub hit_weights: &'r [f32],
    pub uniform: f32,
}

/// Words before a frozen job's row starts: receivers, entries or hits, per-hit weights (0 or
/// the hits), the uniform weight's bits.
const HEADER: usize = 4;

/// A finished job's rows in one allocation of u32 words: the [`HEADER`], each receiver's
/// start, then (texel targets) the hits (triangle, u, v bits) and their own weights if they
/// differ, or (vertex targets) the entries' slots and RGB weights. Bit for bit what was
/// recorded.
pub(crate) struct FrozenJob(Box<[u32]>);

impl FrozenJob {
    /// A copy of `data`'s rows (`keeps_hits`: texel targets, whose hits are kept).
    pub(crate) fn freeze(data: RowData, keeps_hits: bool) -> FrozenJob {
        let count = if keeps_hits {
            data.hits.len()
        } else {
            data.vertices.len()
        };
        let len = HEADER
            + data.starts.len()
            + data.vertices.len()
            + 3 * data.weights.len()
            + 3 * data.hits.len()
            + data.hit_weights.len();
        let mut words = Vec::with_capacity(len);
        words.extend([
            data.starts.len() as u32,
            count as u32,
            data.hit_weights.len() as u32,
            data.uniform.to_bits(),
        ]);
        words.extend(data.starts);
        words.extend(data.vertices);
        words.extend(data.weights.iter().flatten().map(|w| w.to_bits()));
        words.extend(data.hits.iter().flatten());
        words.extend(data.hit_weights.iter().map(|w| w.to_bits()));
        debug_assert_eq!(words.len(), len);
        FrozenJob(words.into_boxed_slice())
    }

    /// Receivers of the job.
    pub(crate) fn receiver_count(&self) -> usize {
        self.0[0] as usize
    }

    /// The job's rows as slices of its words (`keeps_hits`: texel targets).
    pub(crate) fn data(&self, keeps_hits: bool) -> RowData<'_> {
        let [receivers, count, weighted, uniform] = [0, 1, 2, 3].map(|i| self.0[i] as usize);
        let (starts, rest) = self.0[HEADER..].split_at(receivers);
        let mut data = RowData {
            starts,
            vertices: &[],
            weights: &[],
            hits: &[],
            hit_weights: &[],
            uniform: f32::from_bits(uniform as u32),
        };
        if keeps_hits {
            let (hits, weights) = rest.split_at(3 * count);
            data.hits = bytemuck::cast_slice(hits);
            data.hit_weights = bytemuck::cast_slice(&weights[..weighted]);
        } else {
            let (vertices, weights) = rest.split_at(count);
            data.vertices = vertices;
            data.weights = bytemuck::cast_slice(&weights[..3 * count]);
        }
        data
    }
}

#[cfg(test)]
mod tests {

    use crate::bake::bounce_rows::{CornerProbe, HitRecorder, JobRows, RowBuilder};
    use crate::bake::options::BakeOptions;
    use crate::bake::receivers::Receivers;
    use crate::bake::receivers::{BounceTargets, RECEIVERS_PER_JOB};
    use crate::math::sampling::Pcg32;
    use crate::scene::Scene;
    use crate::trace::{ObvhsOptions, ObvhsTracer};

    /// Random hits on `scene`'s triangles for a job's receivers, about a fifth on back faces:
    /// with `uniform`, every hit weighs the same.
    fn record(job: &mut JobRows, scene: &Scene, probe: &CornerProbe, seed: u64, uniform: bool) {
        let mut rng = Pcg32::new(seed, 0);
        let mut builder = RowBuilder::default();
        for _ in 0..RECEIVERS_PER_JOB {
            job.begin_vertex();
            for k in 0..40 {
                let hit = crate::bake::bounce_rows::random_hit(&mut rng, scene);
                let normal = scene.normals[scene.triangles[hit.triangle as usize][0] as usize];
                let dir = if k % 5 == 0 { normal } else { -normal };
                let weight = if uniform { 4.0 } else { 0.5 + rng.next_f32() };
                job.record(&hit, dir, weight, &mut builder, probe);
            }
            job.end_vertex(&mut builder);
        }
    }

    type Row = (Vec<u32>, Vec<[u32; 3]>);

    fn bits((slots, weights): (&[u32], &[[f32; 3]])) -> Row {
        let weights = weights.iter().map(|w| w.map(f32::to_bits)).collect();
        (slots.to_vec(), weights)
    }

    #[test]
    fn frozen_jobs_give_the_rows_of_the_jobs_recorded() {
        // Two jobs of texel targets (kept hits: one weight, then a weight per hit) and two of
        // vertex targets (folded rows), recorded into one cleared job as the direct pass
        // does: each receiver's row from the cache must be, bit for bit, the recorded one.
        let (scene, atlas, texels) = crate::bake::lightmap::texels::cornell_lightmap(64);
        let tracer = ObvhsTracer::new(&scene, ObvhsOptions::default());
        let receivers = Receivers::vertices(&scene, &BakeOptions::default());
        let probe = CornerProbe {
            tracer: &tracer,
            origins: &receivers.origins,
            normals: &receivers.normals,
            seed: 1,
        };
        for targets in [
            BounceTargets::texels(&atlas, &texels),
            BounceTargets::Vertices,
        ] {
            let recorder = HitRecorder::new(&scene, &targets, 2 * RECEIVERS_PER_JOB, u64::MAX);
            let mut job = recorder.job();
            let (mut builder, mut expected) = (RowBuilder::default(), Vec::new());
            for j in 0..2 {
                job.clear();
                record(&mut job, &scene, &probe, 7 + j as u64, j == 0);
                for k in 0..RECEIVERS_PER_JOB {
                    expected.push(bits(job.row(k, &mut builder)));
                }
                recorder.finish_job(j, &job);
            }
            let (cache, _) = recorder.into_cache().expect("within the limit");
            assert_eq!(cache.job_count(), 2);
            let mut rows = Vec::new();
            for j in 0..2 {
                assert_eq!(cache.receiver_count(j), RECEIVERS_PER_JOB);
                for k in 0..RECEIVERS_PER_JOB {
                    rows.push(bits(cache.row(j, k, &mut builder)));
                }
            }
            assert!(expected.iter().all(|(slots, _)| !slots.is_empty()));
            for (r, (row, expected)) in rows.iter().zip(&expected).enumerate() {
                assert!(row == expected, "receiver {r}'s row differs");
            }
        }
    }
}
