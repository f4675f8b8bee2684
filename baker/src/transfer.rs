//! Per-vertex diffuse transfer: T_j = (1/π) ∫ V(x, s) max(n·s, 0) y_j(s) ds.
//!
//! * `unshadowed`: V = 1 (the thesis's "fast mode"); no rays are cast but the estimator and
//!   the directions are the same as for `shadowed`.
//! * `shadowed`: V is 0 where an occlusion ray from the vertex is blocked.
//!
//! The stored transfer excludes the receiving surface's own albedo: the renderer multiplies by
//! Kd × texture per pixel, so textures stay sharp between vertices.
//!
//! # How the default estimator is organised
//!
//! The thesis generates its sample directions and evaluates the SH basis at them once, for
//! all vertices. The default estimator does the same in each vertex's *local* frame (z along
//! the normal): one Owen-scrambled, cosine-weighted point set per bake (from the seed), with
//! y_j precomputed at every point. A vertex turns the set by its own random angle about its
//! normal (so neighbouring vertices do not share sample directions), casts the rays, adds the
//! table rows of the unblocked ones, and rotates the local coefficients into world space once
//! ([`crate::sh::Rotator`], exact). Per ray that is a 3×3 transform and a row sum: the cost of
//! a bake is the cost of its rays. The table takes N·(12 + 4n²) bytes: 0.8 MB for the demo's
//! 10,000 rays at order 4, 270 MB for a million rays at order 8.
//!
//! Every quantity is a pure function of (seed, vertex, sample index) and sums are formed in a
//! fixed order, so a bake is bit-identical whatever the number of threads.

use std::time::Instant;

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::sampling::{
    Frame, OwenSobol, Pcg32, Sampling, cosine_hemisphere, hilbert_index, to_unit_float,
    uniform_sphere, vertex_seed,
};
use crate::scene::Scene;
use crate::sh::{self, Basis, Rotator};
use crate::trace::{Backend, Tracer, ray_origins};

/// What the transfer function includes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    Unshadowed,
    #[default]
    Shadowed,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Unshadowed => "unshadowed",
            Mode::Shadowed => "shadowed",
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BakeOptions {
    /// SH order n (n² coefficients).
    pub order: usize,
    /// Directions (rays, in shadowed mode) per vertex.
    pub samples: u32,
    pub mode: Mode,
    pub seed: u64,
    pub sampling: Sampling,
}

impl Default for BakeOptions {
    fn default() -> BakeOptions {
        BakeOptions {
            order: 4,
            samples: 1024,
            mode: Mode::Shadowed,
            seed: 0,
            sampling: Sampling::OwenSobol,
        }
    }
}

impl BakeOptions {
    pub fn validate(&self) -> Result<()> {
        if !(1..=sh::MAX_ORDER).contains(&self.order) {
            return Err(Error::InvalidOption(format!(
                "--order {} is outside 1..={}",
                self.order,
                sh::MAX_ORDER
            )));
        }
        if self.samples == 0 {
            return Err(Error::InvalidOption("--samples must be at least 1".into()));
        }
        Ok(())
    }
}

/// The result of a bake: `coefficients[(v · channels + c) · n² + j]`.
#[derive(Clone, Debug)]
pub struct Transfer {
    /// The options the bake ran with.
    pub options: BakeOptions,
    pub channels: usize,
    pub vertex_count: usize,
    pub coefficients: Vec<f32>,
    pub backend: Backend,
    /// Rays actually cast (0 for unshadowed).
    pub rays_cast: u64,
    pub seconds: f64,
}

impl Transfer {
    /// Coefficients of vertex `v`, channel `c`.
    pub fn vertex(&self, v: usize, c: usize) -> &[f32] {
        let n = sh::coeff_count(self.options.order);
        let start = (v * self.channels + c) * n;
        &self.coefficients[start..start + n]
    }
}

/// Rays per tracer call: the batch over which the SH sums are first formed in f32.
const BATCH: usize = 256;
/// Vertices per parallel work item: progress is reported per item.
const VERTICES_PER_JOB: usize = 8;

/// Bakes the transfer of every vertex. `tracer` may be `None` only in unshadowed mode.
pub fn bake(
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    progress: &dyn Progress,
) -> Result<Transfer> {
    let tracer = match (options.mode, tracer) {
        (Mode::Unshadowed, _) => None,
        (Mode::Shadowed, Some(t)) => Some(t),
        (Mode::Shadowed, None) => {
            return Err(Error::InvalidOption(
                "shadowed transfer needs a ray-tracing backend".into(),
            ));
        }
    };
    let started = Instant::now();
    let estimator = Estimator::new(scene, options)?;
    let n = estimator.basis.coeff_count();
    let vertex_count = scene.vertex_count();
    let rays_per_vertex = if tracer.is_some() {
        u64::from(options.samples)
    } else {
        0
    };
    progress.begin(vertex_count as u64, rays_per_vertex);

    let mut coefficients = vec![0.0f32; vertex_count * n];
    coefficients
        .par_chunks_mut(VERTICES_PER_JOB * n)
        .enumerate()
        .for_each_init(
            || Scratch::new(n),
            |scratch, (job, out)| {
                let first = job * VERTICES_PER_JOB;
                for (k, out) in out.chunks_mut(n).enumerate() {
                    estimator.vertex_transfer(first + k, tracer, scratch, out);
                }
                progress.advance((out.len() / n) as u64);
            },
        );
    progress.finish();

    Ok(Transfer {
        options: options.clone(),
        channels: 1,
        vertex_count,
        coefficients,
        backend: tracer.map_or(Backend::None, |t| t.backend()),
        rays_cast: rays_per_vertex * vertex_count as u64,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// What all vertices of one bake share, and the per-vertex estimator.
pub struct Estimator {
    options: BakeOptions,
    basis: Basis,
    rotator: Rotator,
    normals: Vec<Vec3>,
    origins: Vec<Vec3>,
    /// The bake's cosine-weighted directions in the local frame (Owen–Sobol only).
    local_dirs: Vec<Vec3>,
    /// y_j(local_dirs[i]) at `[i·n² + j]`.
    local_sh: Vec<f32>,
}

impl Estimator {
    pub fn new(scene: &Scene, options: &BakeOptions) -> Result<Estimator> {
        options.validate()?;
        let basis = Basis::new(options.order);
        let n = basis.coeff_count();
        let (mut local_dirs, mut local_sh) = (Vec::new(), Vec::new());
        if options.sampling == Sampling::OwenSobol {
            let points = OwenSobol::new(vertex_seed(options.seed, u64::MAX));
            let mut uv: Vec<(f32, f32)> = (0..options.samples).map(|i| points.point(i)).collect();
            // Consecutive rays with close directions trace much faster (Embree forms
            // coherent packets); the set, and so the estimate, is unchanged by the order.
            uv.sort_by_key(|&(u1, u2)| hilbert_index(u1, u2));
            local_dirs = uv
                .iter()
                .map(|&(u1, u2)| cosine_hemisphere(u1, u2))
                .collect();
            local_sh = vec![0.0; local_dirs.len() * n];
            for (row, d) in local_sh.chunks_mut(n).zip(&local_dirs) {
                basis.eval(*d, row);
            }
        }
        Ok(Estimator {
            options: options.clone(),
            rotator: Rotator::new(options.order),
            basis,
            normals: scene.normals.clone(),
            origins: ray_origins(scene),
            local_dirs,
            local_sh,
        })
    }

    /// Vertex `v`'s local frame (columns: tangent, bitangent, normal), turned about the normal
    /// by an angle drawn from (seed, v).
    pub fn vertex_frame(&self, v: usize) -> Mat3 {
        let frame = Frame::from_normal(self.normals[v]);
        let angle =
            std::f32::consts::TAU * to_unit_float(vertex_seed(self.options.seed, v as u64) as u32);
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
                dirs.extend(self.local_dirs[range].iter().map(|d| *frame * *d));
                weights.resize(dirs.len(), 1.0);
            }
            Sampling::ThesisRandom => {
                // Uniform over the hemisphere: the thesis's sphere points, those below the
                // horizon rejected; the cosine goes into the weight.
                let normal = self.normals[v];
                let mut rng =
                    Pcg32::new(vertex_seed(self.options.seed, v as u64), range.start as u64);
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

    /// The transfer coefficients of vertex `v` into `out`.
    pub fn vertex_transfer(
        &self,
        v: usize,
        tracer: Option<&dyn Tracer>,
        s: &mut Scratch,
        out: &mut [f32],
    ) {
        let n = self.basis.coeff_count();
        let samples = self.options.samples as usize;
        let frame = self.vertex_frame(v);
        s.total.fill(0.0);
        let mut start = 0;
        while start < samples {
            let end = (start + BATCH).min(samples);
            self.directions(v, &frame, start..end, &mut s.dirs, &mut s.weights);
            let occluded = &mut s.occluded[..end - start];
            match tracer {
                Some(tracer) => tracer.occluded_from(self.origins[v], &s.dirs, occluded),
                None => occluded.fill(false),
            }
            s.batch_sum.fill(0.0);
            match self.options.sampling {
                Sampling::OwenSobol => {
                    let rows = self.local_sh[start * n..end * n].chunks_exact(n);
                    for (row, &blocked) in rows.zip(occluded.iter()) {
                        if !blocked {
                            for (acc, y) in s.batch_sum.iter_mut().zip(row) {
                                *acc += y;
                            }
                        }
                    }
                }
                Sampling::ThesisRandom => {
                    for ((dir, &blocked), &weight) in
                        s.dirs.iter().zip(occluded.iter()).zip(&s.weights)
                    {
                        if !blocked {
                            self.basis.eval(*dir, &mut s.y);
                            for (acc, y) in s.batch_sum.iter_mut().zip(&s.y) {
                                *acc += weight * y;
                            }
                        }
                    }
                }
            }
            for (total, b) in s.total.iter_mut().zip(&s.batch_sum) {
                *total += f64::from(*b);
            }
            start = end;
        }
        match self.options.sampling {
            // Cosine-weighted: T_j ≈ (1/N) Σ V y_j, formed in the local frame, then rotated.
            Sampling::OwenSobol => {
                for t in s.total.iter_mut() {
                    *t /= samples as f64;
                }
                self.rotator
                    .rotate(frame.as_dmat3(), &s.total, &mut s.world);
            }
            // Uniform over the hemisphere: T_j ≈ (2π/N) Σ (1/π) V cos y_j.
            Sampling::ThesisRandom => {
                for (w, t) in s.world.iter_mut().zip(&s.total) {
                    *w = t * 2.0 / samples as f64;
                }
            }
        }
        for (o, w) in out.iter_mut().zip(&s.world) {
            *o = *w as f32;
        }
    }
}

/// Per-thread buffers, reused across vertices.
pub struct Scratch {
    dirs: Vec<Vec3>,
    occluded: Vec<bool>,
    weights: Vec<f32>,
    y: Vec<f32>,
    batch_sum: Vec<f32>,
    total: Vec<f64>,
    world: Vec<f64>,
}

impl Scratch {
    pub fn new(n: usize) -> Scratch {
        Scratch {
            dirs: Vec::with_capacity(BATCH),
            occluded: vec![false; BATCH],
            weights: Vec::with_capacity(BATCH),
            y: vec![0.0; n],
            batch_sum: vec![0.0; n],
            total: vec![0.0; n],
            world: vec![0.0; n],
        }
    }
}
