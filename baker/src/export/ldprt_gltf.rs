//! `prt-bake export FILE.ldprt --scene SKINNED.glb --gltf OUT.glb`: the LDPRT lobes written
//! into a copy of the skinned `.glb` they were baked from, as vertex attributes of its own
//! primitives. Everything else in the file (nodes, skins, joints, weights, inverse bind
//! matrices, animations, materials) is kept byte for byte; the new data is appended to its
//! binary chunk (docs/reference/gltf.md, "LDPRT lobes").
//!
//! Per vertex, in the mesh's bind (object) space, as a runtime skins NORMAL and TANGENT:
//! * `_LDPRT_NORMAL`, `_LDPRT_TANGENT` (VEC3): the vertex's frame, taken from the baked pose
//!   back through its skinning ([`bind_frames`]);
//! * `_LDPRT_AXIS_k` (VEC3): lobe k's axis in that frame (x tangent, y normal × tangent,
//!   z normal), as the LDPRT file stores it;
//! * `_LDPRT_ZH_k` (VEC4): lobe k's zonal coefficients g_0..g_3 (zero past the order), or for
//!   an RGB bake `_LDPRT_ZH_R_k`, `_LDPRT_ZH_G_k`, `_LDPRT_ZH_B_k`.
//!
//! A runtime skins the normal and tangent with the vertex's blended joint matrix, makes the
//! tangent orthogonal to the normal, turns each axis into the world with that frame, and
//! lights each lobe: Σ_l c_l g_l Σ_m L_lm y_lm(axis), c_l = sqrt(4π/(2l+1)).
//! `relight SKINNED.glb FILE.ldprt --pose P` computes exactly this.

use std::path::Path;

use glam::DVec3;
use serde_json::{Value, json};

use crate::bake::ldprt::{bind_frames, frame};
use crate::export::relight_ldprt::load_posed_as_baked;
use crate::formats::ldprt_file::LdprtFile;
use crate::scene::Pose;
use crate::support::error::{Error, Location, Result};
use crate::support::output::Output;

/// Zonal coefficients per lobe and channel the attributes hold: one VEC4.
pub const MAX_ORDER: u32 = 4;

/// What was written.
pub struct Written {
    pub bytes: usize,
    pub vertex_count: usize,
    pub primitives: usize,
    pub lobes: u32,
    pub attributes: Vec<String>,
}

/// Writes `ldprt`'s lobes into a copy of `glb` (the skinned file it was baked from) at
/// `output`, atomically.
pub fn export_ldprt_glb(ldprt: &Path, glb: &Path, output: &Path) -> Result<Written> {
    let output = Output::new(output, &[ldprt.to_path_buf(), glb.to_path_buf()])?;
    let bad = |message: String| Error::scene(Location::file(glb), message);
    let file = LdprtFile::read(ldprt)?;
    if file.order > MAX_ORDER {
        return Err(Error::InvalidOption(format!(
            "{}: order {} has more zonal coefficients than the glTF export's VEC4 per lobe \
             (order {MAX_ORDER} at most)",
            ldprt.display(),
            file.order
        )));
    }
    let pose: Pose = file
        .pose
        .as_deref()
        .unwrap_or("rest")
        .parse()
        .map_err(bad)?;
    let (scene, _) = load_posed_as_baked(&file, ldprt, glb, &pose)?;
    let (Some(linear), Some(sources)) = (&scene.pose_linear, &scene.gltf_primitives) else {
        return Err(bad(
            "has no skin: the LDPRT export writes its lobes into a skinned .glb (other meshes \
             relight with prt-bake relight)"
                .into(),
        ));
    };
    if sources.len() != scene.objects.len() {
        return Err(bad(
            "has doubleSided materials whose back sheets the bake added: not exported (bake \
             with --double-sided off)"
                .into(),
        ));
    }
    let mut seen = std::collections::HashSet::new();
    if let Some(twice) = sources.iter().find(|s| !seen.insert(**s)) {
        return Err(bad(format!(
            "mesh {} is placed at two nodes: its primitive {} cannot hold two vertices' lobes",
            twice[0], twice[1]
        )));
    }
    let bytes = crate::support::limits::read_file(glb)?;
    let (mut root, mut bin) = split_glb(&bytes).map_err(bad)?;
    let frames = frame::vertex_frames(&scene.positions, &scene.normals, &scene.triangles);
    let bind = bind_frames(&frames, linear);
    let mut attributes = Vec::new();
    for (object, source) in scene.objects.iter().zip(sources) {
        let vertices = object.vertices.start as usize..object.vertices.end as usize;
        let added = add_attributes(&mut root, &mut bin, &file, &bind, vertices, *source);
        attributes = added.map_err(bad)?;
    }
    root["extras"]["prt_ldprt"] = json!({
        "order": file.order,
        "lobes": file.lobes,
        "channels": file.channels,
        "pose": file.pose,
        "up": file.up.name(),
        "fit_error": file.error,
    });
    let glb_bytes = join_glb(&root, &bin);
    output.write(&glb_bytes)?;
    Ok(Written {
        bytes: glb_bytes.len(),
        vertex_count: scene.vertex_count(),
        primitives: sources.len(),
        lobes: file.lobes,
        attributes,
    })
}

/// The attributes of `vertices` appended to the primitive `[mesh, primitive]`; their names.
fn add_attributes(
    root: &mut Value,
    bin: &mut Vec<u8>,
    file: &LdprtFile,
    bind: &[[DVec3; 2]],
    vertices: std::ops::Range<usize>,
    [mesh, primitive]: [u32; 2],
) -> std::result::Result<Vec<String>, String> {
    let count = vertices.len();
    let (lobes, channels, order) = (
        file.lobes as usize,
        file.channels as usize,
        file.order as usize,
    );
    let mut columns: Vec<(String, usize, Vec<f32>)> = Vec::new();
    let vec3 = |v: DVec3| v.normalize_or_zero().as_vec3().to_array();
    let normals = vertices.clone().flat_map(|v| vec3(bind[v][1])).collect();
    let tangents = vertices.clone().flat_map(|v| vec3(bind[v][0])).collect();
    columns.push(("_LDPRT_NORMAL".into(), 3, normals));
    columns.push(("_LDPRT_TANGENT".into(), 3, tangents));
    for k in 0..lobes {
        let axes = vertices
            .clone()
            .flat_map(|v| file.axes[v * lobes + k])
            .collect();
        columns.push((format!("_LDPRT_AXIS_{k}"), 3, axes));
        for c in 0..channels {
            let name = match channels {
                1 => format!("_LDPRT_ZH_{k}"),
                _ => format!("_LDPRT_ZH_{}_{k}", ["R", "G", "B"][c]),
            };
            let mut zh = Vec::with_capacity(4 * count);
            for v in vertices.clone() {
                let g = file.zh(v, k, c);
                zh.extend((0..4).map(|l| if l < order { g[l] } else { 0.0 }));
            }
            columns.push((name, 4, zh));
        }
    }
    let target =
        root["meshes"][mesh as usize]["primitives"][primitive as usize]["attributes"].clone();
    if !target.is_object() {
        return Err(format!(
            "mesh {mesh} primitive {primitive} has no attributes"
        ));
    }
    let mut names = Vec::new();
    for (name, width, values) in columns {
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let offset = bin.len();
        bin.extend(values.iter().flat_map(|x| x.to_le_bytes()));
        let views = root["bufferViews"].as_array_mut().ok_or("no bufferViews")?;
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": 4 * values.len(), "target": 34962}));
        let view = views.len() - 1;
        let accessors = root["accessors"].as_array_mut().ok_or("no accessors")?;
        let kind = if width == 3 { "VEC3" } else { "VEC4" };
        accessors
            .push(json!({"bufferView": view, "componentType": 5126, "count": count, "type": kind}));
        let accessor = accessors.len() - 1;
        root["meshes"][mesh as usize]["primitives"][primitive as usize]["attributes"][&name] =
            json!(accessor);
        names.push(name);
    }
    Ok(names)
}

/// The JSON and binary chunk of a `.glb` whose only buffer is that chunk.
fn split_glb(bytes: &[u8]) -> std::result::Result<(Value, Vec<u8>), String> {
    let glb = gltf::Glb::from_slice(bytes).map_err(|_| {
        "is not a binary glTF (.glb): the LDPRT export writes into the .glb it was baked from"
            .to_string()
    })?;
    let root: Value =
        serde_json::from_slice(&glb.json).map_err(|e| format!("invalid JSON: {e}"))?;
    let buffers = root["buffers"].as_array().map_or(0, Vec::len);
    let embedded = root["buffers"][0].get("uri").is_none();
    match (&glb.bin, buffers, embedded) {
        (Some(bin), 1, true) => Ok((root, bin.to_vec())),
        _ => Err(format!(
            "has {buffers} buffer(s); the LDPRT export needs its data in the .glb's own binary \
             chunk, one buffer"
        )),
    }
}

/// A `.glb` of `root` (its buffer's length set to the chunk's) and `bin`.
fn join_glb(root: &Value, bin: &[u8]) -> Vec<u8> {
    let mut root = root.clone();
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    root["buffers"][0]["byteLength"] = json!(bin.len());
    let mut text = serde_json::to_string(&root).expect("a JSON value serialises");
    while text.len() % 4 != 0 {
        text.push(' ');
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text.as_bytes());
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&bin);
    out
}
