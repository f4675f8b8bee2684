//! Scene lightmap UVs laid out per object, as Blender's Smart UV Project and Unity lay them
//! out: every object has its own UVs in [0, 1]. Used as one atlas, such objects share texels
//! (the last one rasterised wins each texel, and the others read its transfer). So before a
//! scene's TEXCOORD_1 becomes the atlas, [`check`] rasterises it at the bake's resolution
//! and counts the texels claimed by two objects, and per object the texels claimed twice
//! by its own triangles. Where objects overlap each other (or one overlaps itself, or has
//! no lightmap UVs), [`pack`] puts each object's own UVs into the atlas with a scale and an
//! offset of its own (Unity's `lightmapScaleOffset`), in rectangles proportional to the
//! object's surface (the same texel density everywhere) with [`PADDING`] texels between
//! them; an object whose own UVs overlap themselves, or that has none, gets a chart set
//! unwrapped for it alone ([`generate`]) instead. docs/guides/lightmaps.md, "Per-object
//! lightmap UVs".

use glam::Vec2;

use super::atlas::{
    Atlas, AtlasMethod, AtlasSource, MIN_RESOLUTION, ObjectPlacement, ObjectUvs, PADDING, generate,
};
use crate::scene::{Object, Scene};
use crate::support::error::{Error, Result};

/// How far inside a triangle (in texels) a texel centre must lie to count as claimed by it
/// in [`check`]: the tolerance that keeps triangles sharing an edge, and charts of two
/// objects that merely touch, from counting as overlapping.
pub const EDGE_TOLERANCE: f32 = 0.01;

/// The fraction of an object's texels that its own triangles may claim twice before its
/// UVs count as overlapping themselves (rounding along folded slivers; real overlaps, such
/// as mirrored halves sharing UVs, claim far more).
pub const SELF_OVERLAP_TOLERANCE: f64 = 0.001;

/// What [`check`] found in a scene's lightmap UVs at one resolution.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UvCheck {
    /// Texels whose centre lies inside triangles of two or more objects.
    pub shared_texels: usize,
    /// Per object, in scene order.
    pub objects: Vec<ObjectCheck>,
}

/// One object's UVs in [`UvCheck`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectCheck {
    /// Texels whose centre lies inside one of its triangles.
    pub texels: usize,
    /// Of those, texels whose centre lies inside two or more of its triangles.
    pub self_overlapped: usize,
    /// Whether its UV triangles have any area (no TEXCOORD_1 reads as all zeros).
    pub has_uvs: bool,
}

impl ObjectCheck {
    /// The fraction of its texels claimed twice by its own triangles.
    pub fn overlap_fraction(&self) -> f64 {
        self.self_overlapped as f64 / self.texels.max(1) as f64
    }

    /// Whether its own UVs overlap beyond [`SELF_OVERLAP_TOLERANCE`].
    pub fn overlaps_itself(&self) -> bool {
        self.overlap_fraction() > SELF_OVERLAP_TOLERANCE
    }
}

impl UvCheck {
    /// Whether the UVs can be the atlas as they are: no texel shared between objects, no
    /// object overlapping itself, every object with UVs.
    pub fn is_clean(&self) -> bool {
        self.shared_texels == 0
            && self
                .objects
                .iter()
                .all(|o| o.has_uvs && !o.overlaps_itself())
    }
}

/// Rasterises `uv1` (per triangle corner, [0, 1]) at `width`×`height` by texel centres
/// (inside by [`EDGE_TOLERANCE`]) and counts the texels claimed by two objects and, per
/// object, by two of its own triangles.
pub fn check(scene: &Scene, uv1: &[[Vec2; 3]], width: u32, height: u32) -> UvCheck {
    let (w, h) = (width as usize, height as usize);
    // Per texel: 1 + the last object that claimed it (0: none yet), whether two objects
    // did, and 1 + the object whose own triangles claimed it twice.
    let mut last = vec![0u32; w * h];
    let mut shared = vec![false; w * h];
    let mut twice = vec![0u32; w * h];
    let size = Vec2::new(width as f32, height as f32);
    let mut result = UvCheck::default();
    for (k, object) in scene.objects.iter().enumerate() {
        let me = k as u32 + 1;
        let mut this = ObjectCheck::default();
        for t in object.triangles.clone() {
            let uv = uv1[t as usize].map(|p| p * size);
            let area = (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]);
            if !area.is_finite() || area == 0.0 {
                continue;
            }
            this.has_uvs = true;
            // A triangle visits each texel once: a texel this object already holds was
            // claimed by another of its triangles.
            for i in centres_inside(uv, w, h) {
                if last[i] == me {
                    if twice[i] != me {
                        twice[i] = me;
                        this.self_overlapped += 1;
                    }
                    continue;
                }
                if last[i] != 0 && !shared[i] {
                    shared[i] = true;
                    result.shared_texels += 1;
                }
                last[i] = me;
                this.texels += 1;
            }
        }
        result.objects.push(this);
    }
    result
}

/// The texels (row-major indices) whose centres lie inside the triangle `uv` (in texels) by
/// more than [`EDGE_TOLERANCE`].
fn centres_inside(uv: [Vec2; 3], w: usize, h: usize) -> impl Iterator<Item = usize> {
    let sign = (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]).signum();
    let edges = [0, 1, 2].map(|k| {
        let (a, b) = (uv[k], uv[(k + 1) % 3]);
        let d = b - a;
        (a, d * sign / d.length().max(f32::MIN_POSITIVE))
    });
    let lo = uv[0].min(uv[1]).min(uv[2]).floor().max(Vec2::ZERO);
    let hi = uv[0].max(uv[1]).max(uv[2]).ceil();
    let (x0, y0) = (lo.x as usize, lo.y as usize);
    let (x1, y1) = (
        (hi.x.max(0.0) as usize).min(w),
        (hi.y.max(0.0) as usize).min(h),
    );
    (y0..y1).flat_map(move |y| {
        (x0..x1).filter_map(move |x| {
            let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let inside = edges
                .iter()
                .all(|(a, d)| d.perp_dot(q - *a) > EDGE_TOLERANCE);
            inside.then_some(y * w + x)
        })
    })
}

/// Texels that triangles of two or more objects overlap with positive area, as the bake's
/// conservative rasterisation sees them ([`crate::bake::lightmap::Texels::rasterise`] gives
/// each such texel to one triangle, and the other object then reads its transfer). The
/// figure the issue measured; 0 for every atlas prt-bake lays out.
pub fn shared_texels(scene: &Scene, atlas: &Atlas) -> usize {
    let (w, h) = (atlas.width as usize, atlas.height as usize);
    let mut owner = vec![0u32; w * h];
    let mut shared = vec![false; w * h];
    let corners: Vec<[Vec2; 3]> = atlas.texel_corners().collect();
    for (k, object) in scene.objects.iter().enumerate() {
        for t in object.triangles.clone() {
            let uv = corners[t as usize];
            let area = (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]);
            if !area.is_finite() || area == 0.0 {
                continue;
            }
            let lo = uv[0].min(uv[1]).min(uv[2]).floor().max(Vec2::ZERO);
            let hi = uv[0].max(uv[1]).max(uv[2]).ceil();
            let (x1, y1) = (
                (hi.x.max(0.0) as usize).min(w),
                (hi.y.max(0.0) as usize).min(h),
            );
            for y in lo.y as usize..y1 {
                for x in lo.x as usize..x1 {
                    if !overlaps_square(uv, Vec2::new(x as f32, y as f32)) {
                        continue;
                    }
                    let i = y * w + x;
                    match owner[i] {
                        0 => owner[i] = k as u32 + 1,
                        o if o != k as u32 + 1 => shared[i] = true,
                        _ => {}
                    }
                }
            }
        }
    }
    shared.iter().filter(|&&s| s).count()
}

/// Whether the triangle overlaps the unit square at `corner` with positive area: no
/// separating axis among the square's and the triangle's edge normals (touching counts as
/// separated).
fn overlaps_square(uv: [Vec2; 3], corner: Vec2) -> bool {
    let square = [
        corner,
        corner + Vec2::X,
        corner + Vec2::ONE,
        corner + Vec2::Y,
    ];
    let axes = [
        Vec2::X,
        Vec2::Y,
        (uv[1] - uv[0]).perp(),
        (uv[2] - uv[1]).perp(),
        (uv[0] - uv[2]).perp(),
    ];
    axes.iter().all(|axis| {
        let range = |points: &[Vec2]| {
            points
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                    let d = axis.dot(*p);
                    (lo.min(d), hi.max(d))
                })
        };
        let (a0, a1) = range(&uv);
        let (b0, b1) = range(&square);
        a0.max(b0) < a1.min(b1)
    })
}

/// One object's UVs as [`pack`] places them.
struct Own {
    /// Per triangle of the object, its corners in the object's own UV space; (−1, −1) at
    /// every corner of a triangle left out.
    uv1: Vec<[Vec2; 3]>,
    uvs: ObjectUvs,
}

/// The scene's lightmap UVs (per triangle corner) as the atlas, if [`check`] finds them
/// clean at `resolution` (the atlas of [`Atlas::from_vertex_uvs`], byte for byte as before
/// this check existed); otherwise each object packed with a scale and offset of its own
/// ([`AtlasSource::PerObject`]), objects whose own UVs overlap themselves or that have none
/// unwrapped alone. `strict`: an object overlapping itself is an error (exit 3) instead.
/// Returns the atlas, the check, and sentences for the user (stderr).
pub fn from_scene_uvs(
    scene: &Scene,
    uvs: &[Vec2],
    resolution: u32,
    strict: bool,
) -> Result<(Atlas, UvCheck, Vec<String>)> {
    let atlas = Atlas::from_vertex_uvs(scene, uvs, resolution, resolution)?;
    let check = check(scene, &atlas.uv1, resolution, resolution);
    if check.is_clean() {
        return Ok((atlas, check, Vec::new()));
    }
    let mut notes = Vec::new();
    let path = scene.path.display();
    let overlapping: Vec<String> = scene
        .objects
        .iter()
        .zip(&check.objects)
        .filter(|(_, c)| c.has_uvs && c.overlaps_itself())
        .map(|(o, c)| {
            format!(
                "'{}' ({:.1} % of its {} texels)",
                o.name,
                100.0 * c.overlap_fraction(),
                c.texels
            )
        })
        .collect();
    if !overlapping.is_empty() {
        let message = format!(
            "the lightmap UVs (TEXCOORD_1) of {} overlap themselves at {resolution}²: {}",
            if overlapping.len() == 1 {
                "object"
            } else {
                "objects"
            },
            overlapping.join(", ")
        );
        if strict {
            return Err(Error::scene(
                crate::support::error::Location::file(&scene.path),
                format!("{message} (--strict-uvs)"),
            ));
        }
        notes.push(format!(
            "warning: {path}: {message}; prt-bake unwraps {} instead and packs it beside the \
             others (--strict-uvs makes this an error)",
            if overlapping.len() == 1 {
                "that object"
            } else {
                "those objects"
            }
        ));
    }
    let missing: Vec<&str> = scene
        .objects
        .iter()
        .zip(&check.objects)
        .filter(|(_, c)| !c.has_uvs)
        .map(|(o, _)| o.name.as_str())
        .collect();
    if !missing.is_empty() {
        notes.push(format!(
            "note: {path}: no lightmap UVs (TEXCOORD_1) on '{}': unwrapped by prt-bake",
            missing.join("', '")
        ));
    }
    if check.shared_texels > 0 {
        notes.push(format!(
            "note: {path}: the lightmap UVs (TEXCOORD_1) of different objects overlap ({} \
             texels at {resolution}² claimed by two or more objects): each object's UVs are \
             packed into the atlas with a scale and offset of its own (prt-bake inspect \
             lists them)",
            check.shared_texels
        ));
    }
    let own: Vec<Own> = scene
        .objects
        .iter()
        .zip(&check.objects)
        .map(|(o, c)| {
            let uv1 = atlas.uv1[o.triangles.start as usize..o.triangles.end as usize].to_vec();
            let uvs = match (c.has_uvs, c.overlaps_itself()) {
                (false, _) => ObjectUvs::GeneratedMissing,
                (true, true) => ObjectUvs::GeneratedOverlapping,
                (true, false) => ObjectUvs::Own,
            };
            Own { uv1, uvs }
        })
        .collect();
    let packed = pack(scene, own, resolution)?;
    Ok((packed, check, notes))
}

/// A scene of one object of `scene` (for unwrapping it alone).
fn object_scene(scene: &Scene, object: &Object) -> Scene {
    let (v0, v1) = (object.vertices.start as usize, object.vertices.end as usize);
    let (t0, t1) = (
        object.triangles.start as usize,
        object.triangles.end as usize,
    );
    Scene {
        objects: vec![Object {
            name: object.name.clone(),
            vertices: 0..object.vertices.len() as u32,
            triangles: 0..object.triangles.len() as u32,
        }],
        positions: scene.positions[v0..v1].to_vec(),
        normals: scene.normals[v0..v1].to_vec(),
        uvs: scene.uvs[v0..v1].to_vec(),
        vertex_material: scene.vertex_material[v0..v1].to_vec(),
        triangles: scene.triangles[t0..t1]
            .iter()
            .map(|t| t.map(|v| v - object.vertices.start))
            .collect(),
        materials: scene.materials.clone(),
        up: scene.up,
        tangents: scene.tangents.as_ref().map(|t| t[v0..v1].to_vec()),
        ..Scene::empty(&scene.path)
    }
}

/// An object unwrapped alone into a `page`² chart set, its UVs in [0, 1] of that page.
fn unwrap_alone(scene: &Scene, object: &Object, page: u32) -> Result<Vec<[Vec2; 3]>> {
    let alone = object_scene(scene, object);
    let generated = generate(&alone, page, None, AtlasMethod::Unwrap).map_err(|e| {
        Error::InvalidOption(format!(
            "unwrapping '{}' for the lightmap: {e}",
            object.name
        ))
    })?;
    Ok(generated.atlas.uv1)
}

/// What an object's rectangle is made from: its own UVs' bounding box and texel density.
struct Extent {
    min: Vec2,
    /// The bounding box's size in world units at equal density: size × √(world area / UV area).
    world: Vec2,
    size: Vec2,
}

fn extent(scene: &Scene, object: &Object, uv1: &[[Vec2; 3]]) -> Option<Extent> {
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    let (mut uv_area, mut world_area) = (0.0f64, 0.0f64);
    for (t, uv) in object.triangles.clone().zip(uv1) {
        if uv.iter().any(|p| *p == Vec2::splat(-1.0)) {
            continue;
        }
        let p = scene.triangles[t as usize].map(|v| scene.positions[v as usize]);
        uv_area += f64::from((uv[1] - uv[0]).perp_dot(uv[2] - uv[0]).abs()) / 2.0;
        world_area += f64::from((p[1] - p[0]).cross(p[2] - p[0]).length()) / 2.0;
        for c in uv {
            lo = lo.min(*c);
            hi = hi.max(*c);
        }
    }
    if !(uv_area > 0.0 && world_area > 0.0) {
        return None;
    }
    let size = (hi - lo).max(Vec2::splat(1e-6));
    Some(Extent {
        min: lo,
        world: size * (world_area / uv_area).sqrt() as f32,
        size,
    })
}

/// Places rectangles of `sizes` texels on shelves (tallest first) in a `resolution`² page
/// with [`PADDING`] texels between them; their lower-left corners, or `None` if they do not
/// fit.
fn shelves(sizes: &[[u32; 2]], resolution: u32) -> Option<Vec<[u32; 2]>> {
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&i| {
        (
            std::cmp::Reverse(sizes[i][1]),
            std::cmp::Reverse(sizes[i][0]),
            i,
        )
    });
    let mut at = vec![[0u32; 2]; sizes.len()];
    let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
    for i in order {
        let [w, h] = sizes[i];
        if x > 0 && x + w > resolution {
            (x, y, shelf) = (0, y + shelf + PADDING, 0);
        }
        if x + w > resolution || y + h > resolution {
            return None;
        }
        at[i] = [x, y];
        x += w + PADDING;
        shelf = shelf.max(h);
    }
    Some(at)
}

/// Rectangle sizes in texels at `k` texels per world unit.
fn sizes_at(extents: &[Extent], k: f64) -> Vec<[u32; 2]> {
    extents
        .iter()
        .map(|e| {
            e.world
                .to_array()
                .map(|s| ((f64::from(s) * k + 1e-3).ceil() as u32).max(1))
        })
        .collect()
}

/// The largest density (texels per world unit, within 0.1 %) at which `extents` fit on
/// shelves, and where.
fn largest_fit(extents: &[Extent], resolution: u32) -> Option<(f64, Vec<[u32; 2]>)> {
    let widest = extents
        .iter()
        .map(|e| f64::from(e.world.max_element()))
        .fold(0.0, f64::max);
    let (mut lo, mut hi) = (0.0, f64::from(resolution) / widest.max(f64::MIN_POSITIVE));
    let mut best = shelves(&sizes_at(extents, lo), resolution).map(|at| (lo, at));
    best.as_ref()?;
    while hi - lo > 1e-3 * hi {
        let mid = (lo + hi) / 2.0;
        match shelves(&sizes_at(extents, mid), resolution) {
            Some(at) => (lo, best) = (mid, Some((mid, at))),
            None => hi = mid,
        }
    }
    best
}

/// Packs every object's own UVs into a `resolution`² atlas at one texel density, each
/// object in a rectangle of its own ([`AtlasSource::PerObject`]); objects marked generated
/// are unwrapped alone, first at `resolution` (for their area), then again at the size of
/// their rectangle, so their charts keep [`PADDING`] texels apart in the atlas.
fn pack(scene: &Scene, mut own: Vec<Own>, resolution: u32) -> Result<Atlas> {
    for (object, o) in scene.objects.iter().zip(&mut own) {
        if o.uvs != ObjectUvs::Own {
            o.uv1 = unwrap_alone(scene, object, resolution)?;
        }
    }
    let extents: Vec<Option<Extent>> = scene
        .objects
        .iter()
        .zip(&own)
        .map(|(object, o)| extent(scene, object, &o.uv1))
        .collect();
    // Objects of no area (in space or in their UVs) take no texels.
    let placed: Vec<usize> = (0..extents.len())
        .filter(|&i| extents[i].is_some())
        .collect();
    let boxes: Vec<Extent> = extents.into_iter().flatten().collect();
    let too_small = || {
        Error::InvalidOption(format!(
            "the scene's {} objects do not fit a {resolution}² lightmap, each in a rectangle of \
             its own with {PADDING} texels of padding: use a larger --lightmap",
            boxes.len()
        ))
    };
    let (k, at) = largest_fit(&boxes, resolution).ok_or_else(too_small)?;
    let sizes = sizes_at(&boxes, k);
    let r = resolution as f32;
    let mut uv1 = vec![[Vec2::splat(-1.0); 3]; scene.triangles.len()];
    let mut placements = vec![
        ObjectPlacement {
            scale: [1.0; 2],
            offset: [0.0; 2],
            uvs: ObjectUvs::Own,
        };
        scene.objects.len()
    ];
    for (n, &i) in placed.iter().enumerate() {
        let object = &scene.objects[i];
        let corner = Vec2::new(at[n][0] as f32, at[n][1] as f32);
        let (scale, offset) = if own[i].uvs == ObjectUvs::Own {
            // Uniform: the object's UV aspect is kept.
            let s = (boxes[n].world.x as f64 * k / f64::from(boxes[n].size.x)) as f32 / r;
            (s, corner / r - boxes[n].min * s)
        } else {
            // Again at the rectangle's size: its charts' padding is then in atlas texels.
            let page = sizes[n][0].min(sizes[n][1]).max(MIN_RESOLUTION);
            match unwrap_alone(scene, object, page) {
                Ok(uv1) if page <= sizes[n][0].min(sizes[n][1]) => {
                    own[i].uv1 = uv1;
                    (page as f32 / r, corner / r)
                }
                // Too small a rectangle to unwrap into: the first unwrap, scaled into it
                // (its charts' padding shrinks with it).
                _ => {
                    let fit = Vec2::new(sizes[n][0] as f32, sizes[n][1] as f32) / boxes[n].size;
                    let s = fit.min_element() / r;
                    (s, corner / r - boxes[n].min * s)
                }
            }
        };
        placements[i] = ObjectPlacement {
            scale: [scale; 2],
            offset: offset.to_array(),
            uvs: own[i].uvs,
        };
        for (t, corners) in object.triangles.clone().zip(&own[i].uv1) {
            if corners.iter().all(|p| *p != Vec2::splat(-1.0)) {
                uv1[t as usize] =
                    corners.map(|p| (p * scale + offset).clamp(Vec2::ZERO, Vec2::ONE));
            }
        }
    }
    Ok(Atlas {
        width: resolution,
        height: resolution,
        uv1,
        source: AtlasSource::PerObject,
        texel_size: None,
        objects: placements,
    })
}
