//! The atlas of a texel bake of some objects only (`bake --lightmap N --receivers GLOBS`):
//! the receiving objects are unwrapped (or their lightmap UVs checked and packed) as a scene
//! of their own, so their charts are exactly those of a scene holding only them; every other
//! triangle is left out of the atlas ((−1, −1) at its corners, as a degenerate one is), casts
//! no texel and only occludes.
//!
//! Interreflected texel bakes need the previous bounce at every hit, the non-receivers' too,
//! and those have no texels: refused ([`check_mode`]).

use glam::Vec2;

use crate::bake::options::Mode;
use crate::formats::header::{AtlasSource, ObjectPlacement, ObjectUvs};
use crate::scene::{Object, Scene};
use crate::support::error::{Error, Result};

use super::Atlas;

/// Refuses (a usage error) an interreflected texel bake of some objects: a bounce that hits
/// a non-receiver needs its transfer, which has no texels to live in.
pub fn check_mode(mode: Mode) -> Result<()> {
    match mode {
        Mode::Interreflected => Err(Error::InvalidOption(
            "--receivers with --lightmap bakes unshadowed or shadowed transfer only: \
             interreflected texels need the previous bounce on the non-receivers too, \
             which have no texels (bake them per vertex, or every object per texel)"
                .into(),
        )),
        _ => Ok(()),
    }
}

/// The scene of `objects` (ascending indices of `scene`) alone, their vertices and triangles
/// in scene order, as a file holding only them would load.
pub fn receiver_scene(scene: &Scene, objects: &[u32]) -> Scene {
    // No instances and no back sheets: only the atlas is made from it, and receiving back
    // sheets are ordinary objects here.
    let mut sub = Scene {
        objects: Vec::with_capacity(objects.len()),
        materials: scene.materials.clone(),
        up: scene.up,
        lightmap_uvs: scene.lightmap_uvs.as_ref().map(|_| Vec::new()),
        tangents: scene.tangents.as_ref().map(|_| Vec::new()),
        ..Scene::empty(&scene.path)
    };
    for &o in objects {
        let object = &scene.objects[o as usize];
        let vertices = object.vertices.start as usize..object.vertices.end as usize;
        let base = sub.positions.len() as u32;
        sub.objects.push(Object {
            name: object.name.clone(),
            vertices: base..base + object.vertices.len() as u32,
            triangles: sub.triangles.len() as u32
                ..(sub.triangles.len() + object.triangles.len()) as u32,
        });
        sub.positions
            .extend_from_slice(&scene.positions[vertices.clone()]);
        sub.normals
            .extend_from_slice(&scene.normals[vertices.clone()]);
        sub.uvs.extend_from_slice(&scene.uvs[vertices.clone()]);
        sub.vertex_material
            .extend_from_slice(&scene.vertex_material[vertices.clone()]);
        if let (Some(to), Some(from)) = (&mut sub.lightmap_uvs, &scene.lightmap_uvs) {
            to.extend_from_slice(&from[vertices.clone()]);
        }
        if let (Some(to), Some(from)) = (&mut sub.tangents, &scene.tangents) {
            to.extend_from_slice(&from[vertices]);
        }
        let t = object.triangles.start as usize..object.triangles.end as usize;
        sub.triangles.extend(
            scene.triangles[t]
                .iter()
                .map(|tri| tri.map(|v| v - object.vertices.start + base)),
        );
    }
    sub
}

/// The atlas of the whole `scene` from `receiving`, the atlas of [`receiver_scene`]`(scene,
/// objects)`: the receivers' triangles keep their UVs, the others are left out. A per-object
/// atlas places the non-receivers with scale 0 at (−1, −1): their own UVs map to "left out".
pub fn widen(scene: &Scene, objects: &[u32], receiving: Atlas) -> Atlas {
    let left_out = [Vec2::splat(-1.0); 3];
    let mut uv1 = vec![left_out; scene.triangles.len()];
    let mut placements = Vec::new();
    let mut from = 0usize;
    for (k, &o) in objects.iter().enumerate() {
        let t = &scene.objects[o as usize].triangles;
        let n = t.len();
        uv1[t.start as usize..t.end as usize].copy_from_slice(&receiving.uv1[from..from + n]);
        from += n;
        if receiving.source == AtlasSource::PerObject {
            placements.resize(o as usize, absent());
            placements.push(receiving.objects[k]);
        }
    }
    if receiving.source == AtlasSource::PerObject {
        placements.resize(scene.objects.len(), absent());
    }
    Atlas {
        uv1,
        objects: placements,
        ..receiving
    }
}

/// A per-object placement that maps every UV out of the atlas.
fn absent() -> ObjectPlacement {
    ObjectPlacement {
        scale: [0.0, 0.0],
        offset: [-1.0, -1.0],
        uvs: ObjectUvs::Own,
    }
}
