//! `prt-bake export`: a coefficient file and its scene as NumPy arrays, for analysis and for
//! checking a bake against an independent reference.

use std::path::Path;

use crate::coefficient_file::CoefficientFile;
use crate::error::Result;
use crate::npz;
use crate::scene::Scene;
use crate::sh;

/// Writes `positions` (V,3), `normals` (V,3), `albedo` (V,3, linear Kd × texture),
/// `transfer` (V, channels, n²), `uv` (V,2, v up from the image's bottom, as OBJ) where the
/// scene has texture coordinates, and, where the file has them, `ao` (V,) and `bent_normal`
/// (V,3), and for adaptive bakes `rays` (V,; per-vertex rays cast, exact below 2^24) and
/// `error_estimate` (V,), all float32 in the file's vertex order; and `triangles` (F,3)
/// uint32 vertex indices. The coefficient file must have been baked for this scene.
///
/// A lightmap (texel) bake is written as [`export_lightmap_npz`] describes.
pub fn export_npz(coefficients: &Path, scene: &Path, output: &Path) -> Result<()> {
    let file = CoefficientFile::read(coefficients)?;
    let scene = Scene::load(scene)?;
    if file.lightmap.is_some() {
        return export_lightmap_npz(coefficients, &file, &scene, output);
    }
    file.check_scene(coefficients, &scene)?;
    let mut inputs = scene.input_files();
    inputs.push(coefficients.to_path_buf());
    let output = crate::output::Output::new(output, &inputs)?;
    let v = scene.vertex_count();
    let flat = |values: &[glam::Vec3]| {
        values
            .iter()
            .flat_map(|x| x.to_array())
            .collect::<Vec<f32>>()
    };
    let positions = flat(&scene.positions);
    let normals = flat(&scene.normals);
    let albedo = flat(&scene.vertex_albedo());
    let header = &file.header;
    let ao = file.ao.clone();
    let bent_normal = file.bent_normal.as_deref().map(flat);
    let mut arrays = vec![
        npz::Array {
            name: "positions",
            shape: vec![v, 3],
            data: &positions,
        },
        npz::Array {
            name: "normals",
            shape: vec![v, 3],
            data: &normals,
        },
        npz::Array {
            name: "albedo",
            shape: vec![v, 3],
            data: &albedo,
        },
        npz::Array {
            name: "transfer",
            shape: vec![
                v,
                header.channels as usize,
                sh::coeff_count(header.order as usize),
            ],
            data: &file.coefficients,
        },
    ];
    if let Some(ao) = &ao {
        arrays.push(npz::Array {
            name: "ao",
            shape: vec![v],
            data: ao,
        });
    }
    if let Some(bent_normal) = &bent_normal {
        arrays.push(npz::Array {
            name: "bent_normal",
            shape: vec![v, 3],
            data: bent_normal,
        });
    }
    let rays: Option<Vec<f32>> = file
        .rays
        .as_ref()
        .map(|r| r.iter().map(|&r| r as f32).collect());
    if let Some(rays) = &rays {
        arrays.push(npz::Array {
            name: "rays",
            shape: vec![v],
            data: rays,
        });
    }
    if let Some(errors) = &file.error_estimate {
        arrays.push(npz::Array {
            name: "error_estimate",
            shape: vec![v],
            data: errors,
        });
    }
    // A scene whose every uv is (0, 0) has none (OBJ without `vt`, glTF without TEXCOORD_0).
    let uv: Vec<f32> = scene.uvs.iter().flat_map(|uv| uv.to_array()).collect();
    if uv.iter().any(|&x| x != 0.0) {
        arrays.push(npz::Array {
            name: "uv",
            shape: vec![v, 2],
            data: &uv,
        });
    }
    let triangles: Vec<u32> = scene.triangles.iter().flatten().copied().collect();
    let indices = [npz::IndexArray {
        name: "triangles",
        shape: vec![scene.triangles.len(), 3],
        data: &triangles,
    }];
    output.write(&npz::to_bytes(&arrays, &indices, &[])?)
}

/// A texel bake of a W×H lightmap: `texel_positions` (H,W,3), `texel_normals` (H,W,3) (the
/// points the texels were baked at, recomputed from the stored UVs exactly as the bake did),
/// `texel_valid` (H,W, bool: baked), `texel_dilated` (H,W, bool: padding filled from baked
/// neighbours), `transfer` (H,W,channels,n²), `uv1` (triangles,3,2: each
/// triangle corner's lightmap UV in [0, 1]) and, where stored, `ao` (H,W) and
/// `bent_normal` (H,W,3). Row y of the arrays is v ∈ [y/H, (y+1)/H].
fn export_lightmap_npz(
    path: &Path,
    file: &CoefficientFile,
    scene: &Scene,
    output: &Path,
) -> Result<()> {
    let block = file.check_lightmap_scene(path, scene)?;
    let mut inputs = scene.input_files();
    inputs.push(path.to_path_buf());
    let output = crate::output::Output::new(output, &inputs)?;
    let (w, h) = (block.width as usize, block.height as usize);
    let atlas = crate::lightmap::Atlas {
        width: block.width,
        height: block.height,
        uv1: block.uv1.clone(),
        source: block.source,
        texel_size: (block.texel_size > 0.0).then_some(block.texel_size),
    };
    let texels = crate::lightmap::Texels::rasterise(scene, &atlas);
    let flat = |values: &[glam::Vec3]| {
        values
            .iter()
            .flat_map(|x| x.to_array())
            .collect::<Vec<f32>>()
    };
    let positions = flat(&texels.positions);
    let normals = flat(&texels.normals);
    let uv1: Vec<f32> = block
        .uv1
        .iter()
        .flatten()
        .flat_map(|p| p.to_array())
        .collect();
    let bent_normal = file.bent_normal.as_deref().map(flat);
    let header = &file.header;
    let mut arrays = vec![
        npz::Array {
            name: "texel_positions",
            shape: vec![h, w, 3],
            data: &positions,
        },
        npz::Array {
            name: "texel_normals",
            shape: vec![h, w, 3],
            data: &normals,
        },
        npz::Array {
            name: "transfer",
            shape: vec![
                h,
                w,
                header.channels as usize,
                sh::coeff_count(header.order as usize),
            ],
            data: &file.coefficients,
        },
        npz::Array {
            name: "uv1",
            shape: vec![block.uv1.len(), 3, 2],
            data: &uv1,
        },
    ];
    if let Some(ao) = &file.ao {
        arrays.push(npz::Array {
            name: "ao",
            shape: vec![h, w],
            data: ao,
        });
    }
    if let Some(bent_normal) = &bent_normal {
        arrays.push(npz::Array {
            name: "bent_normal",
            shape: vec![h, w, 3],
            data: bent_normal,
        });
    }
    let masks = [
        npz::BoolArray {
            name: "texel_valid",
            shape: vec![h, w],
            data: &block.valid,
        },
        npz::BoolArray {
            name: "texel_dilated",
            shape: vec![h, w],
            data: &block.dilated,
        },
    ];
    output.write(&npz::to_bytes(&arrays, &[], &masks)?)
}
