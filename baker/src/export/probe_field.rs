//! Reading transfer probes at any point, and relighting a rigid object that moves through
//! them (docs/guides/probes.md).
//!
//! **Interpolation.** Between the probes of a grid, the incident radiance at x is the
//! trilinear blend of the 8 probes around it, L_in(x) = Σ w_p M_p·L. Probes inside geometry
//! ([`ProbeBlock::valid`]: mostly back faces seen) are left out and the others' weights
//! renormalised, so a probe under the floor or inside a block neither darkens nor brightens
//! what is near it (DDGI's probe classification; what is left of a leak is measured in
//! `tests/probe_interpolation.rs`). Outside the grid's cell centres, x is clamped to them.
//!
//! **Rigid objects.** An object baked alone (its own transfer T, in its local frame) placed at
//! x with rotation q receives, in its frame, L_obj = R(q⁻¹)·L_in(x) (Sloan, Kautz & Snyder
//! 2002, §7: the light turned into the object's frame), and a vertex's radiance is
//! albedo · T·L_obj, as [`crate::export::relight::vertex_radiance`] computes it. The scene's
//! shadow and colour reach the object through L_in; its own shadowing stays in T.

use std::path::Path;

use glam::{DQuat, Vec3};

use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::probe_block::{ProbeBlock, ProbeGrid};
use crate::light::LightCoefficients;
use crate::math::sh::{self, rotation::ShRotation};
use crate::support::error::{Error, Result};

/// A probe file's probes, ready to be read at any point.
pub struct ProbeField<'a> {
    probes: &'a ProbeBlock,
    grid: ProbeGrid,
    /// `matrices[((p · channels + c) · n² + i) · n² + j]`.
    matrices: &'a [f32],
    channels: usize,
    order: usize,
}

impl<'a> ProbeField<'a> {
    /// The field of a probe file baked on a grid (`bake --probes grid:…`); an error (a
    /// sentence) for any other file.
    pub fn new(file: &'a CoefficientFile) -> std::result::Result<ProbeField<'a>, String> {
        let probes = file
            .probes
            .as_ref()
            .ok_or("not a probe bake (bake --probes)")?;
        let grid = probes.grid.ok_or(
            "a probe bake of a list of points: interpolation needs a grid (--probes grid:…)",
        )?;
        Ok(ProbeField {
            probes,
            grid,
            matrices: &file.coefficients,
            channels: file.header.channels as usize,
            order: file.header.order as usize,
        })
    }

    pub fn order(&self) -> usize {
        self.order
    }

    /// Refuses probes (the file `probes`) of another order than `order`, that of `bake`
    /// (what is lit through them, named for the message: "the object FILE").
    pub fn require_order(&self, probes: &Path, order: usize, bake: &str) -> Result<()> {
        if self.order == order {
            return Ok(());
        }
        Err(Error::InvalidOption(format!(
            "{}: probes of order {}, but {bake} is of order {order}",
            probes.display(),
            self.order
        )))
    }

    /// The probes' weights at `x`: trilinear over the 8 around it (fewer at a grid of one
    /// probe along an axis), invalid probes left out and the rest renormalised (with
    /// `validity`); empty where every one of them is invalid.
    pub fn weights(&self, x: Vec3, validity: bool) -> Vec<(usize, f64)> {
        let g = &self.grid;
        let counts = g.counts.map(|c| c as usize);
        let size = (g.hi - g.lo) / Vec3::new(counts[0] as f32, counts[1] as f32, counts[2] as f32);
        // Continuous grid coordinates: probe (i, j, k) sits at (i, j, k).
        let u = ((x - g.lo) / size.max(Vec3::splat(f32::MIN_POSITIVE)) - 0.5).to_array();
        let mut axes = [[(0usize, 1.0f64); 2]; 3];
        for (axis, (&u, &n)) in axes.iter_mut().zip(u.iter().zip(&counts)) {
            let u = f64::from(u).clamp(0.0, (n - 1) as f64);
            let i = (u.floor() as usize).min(n.saturating_sub(2));
            let t = if n == 1 { 0.0 } else { u - i as f64 };
            *axis = [(i, 1.0 - t), ((i + 1).min(n - 1), t)];
        }
        let mut weights: Vec<(usize, f64)> = Vec::with_capacity(8);
        for &(k, wz) in &axes[2] {
            for &(j, wy) in &axes[1] {
                for &(i, wx) in &axes[0] {
                    let p = g.index([i as u32, j as u32, k as u32]);
                    let w = wx * wy * wz;
                    if w > 0.0 && (!validity || self.probes.valid(p)) {
                        weights.push((p, w));
                    }
                }
            }
        }
        let total: f64 = weights.iter().map(|(_, w)| w).sum();
        weights.iter_mut().for_each(|(_, w)| *w /= total);
        weights
    }

    /// L_in = M_p·L at probe `p`, per channel (one matrix serves every light channel of a
    /// grey bake).
    pub fn probe_incident(&self, p: usize, light: &LightCoefficients) -> LightCoefficients {
        self.blend(&[(p, 1.0)], light)
    }

    /// L_in at `x`: the blend [`ProbeField::weights`] gives of the probes' M·L (zero light
    /// where every probe around x is invalid).
    pub fn incident(
        &self,
        x: Vec3,
        light: &LightCoefficients,
        validity: bool,
    ) -> LightCoefficients {
        self.blend(&self.weights(x, validity), light)
    }

    fn blend(&self, weights: &[(usize, f64)], light: &LightCoefficients) -> LightCoefficients {
        assert_eq!(light.order(), self.order, "a light of another order");
        let n = sh::coeff_count(self.order);
        let mut out = LightCoefficients::zero(self.order);
        for &(p, w) in weights {
            for (c, (out, l)) in out.rgb.iter_mut().zip(&light.rgb).enumerate() {
                let channel = if self.channels == 1 { 0 } else { c };
                let start = (p * self.channels + channel) * n * n;
                let m = &self.matrices[start..start + n * n];
                for (o, row) in out.iter_mut().zip(m.chunks_exact(n)) {
                    let dot: f64 = row.iter().zip(l).map(|(&a, &b)| f64::from(a) * b).sum();
                    *o += w * dot;
                }
            }
        }
        out
    }
}

/// The light a rigid object placed with `rotation` receives in its own frame from the
/// incident radiance `incident` (world frame): R(q⁻¹)·L_in.
pub fn into_object_frame(incident: &LightCoefficients, rotation: DQuat) -> LightCoefficients {
    incident.rotated(&ShRotation::from_quat(incident.order(), rotation.inverse()))
}

/// Per-vertex linear RGB radiance of a rigid object (`object`: a vector bake of the object
/// alone, in its local frame, with per-vertex `albedo`) placed at `position` with `rotation`
/// in the probes' scene, lit by `light`.
pub fn rigid_radiance(
    object: &CoefficientFile,
    albedo: &[Vec3],
    field: &ProbeField,
    (position, rotation): (Vec3, DQuat),
    light: &LightCoefficients,
) -> Vec<[f32; 3]> {
    let incident = field.incident(position, light, true);
    let local = into_object_frame(&incident, rotation);
    crate::export::relight::vertex_radiance(object, albedo, &local)
}
