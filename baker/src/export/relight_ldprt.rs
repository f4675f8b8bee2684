//! `prt-bake relight MESH FILE.ldprt`: an LDPRT bake ([`crate::bake::ldprt`]) lit by a rig on
//! a mesh of the same topology in any pose. Each vertex's frame is rebuilt from that mesh
//! ([`crate::bake::ldprt::frame`]), its lobes' axes turned into the world with it, and the
//! lobes lit as SH: radiance_c = albedo_c · Σ_k Σ_l c_l g_kcl Σ_m L_c,lm y_lm(R a_k).

use std::path::Path;

use crate::bake::ldprt::{frame, world_transfer};
use crate::export::relight::{Relit, write_vertex_ply};
use crate::formats::ldprt_file::{LdprtFile, topology_fingerprint};
use crate::light::{LightCoefficients, Rig};
use crate::scene::Scene;
use crate::support::error::Result;

/// Refuses a mesh whose vertex count or triangles differ from the baked mesh's.
pub fn check_topology(file: &LdprtFile, path: &Path, scene: &Scene) -> Result<()> {
    let count = scene.vertex_count();
    if count as u64 != file.vertex_count
        || topology_fingerprint(count, &scene.triangles) != file.topology
    {
        return Err(crate::Error::coefficient_file(
            path,
            format!(
                "baked for a mesh of {} vertices and topology {:016x}; {} has {count} vertices and \
                 topology {:016x} (a posed mesh must keep the baked mesh's vertices and triangles)",
                file.vertex_count,
                file.topology,
                scene.path.display(),
                topology_fingerprint(count, &scene.triangles)
            ),
        ));
    }
    Ok(())
}

/// Per-vertex linear RGB radiance of `file`'s lobes on `scene` (its pose) under `light`
/// (of the file's order, in the scene's frame).
pub fn ldprt_radiance(file: &LdprtFile, scene: &Scene, light: &LightCoefficients) -> Vec<[f32; 3]> {
    let frames = frame::vertex_frames(&scene.positions, &scene.normals, &scene.triangles);
    let transfer = world_transfer(file, &frames);
    let n = crate::math::sh::coeff_count(file.order as usize);
    let channels = file.channels as usize;
    let albedo = scene.vertex_albedo();
    albedo
        .iter()
        .enumerate()
        .map(|(v, a)| {
            let mut radiance = [0.0f32; 3];
            for (c, out) in radiance.iter_mut().enumerate() {
                let ch = if channels == 3 { c } else { 0 };
                let t = &transfer[(v * channels + ch) * n..][..n];
                let dot: f64 = t.iter().zip(&light.rgb[c]).map(|(t, l)| t * l).sum();
                *out = (f64::from(a[c]) * dot) as f32;
            }
            radiance
        })
        .collect()
}

/// Lights the LDPRT file `ldprt` on the mesh `mesh` (any pose of the baked mesh) with the rig
/// and writes a PLY to `output` atomically.
pub fn relight_ldprt(
    mesh: &Path,
    ldprt: &Path,
    rig: &Path,
    output: &Path,
    exposure: f64,
) -> Result<Relit> {
    let rig = Rig::load(rig)?;
    let file = LdprtFile::read(ldprt)?;
    let scene = Scene::load(mesh)?;
    check_topology(&file, ldprt, &scene)?;
    if crate::export::relight::image_format(output).is_some() {
        return Err(crate::Error::InvalidOption(format!(
            "{}: an LDPRT bake relights to a .ply mesh",
            output.display()
        )));
    }
    let output = crate::export::relight::relight_output(&scene, &[ldprt], &rig, output)?;
    let order = file.order as usize;
    let light = rig.project(order).in_scene_frame(file.up);
    let radiance = ldprt_radiance(&file, &scene, &light);
    let relit = Relit {
        vertex_count: scene.vertex_count(),
        lightmap: false,
        order,
        light_count: rig.lights.len(),
        max_radiance: 0.0,
        matrix: false,
    };
    let comment = format!(
        "prt-bake relight: mesh {}, LDPRT {} ({} lobes), lights {} (order {order}, window {})",
        mesh.display(),
        ldprt.display(),
        file.lobes,
        rig.path.display(),
        rig.window.name()
    );
    write_vertex_ply(&output, &scene, &radiance, exposure, comment, relit)
}
