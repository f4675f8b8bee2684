//! The per-receiver estimator of the shadowed transfer
//! T_j = (1/π) ∫ V(x, s) max(n·s, 0) y_j(s) ds, shared by vertex and texel bakes, and the
//! direct pass that runs it over a range of receivers. In interreflected mode the same rays
//! also record each receiver's bounce row ([`crate::bake::bounce_rows`]).
//!
//! # How the default estimator is organised
//!
//! The thesis generates its sample directions and evaluates the SH basis at them once, for
//! all vertices. The default estimator does the same in each vertex's *local* frame (z along
//! the normal): one Owen-scrambled, cosine-weighted point set per bake (from the seed), with
//! y_j precomputed at every point. A vertex turns the set by its own random angle about its
//! normal (so neighbouring vertices do not share sample directions); the receivers of a
//! denoised bake instead take, unturned, one of several complementary sets by their place
//! (a texel's in the lightmap, a vertex's in space), so that the denoiser's average over
//! neighbours integrates like a larger set ([`crate::bake::strata`]). A receiver casts the
//! rays, adds the
//! table rows of the unblocked ones, and rotates the local coefficients into world space once
//! ([`crate::math::sh::ZyzRotator`], exact). Per ray that is a 3×3 transform and a row sum:
//! the cost of a bake is the cost of its rays. Each row also holds the local direction, so the
//! same sums give the bent normal; and a batch of rays most of which are unblocked is summed
//! as the batch's precomputed total minus its blocked rows (on an open surface, most rays are
//! unblocked). The table takes N·(24 + 4n²) bytes: 0.9 MB for the demo's 10,000 rays at
//! order 4, 280 MB for a million rays at order 8 (a denoised bake's joint sets, up to 256
//! tables, at most 64 MB more).
//!
//! Every quantity is a pure function of (seed, vertex, sample index) and sums are formed in a
//! fixed order, so a bake is bit-identical whatever the number of threads.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use crate::bake::bounce_rows::{CornerProbe, HitRecorder, JobRows, RowBuilder};
use crate::bake::noise::NoiseBlocks;
use crate::bake::options::{BakeOptions, TransferKind};
use crate::bake::receivers::{RECEIVERS_PER_JOB, Receivers};
use crate::bake::sample_sets::{BATCH, DIR_COLUMNS, SampleSets, batch_ranges};
use crate::bake::strata;
use crate::math::sampling::{Frame, Pcg32, Sampling, to_unit_float, uniform_sphere, vertex_seed};
use crate::math::sh::{Basis, RotationScratch, ZyzRotator};
use crate::scene::Scene;
use crate::support::error::Result;
use crate::support::progress::Progress;
use crate::trace::Tracer;

/// What a vertex's rays tell besides its transfer: the thesis's ambient-occlusion
/// quantities (digest §9), here from the same rays as the shadowed transfer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Visibility {
    /// Cosine-weighted fraction of the hemisphere through which the sky is seen:
    /// (1/π) ∫ V(s) max(n·s, 0) ds.
    pub accessibility: f32,
    /// The cosine-weighted mean of the unblocked directions, normalised; the shading normal
    /// where every ray is blocked.
    pub bent_normal: Vec3,
    /// Rays the vertex cast: `samples` (0 with no tracer), or fewer in an adaptive bake.
    pub rays: u32,
    /// Sample points whose answers the transfer sums: `rays`, or more in an adaptive bake,
    /// where the rest were inferred from their neighbours ([`crate::bake::inference`]).
    pub points: u32,
    /// Adaptive bakes: the estimated RMS coefficient error of the vertex's transfer
    /// ([`crate::bake::adaptive`]); 0 otherwise.
    pub error_estimate: f32,
    /// Fixed Owen–Sobol bakes: the estimated variance of one of the receiver's band-0 and
    /// band-1 coefficients (their mean), from the spread of its rays' [`crate::bake::noise::NOISE_BLOCKS`]
    /// blocks ([`crate::bake::noise`]); for transfer matrices, of one entry of their first
    /// row's bands 0 to 2. What the denoiser weighs differences against; 0 where not
    /// estimated.
    pub noise: f32,
}

/// The result of the shadowed (or unshadowed) pass over every vertex.
pub(crate) struct DirectPass {
    /// One channel: `coefficients[v · n² + j]`.
    pub coefficients: Vec<f32>,
    pub visibility: Vec<Visibility>,
}

/// The shadowed transfer of the vertices `vertices` (every vertex, or a shard's or a
/// checkpoint block's range; results are indexed from `vertices.start`); with `recorder`,
/// each vertex's front hits are handed to it (interreflected mode).
pub(crate) fn direct_pass(
    estimator: &Estimator,
    tracer: Option<&dyn Tracer>,
    recorder: Option<&HitRecorder<'_>>,
    vertices: std::ops::Range<usize>,
    progress: &dyn Progress,
) -> DirectPass {
    let n = estimator.basis.coeff_count();
    let vertex_count = vertices.len();
    let rays_per_vertex = if tracer.is_some() {
        u64::from(estimator.options.samples)
    } else {
        0
    };
    progress.begin("direct", vertex_count as u64, rays_per_vertex);
    let mut coefficients = vec![0.0f32; vertex_count * n];
    let mut visibility = vec![Visibility::default(); vertex_count];
    coefficients
        .par_chunks_mut(RECEIVERS_PER_JOB * n)
        .zip(visibility.par_chunks_mut(RECEIVERS_PER_JOB))
        .enumerate()
        .for_each_init(
            // One recording of rows per worker, cleared between jobs (the recorder keeps a
            // frozen copy of each).
            || (Scratch::new(n), recorder.map(|r| r.job())),
            |(scratch, hits), (job, (out, vis))| {
                let first = vertices.start + job * RECEIVERS_PER_JOB;
                if let Some(hits) = hits.as_mut() {
                    hits.clear();
                }
                for (k, (out, vis)) in out.chunks_mut(n).zip(vis.iter_mut()).enumerate() {
                    *vis =
                        estimator.receiver_transfer(first + k, tracer, scratch, out, hits.as_mut());
                }
                if let (Some(recorder), Some(hits)) = (recorder, hits.as_ref()) {
                    recorder.finish_job(job, hits);
                }
                progress.advance(vis.len() as u64);
            },
        );
    progress.finish();
    DirectPass {
        coefficients,
        visibility,
    }
}

/// `acc += row`, element by element.
#[inline]
fn add_row(acc: &mut [f32], row: &[f32]) {
    for (a, y) in acc.iter_mut().zip(row) {
        *a += y;
    }
}

/// `acc -= row`, element by element.
#[inline]
fn sub_row(acc: &mut [f32], row: &[f32]) {
    for (a, y) in acc.iter_mut().zip(row) {
        *a -= y;
    }
}

/// What all vertices of one bake share, and the per-vertex estimator.
pub struct Estimator {
    pub(crate) options: BakeOptions,
    pub(crate) basis: Basis,
    rotator: ZyzRotator,
    pub(crate) normals: Vec<Vec3>,
    origins: Vec<Vec3>,
    /// [`Receivers::horizons`].
    horizons: Option<Vec<Vec3>>,
    /// [`Receivers::streams`].
    streams: Option<Vec<u64>>,
    /// The sample tables (Owen–Sobol only): one set, or a denoised bake's joint sets, each
    /// `samples` rows (a matrix bake's joint sets are in its matrix tables, these hold one). With bounce samples (interreflected mode), a set's rows 0..M are its
    /// sequence's first M points — a stratified set of their own — the rest follow;
    /// thesis-random samples are independent, so their first M serve.
    tables: SampleSets,
    /// Adaptive bakes (`--target-error`): the pilot and its extensions, instead of the table above.
    adaptive: Option<crate::bake::adaptive::Tables>,
    /// The groups of joint sets the tables hold ([`strata::groups`]); 0: one set, turned by
    /// each receiver.
    groups: u32,
    /// With `groups`, each receiver's stratum ([`crate::bake::receivers::Receivers::strata`]).
    strata: Vec<u32>,
}

impl Estimator {
    /// The estimator for the scene's vertices.
    pub fn new(scene: &Scene, options: &BakeOptions) -> Result<Estimator> {
        Estimator::for_receivers(Receivers::vertices(scene, options), options)
    }

    /// The estimator for any receivers (vertices, or lightmap texels: [`crate::bake::lightmap`]);
    /// receiver `i` plays the part of vertex `i` everywhere below.
    pub fn for_receivers(receivers: Receivers, options: &BakeOptions) -> Result<Estimator> {
        options.validate()?;
        let basis = Basis::new(options.order);
        let adaptive = options
            .target_error
            .map(|_| crate::bake::adaptive::Tables::new(options, &basis));
        if adaptive.is_some() && receivers.horizons.is_some() {
            return Err(crate::Error::InvalidOption(
                "--target-error with a normal-mapped texel bake is not supported yet: \
                 bake it with a fixed --samples"
                    .into(),
            ));
        }
        let set_bytes = crate::bake::memory::set_bytes(options).unwrap_or(u64::MAX);
        let groups = match (&receivers.strata, options.sampling, &adaptive) {
            (Some(_), Sampling::OwenSobol, None) => strata::groups(options, set_bytes),
            _ => 0,
        };
        // A matrix bake's joint sets are its own tables ([`crate::bake::matrix`]): the
        // vector tables keep their one set.
        let vector_sets = match options.transfer {
            TransferKind::Vector => strata::set_count(groups),
            TransferKind::Matrix => 1,
        };
        let tables = match (options.sampling, &adaptive) {
            (Sampling::OwenSobol, None) => SampleSets::new(options, &basis, vector_sets),
            _ => SampleSets::default(),
        };
        let strata = match groups {
            0 => Vec::new(),
            _ => receivers.strata.unwrap_or_default(),
        };
        Ok(Estimator {
            options: options.clone(),
            rotator: ZyzRotator::new(options.order),
            basis,
            normals: receivers.normals,
            origins: receivers.origins,
            horizons: receivers.horizons,
            streams: receivers.streams,
            tables,
            adaptive,
            groups,
            strata,
        })
    }

    /// Adaptive bakes: the pilot's and extensions' tables ([`crate::bake::adaptive`]).
    pub(crate) fn adaptive_tables(&self) -> Option<&crate::bake::adaptive::Tables> {
        self.adaptive.as_ref()
    }

    /// How many receivers the estimator bakes.
    pub fn receiver_count(&self) -> usize {
        self.normals.len()
    }

    /// The batches of sample indices a vertex traces ([`batch_ranges`]).
    fn batches(&self) -> impl Iterator<Item = std::ops::Range<usize>> {
        batch_ranges(&self.options)
    }

    /// The random stream receiver `v` samples from ([`Receivers::streams`]).
    fn stream(&self, v: usize) -> u64 {
        self.streams.as_ref().map_or(v as u64, |s| s[v])
    }

    /// The sample sets the bake's tables hold, vector or matrix: the joint sets
    /// ([`strata`]), or one.
    pub(crate) fn set_count(&self) -> u32 {
        strata::set_count(self.groups)
    }

    /// The set receiver `v` samples, of [`Estimator::set_count`]: its stratum's
    /// ([`strata::set_of`]), or the one set. Its frame is then unturned
    /// ([`Estimator::vertex_frame`]).
    pub(crate) fn set(&self, v: usize) -> usize {
        match self.groups {
            0 => 0,
            groups => strata::set_of(self.options.seed, self.strata[v], groups),
        }
    }

    /// The first of receiver `v`'s `samples` rows in the tables (the vector estimator's or
    /// the matrix one's: each set takes `samples` rows).
    pub(crate) fn first_row(&self, v: usize) -> usize {
        self.set(v) * self.options.samples as usize
    }

    /// Vertex `v`'s local frame (columns: tangent, bitangent, normal), turned about the normal
    /// by an angle drawn from (seed, v); unturned where the receivers sample joint sets, which
    /// complement one another in one frame ([`strata`]).
    pub fn vertex_frame(&self, v: usize) -> Mat3 {
        let frame = Frame::from_normal(self.normals[v]);
        if self.groups > 0 {
            return Mat3::from_cols(frame.tangent, frame.bitangent, frame.normal);
        }
        let angle = std::f32::consts::TAU
            * to_unit_float(vertex_seed(self.options.seed, self.stream(v)) as u32);
        let (sin, cos) = angle.sin_cos();
        let tangent = frame.tangent * cos + frame.bitangent * sin;
        let bitangent = frame.normal.cross(tangent);
        Mat3::from_cols(tangent, bitangent, frame.normal)
    }

    /// Where vertex `v`'s rays start (see [`crate::trace::ray_origins`]).
    pub fn origin(&self, v: usize) -> Vec3 {
        self.origins[v]
    }

    /// The directions vertex `v` casts rays in for samples `range` (what the bake traces), with
    /// their estimator weights. `frame` is [`Estimator::vertex_frame`]`(v)`.
    pub fn directions(
        &self,
        v: usize,
        frame: &Mat3,
        range: std::ops::Range<usize>,
        dirs: &mut Vec<Vec3>,
        weights: &mut Vec<f32>,
    ) {
        dirs.clear();
        weights.clear();
        match self.options.sampling {
            Sampling::OwenSobol => {
                let first = self.first_row(v);
                let rows = first + range.start..first + range.end;
                dirs.extend(self.tables.dirs[rows].iter().map(|d| *frame * *d));
                weights.resize(dirs.len(), 1.0);
            }
            Sampling::ThesisRandom => {
                // Uniform over the hemisphere: the thesis's sphere points, those below the
                // horizon rejected; the cosine goes into the weight.
                let normal = self.normals[v];
                let mut rng = Pcg32::new(
                    vertex_seed(self.options.seed, self.stream(v)),
                    range.start as u64,
                );
                for _ in range {
                    let (dir, cos) = loop {
                        let d = uniform_sphere(rng.next_f32(), rng.next_f32());
                        let cos = d.dot(normal);
                        if cos > 0.0 {
                            break (d, cos);
                        }
                    };
                    dirs.push(dir);
                    weights.push(cos);
                }
            }
        }
    }

    /// The estimator's normalisation: a sample of weight w stands for (w · norm) of the
    /// cosine-weighted hemisphere, whose total is 1.
    pub(crate) fn norm(&self) -> f64 {
        Estimator::norm_of(&self.options)
    }

    /// [`Estimator::norm`] from the options alone (the merge of shard parts has no scene).
    pub(crate) fn norm_of(options: &BakeOptions) -> f64 {
        match options.sampling {
            // Cosine-weighted samples: each is 1/N of the cosine-weighted hemisphere.
            Sampling::OwenSobol => 1.0 / f64::from(options.samples),
            // Uniform over the hemisphere, weight cos θ: (2π/N)·cos θ/π each.
            Sampling::ThesisRandom => 2.0 / f64::from(options.samples),
        }
    }

    /// One batch of an interreflected bake (directions already in `s.dirs`): bounce
    /// samples are traced with closest-hit rays, their front hits going into `rows` with
    /// weight × N/M; other batches (only when `occlusion`) with occlusion rays. Fills
    /// `s.occluded` for the rays traced.
    fn trace_recording_batch(
        &self,
        v: usize,
        batch: std::ops::Range<usize>,
        tracer: &dyn Tracer,
        s: &mut Scratch,
        rows: &mut JobRows<'_>,
        occlusion: bool,
    ) {
        let origin = self.origins[v];
        let len = batch.len();
        if batch.start >= self.options.effective_bounce_samples() as usize {
            if occlusion {
                tracer.occluded_from(origin, &s.dirs, &mut s.occluded[..len]);
            }
            return;
        }
        let hits = &mut s.hits[..len];
        tracer.intersect_from(origin, &s.dirs, hits);
        let scale = self.options.samples as f32 / self.options.effective_bounce_samples() as f32;
        let probe = self.corner_probe(tracer);
        let horizon = self.horizon(v);
        for (((blocked, hit), dir), weight) in s
            .occluded
            .iter_mut()
            .zip(hits.iter())
            .zip(&s.dirs)
            .zip(&s.weights)
        {
            *blocked = hit.is_some();
            if let Some(hit) = hit
                && horizon.is_none_or(|h| h.dot(*dir) > 0.0)
            {
                rows.record(hit, *dir, weight * scale, &mut s.rows, &probe);
            }
        }
    }

    /// Receiver `v`'s surface normal where its lobe is turned off it ([`Receivers::horizons`]).
    fn horizon(&self, v: usize) -> Option<Vec3> {
        self.horizons.as_ref().map(|h| h[v])
    }

    /// Counts the directions of `dirs` below receiver `v`'s surface as blocked: the surface
    /// itself stops them, whatever the tracer says (a ray just off a flat surface and aimed
    /// into it may miss it near an edge, and would see through it).
    fn block_below_horizon(&self, v: usize, dirs: &[Vec3], occluded: &mut [bool]) {
        if let Some(h) = self.horizon(v) {
            for (blocked, dir) in occluded.iter_mut().zip(dirs) {
                *blocked |= h.dot(*dir) <= 0.0;
            }
        }
    }

    /// What tests a hit triangle's corners for embedding (the same answers in every pass
    /// of a bake: a pure function of the seed and the vertex).
    pub(crate) fn corner_probe<'t>(&'t self, tracer: &'t dyn Tracer) -> CornerProbe<'t> {
        CornerProbe {
            tracer,
            origins: &self.origins,
            normals: &self.normals,
            seed: self.options.seed,
        }
    }

    /// Re-traces vertex `v`'s bounce samples only and records its bounce row (what the
    /// direct pass recorded, when the rows could not be kept).
    pub(crate) fn bounce_row(
        &self,
        v: usize,
        tracer: &dyn Tracer,
        s: &mut Scratch,
        rows: &mut JobRows<'_>,
    ) {
        let frame = self.vertex_frame(v);
        rows.begin_vertex();
        let bounce = self.options.effective_bounce_samples() as usize;
        for batch in self.batches().take_while(|b| b.start < bounce) {
            self.directions(v, &frame, batch.clone(), &mut s.dirs, &mut s.weights);
            self.trace_recording_batch(v, batch, tracer, s, rows, false);
        }
        rows.end_vertex(&mut s.rows);
    }

    /// The shadowed (or unshadowed, with no tracer) transfer of vertex `v` into `out`, and
    /// its [`Visibility`]. With `hits` (interreflected mode), the bounce samples are traced
    /// with closest-hit rays and their front hits recorded for the bounce passes.
    pub fn receiver_transfer(
        &self,
        v: usize,
        tracer: Option<&dyn Tracer>,
        s: &mut Scratch,
        out: &mut [f32],
        mut hits: Option<&mut JobRows<'_>>,
    ) -> Visibility {
        if let Some(tables) = &self.adaptive {
            return self.adaptive_vertex_transfer(v, tables, tracer, s, out);
        }
        let n = self.basis.coeff_count();
        let frame = self.vertex_frame(v);
        s.total.fill(0.0);
        s.noise.clear();
        let (mut unblocked, mut bent) = (0.0f64, Vec3::ZERO);
        if let Some(hits) = hits.as_deref_mut() {
            hits.begin_vertex();
        }
        for (b, batch) in self.batches().enumerate() {
            let (start, end) = (batch.start, batch.end);
            self.directions(v, &frame, batch.clone(), &mut s.dirs, &mut s.weights);
            let len = end - start;
            match (tracer, hits.as_deref_mut()) {
                (Some(tracer), Some(hits)) => {
                    self.trace_recording_batch(v, batch, tracer, s, hits, true);
                }
                (Some(tracer), None) => {
                    tracer.occluded_from(self.origins[v], &s.dirs, &mut s.occluded[..len])
                }
                (None, _) => s.occluded[..len].fill(false),
            }
            if tracer.is_some() {
                self.block_below_horizon(v, &s.dirs, &mut s.occluded[..len]);
            }
            match self.options.sampling {
                Sampling::OwenSobol => {
                    self.sum_owen_sobol_batch(v, b, start..end, s, &mut unblocked)
                }
                Sampling::ThesisRandom => self.sum_thesis_batch(len, s, &mut unblocked, &mut bent),
            }
            for (total, b) in s.total.iter_mut().zip(&s.batch_sum) {
                *total += f64::from(*b);
            }
        }
        if let Some(hits) = hits {
            hits.end_vertex(&mut s.rows);
        }
        let norm = self.norm();
        let (total, local_bent) = s.total.split_at_mut(n);
        for t in total.iter_mut() {
            *t *= norm;
        }
        match self.options.sampling {
            // Formed in the local frame: rotate into world space.
            Sampling::OwenSobol => {
                let local_bent = glam::DVec3::from_slice(local_bent).as_vec3();
                bent = frame * local_bent;
                self.rotator
                    .rotate(frame.as_dmat3(), total, &mut s.world, &mut s.rotation);
            }
            Sampling::ThesisRandom => s.world.copy_from_slice(total),
        }
        for (o, w) in out.iter_mut().zip(&s.world) {
            *o = *w as f32;
        }
        Visibility {
            accessibility: (unblocked * norm) as f32,
            bent_normal: bent.try_normalize().unwrap_or(self.normals[v]),
            rays: if tracer.is_some() {
                self.options.samples
            } else {
                0
            },
            points: self.options.samples,
            error_estimate: 0.0,
            noise: match (tracer, self.options.sampling) {
                (Some(_), Sampling::OwenSobol) => s.noise.variance(self.options.samples),
                _ => 0.0,
            },
        }
    }

    /// Receiver `v`'s Owen–Sobol batch `b` (rays `rays`): every weight is 1, so the sum of
    /// the unblocked rows, formed as the batch's precomputed total minus its blocked rows
    /// when fewer are blocked; the rows' last columns carry the local direction, so the same
    /// sum gives the bent normal. Adds the unblocked count to `unblocked`.
    fn sum_owen_sobol_batch(
        &self,
        v: usize,
        b: usize,
        rays: std::ops::Range<usize>,
        s: &mut Scratch,
        unblocked: &mut f64,
    ) {
        let first = self.first_row(v);
        let b = b + first / self.options.samples as usize * self.batches().count();
        let (start, end) = (first + rays.start, first + rays.end);
        let len = end - start;
        let occluded = &s.occluded[..len];
        let blocked = occluded.iter().filter(|&&b| b).count();
        *unblocked += (len - blocked) as f64;
        let width = self.basis.coeff_count() + DIR_COLUMNS;
        let rows = self.tables.rows[start * width..end * width].chunks_exact(width);
        s.noise
            .add_unblocked(rows.clone(), &self.tables.row_blocks[start..end], occluded);
        if 2 * blocked <= len {
            s.batch_sum
                .copy_from_slice(&self.tables.batch_totals[b * width..(b + 1) * width]);
            for (row, _) in rows.zip(occluded).filter(|(_, blocked)| **blocked) {
                sub_row(&mut s.batch_sum, row);
            }
        } else {
            s.batch_sum.fill(0.0);
            for (row, _) in rows.zip(occluded).filter(|(_, blocked)| !**blocked) {
                add_row(&mut s.batch_sum, row);
            }
        }
    }

    /// The thesis's estimator over a batch of `len` rays: the basis evaluated at each
    /// unblocked world direction, times its weight; accessibility and bent normal summed
    /// as it goes.
    fn sum_thesis_batch(&self, len: usize, s: &mut Scratch, unblocked: &mut f64, bent: &mut Vec3) {
        s.batch_sum.fill(0.0);
        let occluded = &s.occluded[..len];
        for ((dir, &blocked), &weight) in s.dirs.iter().zip(occluded.iter()).zip(&s.weights) {
            if !blocked {
                self.basis.eval(*dir, &mut s.y);
                for (acc, y) in s.batch_sum.iter_mut().zip(&s.y) {
                    *acc += weight * y;
                }
                *unblocked += f64::from(weight);
                *bent += *dir * weight;
            }
        }
    }

    /// [`Estimator::receiver_transfer`] of an adaptive bake: rounds of rays until the estimated
    /// error is at most the target ([`crate::bake::adaptive`]).
    fn adaptive_vertex_transfer(
        &self,
        v: usize,
        tables: &crate::bake::adaptive::Tables,
        tracer: Option<&dyn Tracer>,
        s: &mut Scratch,
        out: &mut [f32],
    ) -> Visibility {
        let n = self.basis.coeff_count();
        let frame = self.vertex_frame(v);
        let result = crate::bake::adaptive::receiver_transfer(
            tables,
            n,
            self.origins[v],
            &frame,
            tracer,
            &mut s.adaptive,
            &mut s.total[..n],
        );
        self.rotator.rotate(
            frame.as_dmat3(),
            &s.total[..n],
            &mut s.world,
            &mut s.rotation,
        );
        for (o, w) in out.iter_mut().zip(&s.world) {
            *o = *w as f32;
        }
        Visibility {
            accessibility: (f64::from(result.unblocked) / f64::from(result.points)) as f32,
            bent_normal: result.bent.try_normalize().unwrap_or(self.normals[v]),
            rays: result.rays,
            points: result.points,
            error_estimate: result.error as f32,
            noise: 0.0,
        }
    }
}

/// Per-thread buffers, reused across vertices.
pub struct Scratch {
    dirs: Vec<Vec3>,
    occluded: Vec<bool>,
    hits: Vec<Option<crate::trace::Hit>>,
    /// Interreflected mode: the current vertex's bounce row.
    rows: RowBuilder,
    weights: Vec<f32>,
    y: Vec<f32>,
    /// A batch's sums and the run's totals: n² coefficients, then [`DIR_COLUMNS`].
    batch_sum: Vec<f32>,
    total: Vec<f64>,
    world: Vec<f64>,
    /// The current receiver's SH rotation blocks.
    rotation: RotationScratch,
    adaptive: crate::bake::adaptive::AdaptiveScratch,
    /// The current receiver's sums per block of its sequence (its noise estimate).
    noise: NoiseBlocks,
}

impl Scratch {
    pub fn new(n: usize) -> Scratch {
        Scratch {
            dirs: Vec::with_capacity(BATCH),
            occluded: vec![false; BATCH],
            hits: vec![None; BATCH],
            rows: Default::default(),
            weights: Vec::with_capacity(BATCH),
            y: vec![0.0; n],
            batch_sum: vec![0.0; n + DIR_COLUMNS],
            total: vec![0.0; n + DIR_COLUMNS],
            world: vec![0.0; n],
            rotation: Default::default(),
            adaptive: Default::default(),
            noise: NoiseBlocks::new(n),
        }
    }
}
