//! `prt-bake relight SCENE FILE.prt --lights RIG --occluder OCC.prt --at X,Y,Z [--turn …] …`:
//! a baked scene darkened by moving occluders (docs/guides/occluders.md).
//!
//! Each occluder is a sphere set ([`crate::formats::occluder_file`]) placed in the scene. Per
//! receiver (vertex or texel) within reach of a sphere, the spheres' visibility V is built in SH
//! ([`crate::math::occlusion`]: closed-form caps, multiplied by triple products), and the
//! receiver reflects ∫ L·T·V = Σ_jk T_j M_jk V_k with M_jk = Σ_i Γ_ijk L_i, M computed once per
//! light and channel: the triple product of light, transfer and visibility, not T·L times a
//! scalar occlusion. Receivers out of every sphere's reach keep Σ T_j L_j.

use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3, Vec3};
use rayon::prelude::*;

use crate::export::relight::{
    PER_VERTEX_TO_MESH, Relit, image_format, lightmap_image, read_with_cpca, refuse_image_output,
    write_vertex_ply,
};
use crate::formats::coefficient_file::{CoefficientFile, LightmapBlock};
use crate::formats::header::TransferKind;
use crate::formats::occluder_file::OccluderFile;
use crate::light::{LightCoefficients, Rig};
use crate::math::occlusion::{Occlusion, Sphere};
use crate::math::sh::coeff_count;
use crate::scene::Scene;
use crate::support::error::{Error, Result};

/// One occluder placed in the scene: its file, position and rotation.
#[derive(Clone, Debug)]
pub struct PlacedOccluder {
    pub file: PathBuf,
    pub position: Vec3,
    pub rotation: DQuat,
}

/// A light prepared for receivers seen through occluders: per channel the matrix
/// M_jk = Σ_i Γ_ijk L_i, and the light itself for receivers no sphere reaches.
pub struct OccludedLight {
    occlusion: Occlusion,
    light: LightCoefficients,
    matrices: [Vec<f64>; 3],
}

impl OccludedLight {
    pub fn new(light: &LightCoefficients) -> OccludedLight {
        OccludedLight::with_visibility_order(light, light.order())
    }

    /// [`OccludedLight::new`] with visibility projected at `visibility_order` (≥ the light's):
    /// M is then n² × k². On the Cornell oracle (tests/occluder_oracles.rs) order-8 visibility
    /// under order-4 transfer changed the error by under 3 %: the transfer's truncation, not
    /// the visibility's, dominates, so `new` keeps the file's order.
    pub fn with_visibility_order(
        light: &LightCoefficients,
        visibility_order: usize,
    ) -> OccludedLight {
        let occlusion = Occlusion::new(visibility_order);
        let n = coeff_count(light.order());
        let k = coeff_count(visibility_order);
        let matrices = light.rgb.clone().map(|l| {
            let mut padded = l.clone();
            padded.resize(k, 0.0);
            let full = occlusion.gaunt().light_matrix(&padded);
            // Rows j < n² (the transfer's), all k² columns (the visibility's).
            full[..n * k].to_vec()
        });
        OccludedLight {
            occlusion,
            light: light.clone(),
            matrices,
        }
    }

    /// The light a receiver of albedo 1 reflects per channel: `transfer[c]` is channel c's
    /// transfer (n² floats), the receiver at `point` with normal `normal`, `spheres` placed.
    pub fn radiance(
        &self,
        transfer: [&[f32]; 3],
        point: Vec3,
        normal: Vec3,
        spheres: &[Sphere],
    ) -> [f64; 3] {
        let n = coeff_count(self.light.order());
        let k = coeff_count(self.occlusion.order());
        let mut v = vec![0.0; k];
        let seen = self
            .occlusion
            .visibility(point.as_dvec3(), normal.as_dvec3(), spheres, &mut v);
        std::array::from_fn(|c| {
            let t = transfer[c];
            if !seen {
                return t
                    .iter()
                    .zip(&self.light.rgb[c])
                    .map(|(t, l)| f64::from(*t) * l)
                    .sum();
            }
            let m = &self.matrices[c];
            (0..n)
                .map(|j| {
                    let row = &m[j * k..(j + 1) * k];
                    f64::from(t[j]) * row.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>()
                })
                .sum()
        })
    }

    /// [`OccludedLight::radiance`] of every receiver of a vector `file` (vertices or texels)
    /// at `points` with `normals`, times `albedo`.
    pub fn file_radiance(
        &self,
        file: &CoefficientFile,
        (points, normals): (&[Vec3], &[Vec3]),
        albedo: &[Vec3],
        spheres: &[Sphere],
    ) -> Vec<[f32; 3]> {
        let channels = file.header.channels as usize;
        (0..points.len())
            .into_par_iter()
            .map(|v| {
                let t = |c: usize| file.vertex(v, if channels == 3 { c } else { 0 });
                let r = self.radiance([t(0), t(1), t(2)], points[v], normals[v], spheres);
                std::array::from_fn(|c| (r[c] * f64::from(albedo[v][c])) as f32)
            })
            .collect()
    }
}

/// The spheres of every occluder, placed, and their count for the summary.
pub fn place_all(occluders: &[PlacedOccluder]) -> Result<Vec<Sphere>> {
    let mut spheres = Vec::new();
    for o in occluders {
        let file = OccluderFile::read(&o.file)?;
        spheres.extend(file.placed(o.position.as_dvec3(), o.rotation));
    }
    Ok(spheres)
}

/// Relights the vector bake `coefficients` of `scene` under `rig` darkened by `occluders`,
/// into a PLY (vertex bakes) or a PNG/EXR lightmap image (texel bakes).
pub fn relight_occluded(
    (scene_path, coefficients): (&Path, &Path),
    rig: &Path,
    occluders: &[PlacedOccluder],
    output: &Path,
    exposure: f64,
) -> Result<Relit> {
    let rig = Rig::load(rig)?;
    let (file, _) = read_with_cpca(coefficients)?;
    if file.header.transfer != TransferKind::Vector || file.probes.is_some() {
        return Err(Error::InvalidOption(format!(
            "{}: --occluder darkens diffuse transfer vectors (a vertex or lightmap bake)",
            coefficients.display()
        )));
    }
    let spheres = place_all(occluders)?;
    let scene = file.load_scene(scene_path)?;
    let mut files = vec![coefficients];
    files.extend(occluders.iter().map(|o| o.file.as_path()));
    let open_output = || crate::export::relight::relight_output(&scene, &files, &rig, output);
    let order = file.header.order as usize;
    let light = OccludedLight::new(&rig.project(order).in_scene_frame(file.header.up));
    let relit = Relit {
        vertex_count: 0,
        lightmap: file.lightmap.is_some(),
        order,
        light_count: rig.lights.len(),
        max_radiance: 0.0,
        matrix: false,
    };
    if let Some(block) = &file.lightmap {
        file.check_lightmap_scene(coefficients, &scene)?;
        let Some(format) = image_format(output) else {
            return Err(Error::InvalidOption(format!(
                "{}: a lightmap bake relights to a .png or .exr image",
                output.display()
            )));
        };
        let output_policy = open_output()?;
        let (points, normals) = texel_points(&scene, block);
        let ones = vec![Vec3::ONE; points.len()];
        let radiance = light.file_radiance(&file, (&points, &normals), &ones, &spheres);
        output_policy.write(&lightmap_image(block, &radiance, format, output, exposure)?)?;
        return Ok(Relit {
            vertex_count: points.len(),
            max_radiance: radiance.iter().flatten().fold(0.0, |a, &b| a.max(b)),
            ..relit
        });
    }
    file.check_scene(coefficients, &scene)?;
    let file = file.spread_to_scene(coefficients, &scene)?;
    refuse_image_output(output, PER_VERTEX_TO_MESH)?;
    let output = open_output()?;
    let albedo = scene.vertex_albedo();
    let geometry = (&scene.positions[..], &scene.normals[..]);
    let radiance = light.file_radiance(&file, geometry, &albedo, &spheres);
    let comment = format!(
        "prt-bake relight: scene {}, transfer {}, lights {}, {} occluder(s), {} sphere(s)",
        scene_path.display(),
        coefficients.display(),
        rig.path.display(),
        occluders.len(),
        spheres.len()
    );
    let relit = Relit {
        vertex_count: scene.vertex_count(),
        ..relit
    };
    write_vertex_ply(&output, &scene, &radiance, exposure, comment, relit)
}

/// Texels searched around an empty (padding) texel for a covered one to stand for it.
const PADDING_REACH: i64 = 4;

/// Per texel of a lightmap bake, the surface point and normal it was baked at (recomputed from
/// the stored UVs as the bake did). Padding texels, which hold dilated transfer, take the
/// point of the nearest covered texel within [`PADDING_REACH`], so a shadow does not stop
/// short of a chart's edge under bilinear filtering.
pub fn texel_points(scene: &Scene, block: &LightmapBlock) -> (Vec<Vec3>, Vec<Vec3>) {
    let atlas = crate::bake::lightmap::Atlas::of_block(block);
    let texels = crate::bake::lightmap::Texels::rasterise(scene, &atlas);
    let (w, h) = (i64::from(block.width), i64::from(block.height));
    let covered = |x: i64, y: i64| {
        (0..w).contains(&x) && (0..h).contains(&y) && texels.valid[(y * w + x) as usize]
    };
    let mut points = texels.positions.clone();
    let mut normals = texels.normals.clone();
    for t in 0..(w * h) {
        let (x, y) = (t % w, t / w);
        if covered(x, y) || !block.dilated[t as usize] {
            continue;
        }
        let nearest = (-PADDING_REACH..=PADDING_REACH)
            .flat_map(|dy| (-PADDING_REACH..=PADDING_REACH).map(move |dx| (dx, dy)))
            .filter(|&(dx, dy)| covered(x + dx, y + dy))
            .min_by_key(|&(dx, dy)| (dx * dx + dy * dy, dy, dx));
        if let Some((dx, dy)) = nearest {
            let s = ((y + dy) * w + x + dx) as usize;
            points[t as usize] = texels.positions[s];
            normals[t as usize] = texels.normals[s];
        }
    }
    (points, normals)
}

/// The world position of `spheres`' centres, for the summary line.
pub fn describe(spheres: &[Sphere]) -> String {
    let DVec3 { x, y, z } = spheres.iter().map(|s| s.centre).sum::<DVec3>() / spheres.len() as f64;
    format!("{} sphere(s) about ({x:.3}, {y:.3}, {z:.3})", spheres.len())
}
