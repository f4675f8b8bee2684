//! The denoiser's guides ([`super::Guides`]) for the two kinds of receivers: a scene's
//! vertices, and a lightmap's baked texels.

use std::collections::BTreeMap;

use glam::Vec3;

use crate::bake::lightmap::atlas::Atlas;
use crate::bake::lightmap::texels::Texels;
use crate::scene::Scene;

/// What the weights are guided by, per receiver (vertices, or a lightmap's baked texels in
/// row-major order).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Guides {
    /// Points on the surface.
    pub points: Vec<Vec3>,
    /// Unit shading normals (normal-mapped where the material has a normal map).
    pub normals: Vec<Vec3>,
    /// Unit surface normals: the plane a neighbour must lie in.
    pub surfaces: Vec<Vec3>,
    /// Object and material: receivers of different groups never mix.
    pub groups: Vec<u32>,
    /// World distance between neighbouring receivers: a texel's side, a vertex's spacing.
    pub spacing: Vec<f32>,
    /// Per receiver, the variance of one coefficient, estimated on bands 0 and 1
    /// ([`crate::bake::noise`]) and taken for every band the range term compares; empty,
    /// or all zero: estimated from the transfer.
    pub noise: Vec<f32>,
}

impl Guides {
    /// The guides of receivers `range` (a part's).
    pub fn range(&self, range: std::ops::Range<usize>) -> Guides {
        Guides {
            points: self.points[range.clone()].to_vec(),
            normals: self.normals[range.clone()].to_vec(),
            surfaces: self.surfaces[range.clone()].to_vec(),
            groups: self.groups[range.clone()].to_vec(),
            spacing: self.spacing[range.clone()].to_vec(),
            noise: self.noise.get(range).map_or(Vec::new(), <[f32]>::to_vec),
        }
    }

    /// Appends `more`'s receivers after these (parts joined in order).
    pub fn append(&mut self, more: Guides) {
        self.points.extend(more.points);
        self.normals.extend(more.normals);
        self.surfaces.extend(more.surfaces);
        self.groups.extend(more.groups);
        self.spacing.extend(more.spacing);
        self.noise.extend(more.noise);
    }
}

/// Dense ids of (object, material) pairs, in the order first met.
struct Groups(BTreeMap<(u32, u32), u32>);

impl Groups {
    fn id(&mut self, object: u32, material: u32) -> u32 {
        let next = self.0.len() as u32;
        *self.0.entry((object, material)).or_insert(next)
    }
}

/// Per triangle, the index of the scene object holding it.
fn triangle_objects(scene: &Scene) -> Vec<u32> {
    let mut objects = vec![0u32; scene.triangles.len()];
    for (k, object) in scene.objects.iter().enumerate() {
        for t in object.triangles.clone() {
            objects[t as usize] = k as u32;
        }
    }
    objects
}

fn triangle_area(scene: &Scene, t: usize) -> f32 {
    let [a, b, c] = scene.triangles[t].map(|v| scene.positions[v as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// The guides of every vertex of `scene`, with `noise` per vertex (or empty).
pub fn vertex_guides(scene: &Scene, noise: Vec<f32>) -> Guides {
    let count = scene.vertex_count();
    let objects = triangle_objects(scene);
    let mut vertex_object = vec![u32::MAX; count];
    // A vertex's share of its triangles' area: its spacing is about √area for a regular mesh.
    let mut area = vec![0.0f32; count];
    for (t, tri) in scene.triangles.iter().enumerate() {
        let third = triangle_area(scene, t) / 3.0;
        for &v in tri {
            area[v as usize] += third;
            vertex_object[v as usize] = vertex_object[v as usize].min(objects[t]);
        }
    }
    let mut groups = Groups(BTreeMap::new());
    let groups: Vec<u32> = (0..count)
        .map(|v| groups.id(vertex_object[v], scene.vertex_material[v]))
        .collect();
    let mut spacing: Vec<f32> = area.iter().map(|a| 1.07 * a.sqrt()).collect();
    fill_missing(&mut spacing);
    Guides {
        points: scene.positions.clone(),
        normals: scene.normals.clone(),
        surfaces: scene.normals.clone(),
        groups,
        spacing,
        noise,
    }
}

/// The guides of `texels`' valid texels, in row-major order, with `noise` per valid texel
/// (or empty). Each texel's spacing is its triangle's world size of a texel.
pub fn texel_guides(scene: &Scene, atlas: &Atlas, texels: &Texels, noise: Vec<f32>) -> Guides {
    let all = 0..texels.valid_count();
    Guides {
        noise,
        ..texel_guides_of(scene, atlas, texels, all)
    }
}

/// [`texel_guides`] of the valid texels `range` (counted in row-major order) alone, without
/// noise: the same guides those texels have among all (group ids and the spacing given to
/// texels of no UV area are the whole lightmap's), for a shard that bakes only them.
pub fn texel_guides_of(
    scene: &Scene,
    atlas: &Atlas,
    texels: &Texels,
    range: std::ops::Range<usize>,
) -> Guides {
    let objects = triangle_objects(scene);
    let texel_area = (atlas.width as f32) * (atlas.height as f32);
    let triangle_spacing: Vec<f32> = (0..scene.triangles.len())
        .map(|t| {
            let [a, b, c] = atlas.uv1[t];
            let uv_area = 0.5 * (b - a).perp_dot(c - a).abs() * texel_area;
            match uv_area > 0.0 {
                true => (triangle_area(scene, t) / uv_area).sqrt(),
                false => 0.0,
            }
        })
        .collect();
    let mut groups = Groups(BTreeMap::new());
    let count = range.len();
    let mut guides = Guides {
        points: Vec::with_capacity(count),
        normals: Vec::with_capacity(count),
        surfaces: Vec::with_capacity(count),
        groups: Vec::with_capacity(count),
        spacing: Vec::with_capacity(count),
        noise: Vec::new(),
    };
    // Group ids are numbered in the order first met, so the texels before `range` are
    // walked too (their group only, and the map consulted only when it changes).
    let mut last = None;
    for (k, i) in texels.valid_indices().enumerate().take(range.end) {
        let t = texels.triangle[i] as usize;
        let key = (
            objects[t],
            scene.vertex_material[scene.triangles[t][0] as usize],
        );
        let group = match last {
            Some((previous, id)) if previous == key => id,
            _ => groups.id(key.0, key.1),
        };
        last = Some((key, group));
        if k < range.start {
            continue;
        }
        guides.points.push(texels.positions[i]);
        guides.normals.push(texels.mapped[i]);
        guides.surfaces.push(texels.normals[i]);
        guides.groups.push(group);
        guides.spacing.push(triangle_spacing[t]);
    }
    if guides.spacing.iter().any(|s| missing(*s)) {
        let all: Vec<f32> = texels
            .valid_indices()
            .map(|i| triangle_spacing[texels.triangle[i] as usize])
            .collect();
        fill_with(&mut guides.spacing, known_median(&all));
    }
    guides
}

/// A spacing the receiver has not got (an isolated vertex, a triangle of no UV area).
fn missing(s: f32) -> bool {
    s.is_nan() || s <= 0.0
}

/// The median of the spacings that are known (positive), 1 if none is.
fn known_median(spacing: &[f32]) -> f32 {
    let mut known: Vec<f32> = spacing.iter().copied().filter(|s| *s > 0.0).collect();
    known.sort_unstable_by(f32::total_cmp);
    known.get(known.len() / 2).copied().unwrap_or(1.0)
}

fn fill_with(spacing: &mut [f32], median: f32) {
    for s in spacing.iter_mut().filter(|s| missing(**s)) {
        *s = median;
    }
}

/// Spacings of 0 (an isolated vertex, a triangle of no UV area) become the median.
fn fill_missing(spacing: &mut [f32]) {
    if spacing.iter().any(|s| missing(*s)) {
        let median = known_median(spacing);
        fill_with(spacing, median);
    }
}
