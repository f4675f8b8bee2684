//! What a bake estimates transfer at — its *receivers* — and how light bounced off a surface
//! finds its way back to them.
//!
//! A receiver is a point a ray leaves from and a shading normal: a scene vertex, or a
//! lightmap texel ([`crate::bake::lightmap`]). The estimator ([`crate::bake::estimator`]) treats both
//! alike, so they share sampling, tracing and determinism (receiver `i` seeds its frame as
//! vertex `i` does).
//!
//! Interreflection needs the way back ([`BounceTargets`]): a bounce ray's first hit (a
//! triangle and barycentrics) reads the previous bounce's transfer *at the hit*, as a
//! weighted sum over *slots* that hold values. For vertex bakes the slots are the vertices,
//! weighted by the hit's barycentrics (the interpolation a renderer does between vertices).
//! For texel bakes the slots are the W×H texels of the lightmap, weighted bilinearly around
//! the hit's lightmap UV (the lookup a renderer does in the lightmap).

use std::borrow::Cow;

use glam::{Vec2, Vec3};

use crate::bake::lightmap::atlas::Atlas;
use crate::bake::lightmap::dilation;
use crate::bake::lightmap::texels::{Texels, bilinear_taps};
use crate::scene::Scene;
use crate::trace::ray_origins;

/// Receivers per parallel work item (progress is reported per item; hit rows are kept per
/// item).
pub const RECEIVERS_PER_JOB: usize = 8;

/// What a bake estimates transfer at: a point a ray leaves from and a shading normal, per
/// receiver. Vertices and lightmap texels are both receivers, so they share sampling,
/// tracing and determinism (receiver index `i` seeds its frame as vertex `i` does).
#[derive(Clone, Debug, Default)]
pub struct Receivers {
    /// Where the receiver's rays start (already moved off its surface).
    pub origins: Vec<Vec3>,
    /// Unit shading normals: the lobe's axis (a texel's normal-mapped normal).
    pub normals: Vec<Vec3>,
    /// Where a receiver's lobe is turned off its surface (normal-mapped texels): per receiver,
    /// the surface normal, whose hemisphere bounds the rays that can leave. A direction below
    /// that surface counts as blocked whenever rays are traced (the surface itself stops it);
    /// unshadowed bakes keep the whole lobe. `None`: the lobe's axis is the surface's.
    pub horizons: Option<Vec<Vec3>>,
    /// Which random stream each receiver's samples come from (its rotation of the point set,
    /// its thesis-random directions): a texel's index y·W + x, so that a texel's samples do
    /// not depend on which other texels are baked (two backends that disagree on one leaking
    /// texel still sample every other texel alike). `None`: the receiver's position in the
    /// list, as for vertices.
    pub streams: Option<Vec<u64>>,
    /// Each receiver's stratum ([`crate::bake::strata`]: a texel's 4 × 4 tile and its place
    /// there, a vertex's rank in a spatial order), from which a denoised bake gives
    /// neighbours complementary point sets. `None`: every receiver samples on its own.
    pub strata: Option<Vec<u32>>,
}

impl Receivers {
    /// The scene's vertices, rays leaving from [`ray_origins`]; with their strata where a bake
    /// with `options` samples them jointly ([`crate::bake::strata::vertex_strata`], a sort
    /// of the vertices that other bakes skip).
    pub fn vertices(scene: &Scene, options: &crate::bake::options::BakeOptions) -> Receivers {
        let joint = crate::bake::strata::samples_jointly(options);
        Receivers {
            origins: ray_origins(scene),
            normals: scene.normals.clone(),
            horizons: None,
            streams: None,
            strata: joint.then(|| crate::bake::strata::vertex_strata(&scene.positions)),
        }
    }

    /// A lightmap's valid texels as receivers, in row-major order of the valid ones, each sampled from
    /// the stream of its texel index.
    pub fn texels(texels: &Texels) -> Receivers {
        // Only the valid texels' entries are read: the pages of empty ones stay unmapped
        // ([`Texels::rasterise`]).
        let valid: Vec<usize> = texels.valid_indices().collect();
        let pick = |values: &[Vec3]| -> Vec<Vec3> { valid.iter().map(|&i| values[i]).collect() };
        let streams = valid.iter().map(|&i| i as u64).collect();
        let turned = valid.iter().any(|&i| texels.mapped[i] != texels.normals[i]);
        Receivers {
            origins: pick(&texels.origins),
            normals: pick(&texels.mapped),
            horizons: turned.then(|| pick(&texels.normals)),
            streams: Some(streams),
            strata: Some(crate::bake::strata::texel_strata(&valid, texels.width)),
        }
    }

    /// [`Receivers::texels`], the points moved out of `texels` rather than copied: `texels`
    /// keeps its size and mask, its points are emptied. For a bake that reads no texel point
    /// after this (none but subsurface texels do): a 2048² lightmap's points are 218 MB, and
    /// an interreflected bake's peak comes later, at its bounces, which must stay under 1.5 GB.
    pub fn take_texels(texels: &mut Texels) -> Receivers {
        let valid: Vec<usize> = texels.valid_indices().collect();
        // Valid texels' entries to the front, in order (the same values `texels` picks).
        let compact = |values: &mut Vec<Vec3>| {
            let mut values = std::mem::take(values);
            for (to, &from) in valid.iter().enumerate() {
                values[to] = values[from];
            }
            values.truncate(valid.len());
            values.shrink_to_fit();
            values
        };
        let turned = valid.iter().any(|&i| texels.mapped[i] != texels.normals[i]);
        let streams = valid.iter().map(|&i| i as u64).collect();
        let strata = crate::bake::strata::texel_strata(&valid, texels.width);
        let origins = compact(&mut texels.origins);
        let normals = compact(&mut texels.mapped);
        let horizons = turned.then(|| compact(&mut texels.normals));
        texels.normals = Vec::new();
        texels.positions = Vec::new();
        texels.triangle = Vec::new();
        Receivers {
            origins,
            normals,
            horizons,
            streams: Some(streams),
            strata: Some(strata),
        }
    }

    pub fn len(&self) -> usize {
        self.normals.len()
    }

    pub fn is_empty(&self) -> bool {
        self.normals.is_empty()
    }
}

/// Where a bounce hit reads the previous bounce's transfer: the *slots* that hold values,
/// and each hit's weights over them (see the module doc).
#[derive(Clone, Debug)]
pub enum BounceTargets<'a> {
    /// Slots are the scene's vertices, which are also the receivers; a hit reads its
    /// triangle's corners with its barycentric weights.
    Vertices,
    /// Slots are the W×H texels of a lightmap; the receivers are its valid texels.
    Texels(TexelTargets<'a>),
}

/// The texel lookup of a texel bake's bounces.
#[derive(Clone, Debug)]
pub struct TexelTargets<'a> {
    texels: &'a Texels,
    /// Per triangle, its corners in texel units (uv · (W, H)).
    corners: Vec<[Vec2; 3]>,
    /// Texels that hold a value: baked (valid) or dilated from baked ones.
    filled: Vec<bool>,
}

impl<'a> BounceTargets<'a> {
    /// The lookup of a texel bake over `atlas`, whose valid texels are `texels`.
    pub fn texels(atlas: &Atlas, texels: &'a Texels) -> BounceTargets<'a> {
        // Which texels dilation fills depends on the valid ones only: dilate no values.
        let dilated = dilation::dilate_values(texels, 0, &mut []);
        let filled = texels
            .valid
            .iter()
            .zip(&dilated)
            .map(|(v, d)| *v || *d)
            .collect();
        BounceTargets::Texels(TexelTargets {
            texels,
            corners: atlas.texel_corners().collect(),
            filled,
        })
    }

    /// The slots a hit on `triangle` at `barycentric` reads, with their weights (summing to
    /// 1, or to less where barycentrics are negative by rounding), into `out`; returns how
    /// many. None where the hit's triangle lies outside the atlas or no texel around its
    /// lightmap UV holds a value: that light is lost.
    pub fn lookup(
        &self,
        scene: &Scene,
        triangle: u32,
        barycentric: [f32; 3],
        out: &mut [(u32, f32); 4],
    ) -> usize {
        match self {
            BounceTargets::Vertices => {
                let tri = scene.triangles[triangle as usize];
                for (slot, (&vertex, &b)) in out.iter_mut().zip(tri.iter().zip(&barycentric)) {
                    *slot = (vertex, b.max(0.0));
                }
                3
            }
            BounceTargets::Texels(t) => t.bilinear(triangle, barycentric, out),
        }
    }

    /// The previous bounce's values at every slot, from its values at the receivers
    /// (`width` floats each): the same array for vertices; for texels, the valid texels'
    /// values put in place in the W×H lightmap and dilated, as the final lightmap is.
    pub fn slot_values<'v>(&self, values: &'v [f32], width: usize) -> Cow<'v, [f32]> {
        match self {
            BounceTargets::Vertices => Cow::Borrowed(values),
            BounceTargets::Texels(t) => Cow::Owned(t.lightmap(values, width)),
        }
    }

    /// [`BounceTargets::slot_values`] made in place: `values`' own allocation grown into the
    /// lightmap (a texel bake), so that the receivers' array and the lightmap are never held
    /// together. The valid texels' values are those of `values`, bit for bit.
    pub fn into_slot_values(&self, values: Vec<f32>, width: usize) -> Vec<f32> {
        match self {
            BounceTargets::Vertices => values,
            BounceTargets::Texels(t) => t.lightmap_in_place(values, width),
        }
    }

    /// The receivers' values back from [`BounceTargets::into_slot_values`]'s slots, in place:
    /// dilation writes only the texels that are not valid, so these are the values given.
    pub fn from_slot_values(&self, slots: Vec<f32>, width: usize) -> Vec<f32> {
        match self {
            BounceTargets::Vertices => slots,
            BounceTargets::Texels(t) => {
                let mut values = slots;
                let valid = t.texels.valid.iter().enumerate().filter(|(_, v)| **v);
                let mut count = 0;
                // Texel i of the k-th valid one is at or past k: each value moves down onto
                // a place already read.
                for (k, (i, _)) in valid.enumerate() {
                    if i != k {
                        values.copy_within(i * width..(i + 1) * width, k * width);
                    }
                    count = k + 1;
                }
                values.truncate(count * width);
                values.shrink_to_fit();
                values
            }
        }
    }
}

impl TexelTargets<'_> {
    /// [`TexelTargets::lightmap`] in `values`' own allocation: the valid texels' values moved
    /// up to their places, last first (the k-th valid texel's place is at or past k, so no
    /// value is written over before it has moved), the others zeroed, then dilated.
    fn lightmap_in_place(&self, mut values: Vec<f32>, width: usize) -> Vec<f32> {
        let count = values.len() / width.max(1);
        values.resize(self.filled.len() * width, 0.0);
        let mut k = count;
        let valid = self.texels.valid.iter().enumerate().rev();
        for (i, _) in valid.filter(|(_, v)| **v) {
            k -= 1;
            if i != k {
                values.copy_within(k * width..(k + 1) * width, i * width);
            }
        }
        debug_assert_eq!(k, 0, "one value per valid texel");
        for (i, _) in self.texels.valid.iter().enumerate().filter(|(_, v)| !**v) {
            values[i * width..(i + 1) * width].fill(0.0);
        }
        dilation::dilate_values(self.texels, width, &mut values);
        values
    }

    /// Bilinear weights over the 4 texels around the hit's lightmap point uv·(W, H) − ½, as
    /// a GPU samples a lightmap; texels outside the lightmap or holding no value are left
    /// out and the others' weights renormalised.
    fn bilinear(&self, triangle: u32, barycentric: [f32; 3], out: &mut [(u32, f32); 4]) -> usize {
        let c = self.corners[triangle as usize];
        let p = c[0] * barycentric[0] + c[1] * barycentric[1] + c[2] * barycentric[2];
        bilinear_taps(p, self.texels.width, self.texels.height, &self.filled, out)
    }

    /// The valid texels' values (`width` floats each, in row-major order of the valid
    /// texels) in a W×H lightmap, dilated.
    fn lightmap(&self, values: &[f32], width: usize) -> Vec<f32> {
        let mut map = vec![0.0f32; self.filled.len() * width];
        let valid = self.texels.valid.iter().enumerate().filter(|(_, v)| **v);
        for ((i, _), value) in valid.zip(values.chunks_exact(width)) {
            map[i * width..(i + 1) * width].copy_from_slice(value);
        }
        dilation::dilate_values(self.texels, width, &mut map);
        map
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The slots made in place are, bit for bit, the slots made in a new array, and give the
    /// receivers' values back, on an atlas whose valid texels are scattered (so values move).
    #[test]
    fn slots_made_in_place_match_the_copied_ones_and_give_the_values_back() {
        let (_, atlas, texels) = crate::bake::lightmap::texels::cornell_lightmap(64);
        let targets = BounceTargets::texels(&atlas, &texels);
        let width = 9;
        let count = texels.valid_indices().count();
        assert!(count < texels.valid.len(), "some texels are empty");
        let values: Vec<f32> = (0..count * width).map(|i| (i as f32).sin() + 1.5).collect();
        let bits = |v: &[f32]| -> Vec<u32> { v.iter().map(|x| x.to_bits()).collect() };
        let copied = targets.slot_values(&values, width);
        let in_place = targets.into_slot_values(values.clone(), width);
        assert!(bits(&in_place) == bits(&copied), "the slots differ");
        let back = targets.from_slot_values(in_place, width);
        assert!(bits(&back) == bits(&values), "the values differ");
        let vertices = BounceTargets::Vertices;
        let same =
            vertices.from_slot_values(vertices.into_slot_values(values.clone(), width), width);
        assert!(bits(&same) == bits(&values));
    }

    /// Taking the points gives the receivers that copying them gives, on an atlas whose valid
    /// texels are scattered (so the compaction moves them), and leaves the size and mask.
    #[test]
    fn taken_texel_points_make_the_receivers_copied_ones_make() {
        let (_, _, texels) = crate::bake::lightmap::texels::cornell_lightmap(64);
        assert!(texels.valid.iter().any(|v| !v), "some texels are empty");
        let copied = Receivers::texels(&texels);
        let mut taken_from = texels.clone();
        let taken = Receivers::take_texels(&mut taken_from);
        assert_eq!(taken.origins, copied.origins);
        assert_eq!(taken.normals, copied.normals);
        assert_eq!(taken.horizons, copied.horizons);
        assert_eq!(taken.streams, copied.streams);
        assert_eq!(taken_from.valid, texels.valid);
        assert_eq!(
            (taken_from.width, taken_from.height),
            (texels.width, texels.height)
        );
        assert!(taken_from.origins.is_empty() && taken_from.positions.is_empty());
    }
}
