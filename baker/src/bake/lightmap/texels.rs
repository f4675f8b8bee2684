//! Texel sample points: which texels a triangle covers, and the world point and normal each
//! covered texel is baked at.
//!
//! Rasterisation is conservative: a texel is covered by a triangle when the triangle
//! overlaps the texel's square footprint with positive area (computed exactly, by clipping
//! the triangle to the square). Where several triangles cover a texel, the one with the
//! largest overlap wins (the first in scene order on a tie, so the result is deterministic).
//! The texel's point is its centre when the centre lies in the winning triangle; otherwise
//! (edge texels) the centroid of the overlap, which lies both in the triangle and in the
//! texel: the centre "clipped into the triangle" without leaving the texel.

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::atlas::Atlas;
use super::footprint::{
    Cover, Edges, clip_to_square, cross, polygon_area, polygon_centroid, texel_bounds,
};
use crate::scene::{NormalMap, Scene};
use crate::support::error::Result;
use crate::trace::{Tracer, offset_distance};

/// Texel sample points of an atlas; every array is row-major, index `y · width + x`.
#[derive(Clone, Debug, PartialEq)]
pub struct Texels {
    pub width: u32,
    pub height: u32,
    /// Whether a triangle covers the texel (a bake clears it again for leaking texels).
    pub valid: Vec<bool>,
    /// The texel's point on the surface (zero where no triangle covers it).
    pub positions: Vec<Vec3>,
    /// The interpolated unit shading normal (zero where no triangle covers it): the surface
    /// whose hemisphere bounds the rays that can leave.
    pub normals: Vec<Vec3>,
    /// The normal the texel's lobe is about: `normals` turned by the material's normal map
    /// ([`crate::scene::NormalMap`]), or equal to it where there is none.
    pub mapped: Vec<Vec3>,
    /// Where its rays start: the point moved off its triangle along the face normal by
    /// [`offset_distance`] δ, as vertices are, and by up to δ towards the triangle's centroid
    /// (δ·|c − p|/e), so a point on the triangle's edge, where it may meet another surface
    /// (a wall's foot on the floor), does not start its rays on that surface, where a
    /// watertight test sees it from behind at t = 0 (zero where no triangle covers it).
    pub origins: Vec<Vec3>,
    /// The winning triangle (`u32::MAX` where none covers it).
    pub triangle: Vec<u32>,
}

impl Texels {
    /// Rasterises every triangle of `scene` into `atlas`. Bands of [`BAND_ROWS`] texel rows
    /// are rasterised in parallel, each from the triangles that reach it in scene order, so
    /// every texel sees its triangles in the same order as one pass over the scene would: the
    /// result does not depend on the thread count.
    pub fn rasterise(scene: &Scene, atlas: &Atlas) -> Texels {
        let (w, h) = (atlas.width as usize, atlas.height as usize);
        let corners: Vec<[Vec2; 3]> = atlas.texel_corners().collect();
        // Each band's triangles, in scene order.
        let bands = h.div_ceil(BAND_ROWS);
        let mut in_band: Vec<Vec<u32>> = vec![Vec::new(); bands];
        for (t, uv) in corners.iter().enumerate() {
            if let Some((_, _, y0, y1)) = texel_bounds(*uv, w, h) {
                for band in in_band
                    .iter_mut()
                    .take(y1.div_ceil(BAND_ROWS))
                    .skip(y0 / BAND_ROWS)
                {
                    band.push(t as u32);
                }
            }
        }
        // Every array in place, each band writing its own rows (no per-band copies to join).
        // The zero ones are allocated zeroed: the system maps their pages as they are first
        // touched, so the pages of texels no triangle covers (most, in a sparse atlas) never
        // are, where writing zeros touched all 200 MB of a 2048² lightmap.
        let n = w * h;
        let mut texels = Texels {
            width: atlas.width,
            height: atlas.height,
            valid: vec![false; n],
            positions: bytemuck::zeroed_vec(n),
            normals: bytemuck::zeroed_vec(n),
            mapped: bytemuck::zeroed_vec(n),
            origins: bytemuck::zeroed_vec(n),
            triangle: filled(n, u32::MAX),
        };
        let chunk = BAND_ROWS * w;
        texels
            .valid
            .par_chunks_mut(chunk)
            .zip(texels.positions.par_chunks_mut(chunk))
            .zip(texels.normals.par_chunks_mut(chunk))
            .zip(texels.mapped.par_chunks_mut(chunk))
            .zip(texels.origins.par_chunks_mut(chunk))
            .zip(texels.triangle.par_chunks_mut(chunk))
            .zip(in_band.par_iter())
            .enumerate()
            .for_each(|(band, (rows, triangles))| {
                let (((((valid, positions), normals), mapped), origins), triangle) = rows;
                let out = Rows {
                    valid,
                    positions,
                    normals,
                    mapped,
                    origins,
                    triangle,
                };
                let rows = band * BAND_ROWS..((band + 1) * BAND_ROWS).min(h);
                rasterise_rows(scene, &corners, triangles, w, rows, out);
            });
        texels
    }

    /// Texels known only by which are baked (no points): what the merge of a texel bake's
    /// shard parts needs to place, dilate and look up values, which depend on nothing else.
    pub fn mask(width: u32, height: u32, valid: Vec<bool>) -> Texels {
        debug_assert_eq!(valid.len(), width as usize * height as usize);
        Texels {
            width,
            height,
            valid,
            positions: Vec::new(),
            normals: Vec::new(),
            mapped: Vec::new(),
            origins: Vec::new(),
            triangle: Vec::new(),
        }
    }

    /// A 64-bit fingerprint (xxh3) of everything a texel bake's receivers are: the size,
    /// which texels are baked, and each baked texel's point, normal, ray origin and triangle
    /// (after leaking texels were moved out), its mapped normal where a normal map turned it.
    /// Two shards of one bake must agree on it.
    pub fn fingerprint(&self) -> u64 {
        let mut digest = crate::support::digest::Digest::default();
        digest.bytes(&self.width.to_le_bytes());
        digest.bytes(&self.height.to_le_bytes());
        for mask in self.valid.chunks(4096) {
            let bytes: Vec<u8> = mask.iter().map(|&v| u8::from(v)).collect();
            digest.bytes(&bytes);
        }
        for i in self.valid_indices() {
            for v in [self.positions[i], self.normals[i], self.origins[i]] {
                digest.floats(&v.to_array());
            }
            digest.bytes(&self.triangle[i].to_le_bytes());
            if self.mapped[i] != self.normals[i] {
                digest.floats(&self.mapped[i].to_array());
            }
        }
        digest.finish()
    }

    /// The valid texels' indices, in order (reading only their entries of the other arrays
    /// leaves the pages of empty texels untouched).
    pub fn valid_indices(&self) -> impl Iterator<Item = usize> + '_ {
        self.valid
            .iter()
            .enumerate()
            .filter(|(_, v)| **v)
            .map(|(i, _)| i)
    }

    pub fn valid_count(&self) -> usize {
        self.valid.iter().filter(|&&v| v).count()
    }

    /// A tracer that is watertight for the valid texels' ray origins (Embree's default mode
    /// picks robust mode per origin, [`crate::trace::seams`]), or `None` where `tracer`
    /// already is for any origin. The tracer forgets its seam index after
    /// ([`Tracer::release_points`]).
    pub fn watertight<'t>(
        &self,
        scene: &Scene,
        tracer: &'t dyn Tracer,
    ) -> Result<Option<Box<dyn Tracer + 't>>> {
        let watertight = self.watertight_keeping(scene, tracer);
        tracer.release_points();
        Ok(watertight?.0)
    }

    /// [`Texels::watertight`], the tracer keeping its seam index for more points (the leak
    /// test's moved texels); and which valid texels are seam points (in [`Texels::valid_indices`]
    /// order; `None` for a tracer that does not route by origin), for [`Texels::watertight_known`].
    pub fn watertight_keeping<'t>(
        &self,
        scene: &Scene,
        tracer: &'t dyn Tracer,
    ) -> Result<Watertight<'t>> {
        let (origins, own): (Vec<Vec3>, Vec<u32>) = self
            .valid_indices()
            .map(|i| (self.origins[i], self.triangle[i]))
            .unzip();
        let Some(seam) = tracer.seam_points(scene, &origins, &own) else {
            return Ok((None, None));
        };
        Ok((tracer.for_seam_points(scene, &origins, &seam)?, Some(seam)))
    }

    /// [`Texels::watertight`] with the seam points known (`seam`, as
    /// [`Texels::watertight_keeping`] found them for these texels): what a texel bake's shard
    /// reads from the prepared lightmap instead of building the seam index again.
    pub fn watertight_known<'t>(
        &self,
        scene: &Scene,
        tracer: &'t dyn Tracer,
        seam: Option<&[bool]>,
    ) -> Result<Option<Box<dyn Tracer + 't>>> {
        let Some(seam) = seam else {
            return self.watertight(scene, tracer);
        };
        let origins: Vec<Vec3> = self.valid_indices().map(|i| self.origins[i]).collect();
        if seam.len() != origins.len() {
            return Err(crate::Error::Shards(format!(
                "a prepared lightmap of {} seam flags for {} baked texels",
                seam.len(),
                origins.len()
            )));
        }
        tracer.for_seam_points(scene, &origins, seam)
    }
}

/// A tracer watertight for a texel bake's ray origins (`None` where the tracer it came from
/// already is), and which of them are seam points ([`Texels::watertight_keeping`]).
pub type Watertight<'t> = (Option<Box<dyn Tracer + 't>>, Option<Vec<bool>>);

/// Texel rows per band of the parallel rasterisation.
const BAND_ROWS: usize = 16;

/// `n` copies of `value`, written in parallel (a lightmap's arrays are hundreds of MB).
fn filled<T: Copy + Send + Sync>(n: usize, value: T) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    v.par_extend(rayon::iter::repeat_n(value, n));
    v
}

/// Texel rows of the [`Texels`] arrays, for one band to write.
struct Rows<'a> {
    valid: &'a mut [bool],
    positions: &'a mut [Vec3],
    normals: &'a mut [Vec3],
    mapped: &'a mut [Vec3],
    origins: &'a mut [Vec3],
    triangle: &'a mut [u32],
}

/// Rasterises `triangles` (in order) into texel rows `rows` of a `w`-wide lightmap, `texels`
/// (cleared): the largest overlap wins, the first triangle on a tie.
fn rasterise_rows(
    scene: &Scene,
    corners: &[[Vec2; 3]],
    triangles: &[u32],
    w: usize,
    rows: std::ops::Range<usize>,
    texels: Rows<'_>,
) {
    let n = w * rows.len();
    let mut coverage = vec![0.0f32; n];
    for &t in triangles {
        let (tri, uv) = (scene.triangles[t as usize], corners[t as usize]);
        let Some((x0, x1, y0, y1)) = texel_bounds(uv, w, usize::MAX) else {
            continue;
        };
        let p = tri.map(|v| scene.positions[v as usize]);
        let n = tri.map(|v| scene.normals[v as usize]);
        let mapping = normal_mapping(scene, tri);
        let face = (p[1] - p[0]).cross(p[2] - p[0]);
        let Some(face_normal) = face.try_normalize() else {
            continue; // zero area in space
        };
        let longest = p[0]
            .distance(p[1])
            .max(p[1].distance(p[2]))
            .max(p[2].distance(p[0]));
        let centroid = (p[0] + p[1] + p[2]) / 3.0;
        let edges = Edges::new(uv);
        for y in y0.max(rows.start)..y1.min(rows.end) {
            for x in x0..x1 {
                let square = Vec2::new(x as f32, y as f32);
                let area = match edges.cover(x, y) {
                    Cover::Outside => continue,
                    Cover::Inside => 1.0,
                    Cover::Straddles => polygon_area(&clip_to_square(uv, square)),
                };
                let i = (y - rows.start) * w + x;
                if area <= coverage[i] || area <= 0.0 {
                    continue;
                }
                let centre = square + Vec2::splat(0.5);
                let b = match barycentric(uv, centre) {
                    Some(b) => b,
                    None => barycentric_clamped(uv, polygon_centroid(&clip_to_square(uv, square))),
                };
                let position = p[0] * b[0] + p[1] * b[1] + p[2] * b[2];
                let normal = (n[0] * b[0] + n[1] * b[1] + n[2] * b[2])
                    .try_normalize()
                    .unwrap_or(face_normal);
                coverage[i] = area;
                texels.valid[i] = true;
                texels.positions[i] = position;
                texels.normals[i] = normal;
                texels.mapped[i] = mapping.as_ref().map_or(normal, |m| m.at(b, normal));
                let delta = offset_distance(position, longest);
                texels.origins[i] =
                    position + face_normal * delta + (centroid - position) * (delta / longest);
                texels.triangle[i] = t;
            }
        }
    }
}

/// What turns a triangle's texels' normals: its material's normal map, its corners' uvs and
/// tangents; `None` where the material has no map.
struct Mapping<'a> {
    map: &'a NormalMap,
    textures: &'a [crate::scene::Texture],
    uv: [Vec2; 3],
    tangent: [Vec4; 3],
}

fn normal_mapping(scene: &Scene, tri: [u32; 3]) -> Option<Mapping<'_>> {
    let material = scene.vertex_material[tri[0] as usize] as usize;
    let map = scene.materials[material].normal_map.as_ref()?;
    let tangents = scene.tangents.as_ref()?;
    Some(Mapping {
        map,
        textures: &scene.textures,
        uv: tri.map(|v| scene.uvs[v as usize]),
        tangent: tri.map(|v| tangents[v as usize]),
    })
}

impl Mapping<'_> {
    /// The mapped normal at barycentrics `b` of a point whose surface normal is `normal`.
    fn at(&self, b: [f32; 3], normal: Vec3) -> Vec3 {
        let uv = self.uv[0] * b[0] + self.uv[1] * b[1] + self.uv[2] * b[2];
        let t = self.tangent[0] * b[0] + self.tangent[1] * b[1] + self.tangent[2] * b[2];
        // The sign is a corner's, not interpolated (a mesh's corners agree on it).
        let tangent = t.truncate().extend(self.tangent[0].w);
        self.map.perturb(self.textures, uv, normal, tangent)
    }
}

/// The barycentric coordinates of `q` if it lies in the triangle (edges included).
fn barycentric(uv: [Vec2; 3], q: Vec2) -> Option<[f32; 3]> {
    let b = barycentric_unclipped(uv, q);
    b.iter().all(|&x| x >= 0.0).then_some(b)
}

fn barycentric_unclipped(uv: [Vec2; 3], q: Vec2) -> [f32; 3] {
    let area = cross(uv[1] - uv[0], uv[2] - uv[0]);
    let b1 = cross(q - uv[0], uv[2] - uv[0]) / area;
    let b2 = cross(uv[1] - uv[0], q - uv[0]) / area;
    [1.0 - b1 - b2, b1, b2]
}

/// Barycentric coordinates of a point that lies in the triangle up to rounding, clamped
/// into it.
fn barycentric_clamped(uv: [Vec2; 3], q: Vec2) -> [f32; 3] {
    let b = barycentric_unclipped(uv, q).map(|x| x.max(0.0));
    let sum = b[0] + b[1] + b[2];
    b.map(|x| x / sum)
}

/// Bilinear taps at texel-space point `p` (texel centres at half-integers, as a GPU samples a
/// lightmap) over the `filled` texels of a `width`×`height` lightmap: texels outside it or
/// not filled are left out and the others' weights renormalised. Writes (texel, weight) to
/// `out` and returns how many; 0 where `p` is not finite or no tap is filled. The bounce
/// gather and the seam stitching read a lightmap with it, so both read what a GPU shows.
pub(crate) fn bilinear_taps(
    p: Vec2,
    width: u32,
    height: u32,
    filled: &[bool],
    out: &mut [(u32, f32); 4],
) -> usize {
    let p = p - Vec2::splat(0.5);
    let (x0, y0) = (p.x.floor(), p.y.floor());
    let (fx, fy) = (p.x - x0, p.y - y0);
    if !(x0.is_finite() && y0.is_finite()) {
        return 0;
    }
    let (w, h) = (i64::from(width), i64::from(height));
    let (x0, y0) = (x0 as i64, y0 as i64);
    let taps = [
        (x0, y0, (1.0 - fx) * (1.0 - fy)),
        (x0 + 1, y0, fx * (1.0 - fy)),
        (x0, y0 + 1, (1.0 - fx) * fy),
        (x0 + 1, y0 + 1, fx * fy),
    ];
    let (mut count, mut sum) = (0, 0.0);
    for (x, y, weight) in taps {
        if x < 0 || y < 0 || x >= w || y >= h || weight <= 0.0 {
            continue;
        }
        let i = (y * w + x) as usize;
        if filled[i] {
            out[count] = (i as u32, weight);
            sum += weight;
            count += 1;
        }
    }
    for slot in &mut out[..count] {
        slot.1 /= sum;
    }
    count
}

/// The Cornell room's scene, generated atlas at `resolution`² and rasterised texels: the
/// lightmap the receivers' and hit cache's unit tests share (its valid texels are scattered).
#[cfg(test)]
pub(crate) fn cornell_lightmap(resolution: u32) -> (Scene, Atlas, Texels) {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell/cornell.scene");
    let scene = Scene::load(&path).unwrap();
    let atlas = Atlas::generate(&scene, resolution, None).unwrap();
    let texels = Texels::rasterise(&scene, &atlas);
    (scene, atlas, texels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_centroid_of_an_overlap_lies_in_the_triangle() {
        let uv = [
            Vec2::new(0.2, 0.1),
            Vec2::new(3.7, 0.4),
            Vec2::new(0.6, 2.9),
        ];
        for y in 0..3 {
            for x in 0..4 {
                let overlap = clip_to_square(uv, Vec2::new(x as f32, y as f32));
                if polygon_area(&overlap) > 0.0 {
                    let b = barycentric_clamped(uv, polygon_centroid(&overlap));
                    let raw = barycentric_unclipped(uv, polygon_centroid(&overlap));
                    for k in 0..3 {
                        assert!(raw[k] > -1e-5, "texel ({x},{y}): {raw:?}");
                        assert!(b[k] >= 0.0);
                    }
                }
            }
        }
    }

    #[test]
    fn banded_rasterisation_equals_one_pass_over_the_scene() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../scenes/cornell/cornell.scene");
        let scene = Scene::load(&path).unwrap();
        let atlas = Atlas::generate(&scene, 200, None).unwrap();
        let corners: Vec<[Vec2; 3]> = atlas.texel_corners().collect();
        let all: Vec<u32> = (0..scene.triangles.len() as u32).collect();
        let mut one_pass = Texels::mask(200, 200, vec![false; 200 * 200]);
        one_pass.positions = vec![Vec3::ZERO; 200 * 200];
        one_pass.normals = one_pass.positions.clone();
        one_pass.mapped = one_pass.positions.clone();
        one_pass.origins = one_pass.positions.clone();
        one_pass.triangle = vec![u32::MAX; 200 * 200];
        let rows = Rows {
            valid: &mut one_pass.valid,
            positions: &mut one_pass.positions,
            normals: &mut one_pass.normals,
            mapped: &mut one_pass.mapped,
            origins: &mut one_pass.origins,
            triangle: &mut one_pass.triangle,
        };
        rasterise_rows(&scene, &corners, &all, 200, 0..200, rows);
        let banded = Texels::rasterise(&scene, &atlas);
        assert!(
            banded.valid_count() > 20_000,
            "{} texels",
            banded.valid_count()
        );
        assert_eq!(banded.valid, one_pass.valid);
        assert_eq!(banded.triangle, one_pass.triangle);
        assert_eq!(banded.positions, one_pass.positions);
        assert_eq!(banded.normals, one_pass.normals);
        assert_eq!(banded.mapped, one_pass.normals, "no normal maps");
        assert_eq!(banded.origins, one_pass.origins);
    }
}
