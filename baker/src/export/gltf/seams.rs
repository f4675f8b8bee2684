//! A texel bake's mesh for glTF: vertices split where the lightmap's charts part, so each
//! vertex has one lightmap UV, and the bake's AO as a linear PNG for `occlusionTexture`.

use std::path::Path;

use glam::Vec2;

use crate::scene::Scene;
use crate::support::error::{Error, Result};

/// The scene with one vertex per distinct (vertex, lightmap UV) pair of its triangle corners
/// and `lightmap_uvs` set to those UVs; triangles keep their order, each object's new
/// vertices are contiguous and in order of first use. Vertices no triangle uses are dropped.
pub fn split_at_lightmap_seams(scene: &Scene, uv1: &[[Vec2; 3]]) -> Scene {
    let mut split = Scene {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        vertex_material: Vec::new(),
        triangles: Vec::with_capacity(scene.triangles.len()),
        objects: Vec::with_capacity(scene.objects.len()),
        lightmap_uvs: None,
        tangents: scene.tangents.as_ref().map(|_| Vec::new()),
        pose_linear: None,
        gltf_primitives: None,
        ..scene.clone()
    };
    let mut lightmap = Vec::new();
    for object in &scene.objects {
        let first = split.positions.len() as u32;
        let mut index = std::collections::HashMap::new();
        let range = object.triangles.start as usize..object.triangles.end as usize;
        for (vertices, uvs) in scene.triangles[range.clone()].iter().zip(&uv1[range]) {
            let triangle = std::array::from_fn(|corner| {
                let v = vertices[corner];
                let uv = uvs[corner];
                *index
                    .entry((v, uv.x.to_bits(), uv.y.to_bits()))
                    .or_insert_with(|| {
                        let v = v as usize;
                        split.positions.push(scene.positions[v]);
                        split.normals.push(scene.normals[v]);
                        split.uvs.push(scene.uvs[v]);
                        split.vertex_material.push(scene.vertex_material[v]);
                        if let (Some(to), Some(from)) = (&mut split.tangents, &scene.tangents) {
                            to.push(from[v]);
                        }
                        lightmap.push(uv);
                        split.positions.len() as u32 - 1
                    })
            });
            split.triangles.push(triangle);
        }
        split.objects.push(crate::scene::Object {
            name: object.name.clone(),
            vertices: first..split.positions.len() as u32,
            triangles: object.triangles.clone(),
        });
    }
    split.lightmap_uvs = Some(lightmap);
    split
}

/// A texel bake's AO as an 8-bit grey PNG, linear (glTF's occlusion is linear, read from R),
/// rows as the relit lightmap's (row 0 is v = 0 of TEXCOORD_1).
pub(super) fn ao_png_bytes(ao: &[f32], width: u32, height: u32, output: &Path) -> Result<Vec<u8>> {
    let rows = crate::formats::openexr::image_rows(ao, width as usize, height as usize);
    let pixels: Vec<u8> = rows
        .iter()
        .map(|a| (a.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    crate::formats::png::encode(&pixels, width, height, image::ExtendedColorType::L8).map_err(
        |err| {
            Error::io(
                output,
                std::io::Error::other(format!("cannot encode the AO as PNG: {err}")),
            )
        },
    )
}
