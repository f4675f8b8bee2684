//! `EXT_mesh_gpu_instancing`: a node whose extension lists per-instance TRANSLATION,
//! ROTATION and SCALE accessors places its mesh once per instance, at the node's transform
//! times the instance's TRS (and not at the node itself). Each instance becomes a mesh node
//! of its own for the rest of the load, so it is flattened or instanced
//! ([`super::instancing`]) like any node that shares a mesh.
//!
//! The `gltf` crate does not read the extension (nor, without its `extensions` feature, keep
//! it), so the JSON is read again here, only for files that use it. Float attributes are
//! read; the normalised-integer rotations the extension also allows are refused by name.

use glam::{Mat4, Quat, Vec3};
use serde_json::Value;

const EXTENSION: &str = "EXT_mesh_gpu_instancing";

/// The mesh nodes of `placed` with every instanced node replaced by its instances.
#[allow(clippy::type_complexity)]
pub(super) fn expand<'a>(
    document: &'a gltf::Document,
    json: &[u8],
    buffers: &[gltf::buffer::Data],
    placed: Vec<(gltf::Node<'a>, gltf::Mesh<'a>, Mat4)>,
) -> Result<Vec<(gltf::Node<'a>, gltf::Mesh<'a>, Mat4)>, String> {
    if !document.extensions_used().any(|e| e == EXTENSION) {
        return Ok(placed);
    }
    let root: Value =
        serde_json::from_slice(json).map_err(|err| format!("not readable JSON: {err}"))?;
    let mut out = Vec::with_capacity(placed.len());
    for (node, mesh, world) in placed {
        let pointer = format!("/nodes/{}/extensions/{EXTENSION}/attributes", node.index());
        let Some(attributes) = root.pointer(&pointer) else {
            out.push((node, mesh, world));
            continue;
        };
        let transforms = instance_transforms(document, buffers, attributes)
            .map_err(|m| format!("node {}: {EXTENSION}: {m}", node.index()))?;
        out.extend(
            transforms
                .into_iter()
                .map(|t| (node.clone(), mesh.clone(), world * t)),
        );
    }
    Ok(out)
}

/// Each instance's matrix T·R·S from the attributes present (identity for those absent).
fn instance_transforms(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    attributes: &Value,
) -> Result<Vec<Mat4>, String> {
    let read = |name: &str, width: usize| -> Result<Option<Vec<f32>>, String> {
        match attributes.get(name) {
            None => Ok(None),
            Some(index) => {
                let index = index
                    .as_u64()
                    .ok_or_else(|| format!("{name} is not an accessor index"))?;
                floats(document, buffers, index as usize, width)
                    .map(Some)
                    .map_err(|m| format!("{name} (accessor {index}): {m}"))
            }
        }
    };
    let translation = read("TRANSLATION", 3)?;
    let rotation = read("ROTATION", 4)?;
    let scale = read("SCALE", 3)?;
    let counts: Vec<usize> = [(&translation, 3), (&rotation, 4), (&scale, 3)]
        .iter()
        .filter_map(|(values, width)| values.as_ref().map(|v| v.len() / width))
        .collect();
    let Some(&count) = counts.first() else {
        return Err("no TRANSLATION, ROTATION or SCALE attribute".into());
    };
    if counts.iter().any(|&c| c != count) {
        return Err(format!("attributes of different counts {counts:?}"));
    }
    let vec3 = |values: &Option<Vec<f32>>, i: usize, default: Vec3| {
        values
            .as_ref()
            .map_or(default, |v| Vec3::from_slice(&v[3 * i..3 * i + 3]))
    };
    (0..count)
        .map(|i| {
            let r = rotation
                .as_ref()
                .map_or(Quat::IDENTITY, |v| Quat::from_slice(&v[4 * i..4 * i + 4]));
            let m = Mat4::from_scale_rotation_translation(
                vec3(&scale, i, Vec3::ONE),
                r.normalize(),
                vec3(&translation, i, Vec3::ZERO),
            );
            match m.is_finite() {
                true => Ok(m),
                false => Err(format!("instance {i}'s transform is not finite")),
            }
        })
        .collect()
}

/// The float components of accessor `index`, `width` per element, read after checking that
/// every byte lies inside its buffer view and buffer (a hostile file must not make us read
/// past them).
fn floats(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    index: usize,
    width: usize,
) -> Result<Vec<f32>, String> {
    use gltf::accessor::DataType;
    let accessor = document.accessors().nth(index).ok_or("no such accessor")?;
    if accessor.data_type() != DataType::F32 || accessor.dimensions().multiplicity() != width {
        return Err(format!(
            "{:?} of {:?}: only float VEC{width} is read",
            accessor.dimensions(),
            accessor.data_type()
        ));
    }
    if accessor.sparse().is_some() {
        return Err("sparse accessors are not read here".into());
    }
    let view = accessor.view().ok_or("no buffer view")?;
    let buffer = buffers.get(view.buffer().index()).ok_or("no such buffer")?;
    let size = 4 * width;
    let stride = view.stride().unwrap_or(size).max(size);
    let count = accessor.count();
    let last = count
        .checked_sub(1)
        .map_or(Some(0), |n| n.checked_mul(stride)?.checked_add(size));
    let fits = last
        .and_then(|l| accessor.offset().checked_add(l))
        .is_some_and(|end| end <= view.length())
        && view
            .offset()
            .checked_add(view.length())
            .is_some_and(|end| end <= buffer.len());
    if !fits {
        return Err("its data lies outside its buffer view or buffer".into());
    }
    // In range: both offsets were checked against the buffer above.
    let start = view.offset() + accessor.offset();
    let mut values = Vec::with_capacity(count * width);
    for i in 0..count {
        for k in 0..width {
            let at = start + i * stride + 4 * k;
            values.push(f32::from_le_bytes(
                buffer[at..at + 4].try_into().expect("4 bytes"),
            ));
        }
    }
    Ok(values)
}
