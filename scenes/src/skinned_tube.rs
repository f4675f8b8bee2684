//! `tube/tube-skinned.glb`: the ribbed tube of [`crate::tube`] as a skinned glTF, a
//! three-joint armature (root at z = 0, elbow at z = 1, tip at z = 2) and an animation
//! `bend` that turns the elbow about +y from 0° to 90° over one second (keyframes at 0, 0.5
//! and 1 s, linear), bending the far half towards +x as `tube-bent.obj` is bent.
//!
//! Linear-blend skinning: vertices below z = 1 − BLEND follow the root, those above
//! z = 1 + BLEND the elbow, and a smoothstep between. NORMAL is the rest mesh's
//! area-weighted normal. Written byte for byte the same on every run.

use std::fmt::Write as _;

use glam::{Mat4, Quat, Vec3};

use crate::tube::tube;

/// Half the length of the blend between the root's and the elbow's vertices.
pub const BLEND: f32 = 0.2;
/// z of the elbow joint.
pub const ELBOW: f32 = 1.0;
/// Times and angles (degrees about +y) of the `bend` animation's keyframes.
pub const KEYFRAMES: [(f32, f32); 3] = [(0.0, 0.0), (0.5, 45.0), (1.0, 90.0)];

/// The elbow's weight at height z (the root has the rest).
pub fn elbow_weight(z: f32) -> f32 {
    let t = ((z - (ELBOW - BLEND)) / (2.0 * BLEND)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Area-weighted vertex normals of a closed-around tube (open ends).
fn normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let face = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += face;
        }
    }
    n.iter().map(|v| v.normalize()).collect()
}

/// Appends `bytes` to `bin` (4-byte aligned) and returns (offset, length).
fn push(bin: &mut Vec<u8>, bytes: &[u8]) -> (usize, usize) {
    let offset = bin.len();
    bin.extend_from_slice(bytes);
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    (offset, bytes.len())
}

fn floats(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// The GLB's bytes.
pub fn skinned_tube_glb() -> Vec<u8> {
    let (positions, triangles) = tube();
    let normals = normals(&positions, &triangles);
    let mut bin = Vec::new();
    let mut views = Vec::new();
    let mut view = |bin: &mut Vec<u8>, bytes: Vec<u8>, target: Option<u32>| {
        let (offset, length) = push(bin, &bytes);
        let target = target.map_or(String::new(), |t| format!(",\"target\":{t}"));
        views.push(format!(
            "{{\"buffer\":0,\"byteOffset\":{offset},\"byteLength\":{length}{target}}}"
        ));
        views.len() - 1
    };
    let (lo, hi) = positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let p = view(
        &mut bin,
        floats(positions.iter().flat_map(|p| p.to_array())),
        Some(34962),
    );
    let n = view(
        &mut bin,
        floats(normals.iter().flat_map(|n| n.to_array())),
        Some(34962),
    );
    // Joints and weights per vertex, a joint of zero weight written as 0 (the validator's
    // rule): all root, all elbow, or a blend of the two.
    let influences = |z: f32| match elbow_weight(z) {
        0.0 => ([0u8, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
        1.0 => ([1, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
        w => ([0, 1, 0, 0], [1.0 - w, w, 0.0, 0.0]),
    };
    let joints: Vec<u8> = positions.iter().flat_map(|p| influences(p.z).0).collect();
    let j = view(&mut bin, joints, Some(34962));
    let weights = positions.iter().flat_map(|p| influences(p.z).1);
    let w = view(&mut bin, floats(weights), Some(34962));
    let indices: Vec<u8> = triangles
        .iter()
        .flatten()
        .flat_map(|&i| (i as u16).to_le_bytes())
        .collect();
    let i = view(&mut bin, indices, Some(34963));
    let inverse_binds = [0.0, ELBOW, 2.0].map(|z| Mat4::from_translation(Vec3::new(0.0, 0.0, -z)));
    let ibm = view(
        &mut bin,
        floats(inverse_binds.iter().flat_map(|m| m.to_cols_array())),
        None,
    );
    let times = view(&mut bin, floats(KEYFRAMES.map(|k| k.0)), None);
    let turns = KEYFRAMES.map(|k| Quat::from_rotation_y(k.1.to_radians()).to_array());
    let rotations = view(&mut bin, floats(turns.into_iter().flatten()), None);
    let count = positions.len();
    let mut json = String::new();
    let _ = write!(
        json,
        concat!(
            "{{\"asset\":{{\"version\":\"2.0\",\"generator\":\"prt-scenes gen-scenes\"}},",
            "\"scene\":0,\"scenes\":[{{\"nodes\":[0,3]}}],",
            "\"nodes\":[{{\"name\":\"root\",\"children\":[1]}},",
            "{{\"name\":\"elbow\",\"translation\":[0,0,{elbow}],\"children\":[2]}},",
            "{{\"name\":\"tip\",\"translation\":[0,0,{tip}]}},",
            "{{\"name\":\"tube\",\"mesh\":0,\"skin\":0}}],",
            "\"skins\":[{{\"joints\":[0,1,2],\"skeleton\":0,\"inverseBindMatrices\":5}}],",
            "\"meshes\":[{{\"name\":\"tube\",\"primitives\":[{{\"attributes\":",
            "{{\"POSITION\":0,\"NORMAL\":1,\"JOINTS_0\":2,\"WEIGHTS_0\":3}},\"indices\":4}}]}}],",
            "\"animations\":[{{\"name\":\"bend\",\"samplers\":[{{\"input\":6,\"output\":7,",
            "\"interpolation\":\"LINEAR\"}}],\"channels\":[{{\"sampler\":0,",
            "\"target\":{{\"node\":1,\"path\":\"rotation\"}}}}]}}],",
            "\"accessors\":[",
            "{{\"bufferView\":{p},\"componentType\":5126,\"count\":{count},\"type\":\"VEC3\",",
            "\"min\":[{lx},{ly},{lz}],\"max\":[{hx},{hy},{hz}]}},",
            "{{\"bufferView\":{n},\"componentType\":5126,\"count\":{count},\"type\":\"VEC3\"}},",
            "{{\"bufferView\":{j},\"componentType\":5121,\"count\":{count},\"type\":\"VEC4\"}},",
            "{{\"bufferView\":{w},\"componentType\":5126,\"count\":{count},\"type\":\"VEC4\"}},",
            "{{\"bufferView\":{i},\"componentType\":5123,\"count\":{indices},\"type\":\"SCALAR\"}},",
            "{{\"bufferView\":{ibm},\"componentType\":5126,\"count\":3,\"type\":\"MAT4\"}},",
            "{{\"bufferView\":{times},\"componentType\":5126,\"count\":3,\"type\":\"SCALAR\",",
            "\"min\":[{t0}],\"max\":[{t1}]}},",
            "{{\"bufferView\":{rotations},\"componentType\":5126,\"count\":3,\"type\":\"VEC4\"}}],",
            "\"bufferViews\":[{views}],\"buffers\":[{{\"byteLength\":{length}}}]}}"
        ),
        p = p,
        n = n,
        j = j,
        w = w,
        i = i,
        ibm = ibm,
        times = times,
        rotations = rotations,
        count = count,
        elbow = ELBOW,
        tip = 2.0 - ELBOW,
        lx = lo.x,
        ly = lo.y,
        lz = lo.z,
        hx = hi.x,
        hy = hi.y,
        hz = hi.z,
        indices = triangles.len() * 3,
        t0 = KEYFRAMES[0].0,
        t1 = KEYFRAMES[2].0,
        views = views.join(","),
        length = bin.len(),
    );
    while json.len() % 4 != 0 {
        json.push(' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::with_capacity(total);
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(json.as_bytes());
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    glb
}
