//! The bounce rays of an interreflected transfer-matrix bake ([`crate::bake::matrix_bounce`]
//! says what is summed and why): what a front hit reads (ρ·T^{B−1}, gathered exactly as the
//! vector bake's bounce rows read it), and the non-symmetric sums y(s) ⊗ ρ·T(h) over a
//! batch's hits, in 4 × 8 tiles kept in registers as the shadowed part's triangle is.

use glam::Vec3;

use crate::bake::bounce_rows::{CornerProbe, JobRows};
use crate::math::sh::rotation::ShRotation;
use crate::trace::{Hit, Tracer};

/// Rows of a bounce tile (y_i broadcast) and its columns (one AVX register of ρ·T).
pub(crate) const ROWS: usize = 4;
pub(crate) const LANES: usize = 8;

/// What the bounce rays of a matrix bake read at their hits: T^{B−1} at every vertex, and how
/// a hit maps to vertices.
pub(crate) struct BounceLight<'a> {
    pub(crate) rows: JobRows<'a>,
    pub(crate) probe: CornerProbe<'a>,
    /// T^{B−1}: `previous[(v · previous_channels + c) · n² + j]`, world coefficients.
    pub(crate) previous: Vec<f32>,
    pub(crate) previous_channels: usize,
    /// Channels of the matrices (3 unless every albedo is grey).
    pub(crate) channels: usize,
    pub(crate) n: usize,
    /// Stride of a gathered row: channels · n² rounded up to [`LANES`].
    pub(crate) width: usize,
    /// Rays per receiver traced for their closest hits (the first of its samples).
    pub(crate) bounce_samples: usize,
    /// Each bounce ray stands for 2π/M steradians.
    pub(crate) norm: f64,
}

impl<'a> BounceLight<'a> {
    /// ρ·T^{B−1} at `hit` (a ray along `dir`), per channel, into `out` (zero-padded to
    /// `width`); false for a back face, which reflects nothing.
    fn gather(&self, hit: &Hit, dir: Vec3, out: &mut [f32]) -> bool {
        let mut slots = [(0, Vec3::ZERO); 4];
        let count = self
            .rows
            .front_hit_slots(hit, dir, 1.0, &self.probe, &mut slots);
        if count == 0 {
            return false;
        }
        let n = self.n;
        out.fill(0.0);
        for &(slot, weight) in &slots[..count] {
            for c in 0..self.channels {
                let from = if self.previous_channels == 1 { 0 } else { c };
                let t = &self.previous[(slot as usize * self.previous_channels + from) * n..][..n];
                let w = weight[c];
                for (o, t) in out[c * n..(c + 1) * n].iter_mut().zip(t) {
                    *o += w * t;
                }
            }
        }
        true
    }
}

/// Per-thread buffers of the bounce sums.
pub(crate) struct BounceScratch {
    hits: Vec<Option<Hit>>,
    /// Sample index of each front hit of the batch, and its gathered row in `gathered`.
    selected: Vec<u32>,
    gathered: Vec<f32>,
    /// A batch's sums (rows padded to a multiple of [`ROWS`]) and the receiver's.
    batch_sum: Vec<f32>,
    total: Vec<f64>,
}

impl BounceScratch {
    pub(crate) fn new(light: &BounceLight, batch: usize) -> BounceScratch {
        let rows = light.n.div_ceil(ROWS) * ROWS;
        BounceScratch {
            hits: vec![None; batch],
            selected: Vec::with_capacity(batch),
            gathered: vec![0.0; batch * light.width],
            batch_sum: vec![0.0; rows * light.width],
            total: vec![0.0; rows * light.width],
        }
    }

    /// Starts a receiver.
    pub(crate) fn begin(&mut self) {
        self.total.fill(0.0);
    }

    /// Traces a batch of bounce samples (sample indices from `start`, world directions
    /// `dirs`) for their closest hits, fills `occluded`, and adds y ⊗ ρ·T of the front hits;
    /// `y` holds y at every sample in the local frame, rows of `y_width`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn trace_batch(
        &mut self,
        light: &BounceLight,
        (y, y_width): (&[f32], usize),
        tracer: &dyn Tracer,
        origin: Vec3,
        start: usize,
        dirs: &[Vec3],
        occluded: &mut [bool],
    ) {
        let hits = &mut self.hits[..dirs.len()];
        tracer.intersect_from(origin, dirs, hits);
        self.selected.clear();
        let w = light.width;
        for (k, ((hit, blocked), dir)) in hits.iter().zip(occluded.iter_mut()).zip(dirs).enumerate()
        {
            *blocked = hit.is_some();
            if let Some(hit) = hit {
                let q = self.selected.len();
                if light.gather(hit, *dir, &mut self.gathered[q * w..(q + 1) * w]) {
                    self.selected.push((start + k) as u32);
                }
            }
        }
        self.batch_sum.fill(0.0);
        accumulate_general(
            y,
            y_width,
            &self.selected,
            &self.gathered,
            w,
            &mut self.batch_sum,
        );
        for (t, b) in self.total.iter_mut().zip(&self.batch_sum) {
            *t += f64::from(*b);
        }
    }

    /// `out` (channels × n⁴) = `direct` (the shadowed part, world, n × n) + R · the bounce
    /// sums of each channel (rows from the local frame into world space).
    pub(crate) fn finish(
        &self,
        light: &BounceLight,
        rotation: &ShRotation,
        direct: &[f64],
        out: &mut [f32],
        column: &mut [f64],
        rotated: &mut [f64],
    ) {
        let n = light.n;
        for (c, out) in out.chunks_exact_mut(n * n).enumerate() {
            for j in 0..n {
                for (i, x) in column.iter_mut().enumerate() {
                    *x = self.total[i * light.width + c * n + j] * light.norm;
                }
                rotation.apply(column, rotated);
                for i in 0..n {
                    out[i * n + j] = (direct[i * n + j] + rotated[i]) as f32;
                }
            }
        }
    }
}

/// `out[i · width + k] += Σ_q y_{r_q}[i] · g_q[k]` over the selected rows r_q of `y` (padded
/// rows of `y_width`) and the rows g_q of `g` (`width` each): the non-symmetric outer
/// products, in 4 × 8 tiles whose sums stay in registers while the rows stream past.
fn accumulate_general(
    y: &[f32],
    y_width: usize,
    selected: &[u32],
    g: &[f32],
    width: usize,
    out: &mut [f32],
) {
    if selected.is_empty() {
        return;
    }
    let rows = out.len() / width;
    for i0 in (0..rows).step_by(ROWS) {
        for k0 in (0..width).step_by(LANES) {
            let mut acc = [[0.0f32; LANES]; ROWS];
            for (q, &r) in selected.iter().enumerate() {
                let yi: &[f32; ROWS] = y[r as usize * y_width + i0..][..ROWS]
                    .try_into()
                    .expect("4");
                let gk: &[f32; LANES] = g[q * width + k0..][..LANES].try_into().expect("8");
                for (a, &yv) in acc.iter_mut().zip(yi) {
                    for (a, &x) in a.iter_mut().zip(gk) {
                        *a += yv * x;
                    }
                }
            }
            for (ii, a) in acc.iter().enumerate() {
                for (o, x) in out[(i0 + ii) * width + k0..][..LANES].iter_mut().zip(a) {
                    *o += x;
                }
            }
        }
    }
}
