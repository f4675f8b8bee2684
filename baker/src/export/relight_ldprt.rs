//! `prt-bake relight MESH FILE.ldprt`: an LDPRT bake ([`crate::bake::ldprt`]) lit by a rig on
//! a mesh of the same topology in any pose. Each vertex's frame is rebuilt from that mesh
//! ([`crate::bake::ldprt::frame`]), its lobes' axes turned into the world with it, and the
//! lobes lit as SH: radiance_c = albedo_c · Σ_k Σ_l c_l g_kcl Σ_m L_c,lm y_lm(R a_k).
//!
//! A bake of a skinned glTF, lit on a pose of a skinned glTF, follows the skin instead
//! ([`pose_axes`]): each vertex's frame is taken from the baked pose into the bind space,
//! its normal and tangent skinned as runtimes skin NORMAL and TANGENT, so the command line
//! and the runtimes agree to float rounding.

use std::path::Path;

use glam::DVec3;

use crate::bake::ldprt::{bind_frames, frame, frame_axes, skinned_frames, world_transfer_axes};
use crate::export::relight::{Relit, write_vertex_ply};
use crate::formats::ldprt_file::{LdprtFile, topology_fingerprint};
use crate::light::{LightCoefficients, Rig};
use crate::scene::{Pose, Scene};
use crate::support::error::Result;

/// Loads `mesh` in `pose` as the LDPRT file `file` (read from `path`) saw it: without the
/// back sheets of its glTF `doubleSided` objects where the file was baked without them
/// (`bake --double-sided off`; Blender's exporter marks materials double-sided by default).
/// Refuses a mesh whose vertex count or triangles differ from the baked mesh's either way.
pub fn load_posed_as_baked(
    file: &LdprtFile,
    path: &Path,
    mesh: &Path,
    pose: &Pose,
) -> Result<(Scene, Vec<String>)> {
    let (mut scene, warnings) = Scene::load_posed(mesh, None, pose)?;
    let (count, topology) = (scene.vertex_count(), topology_of(&scene));
    if !same_topology(file, &scene) && scene.first_back_sheet().is_some() {
        scene.drop_back_sheets();
    }
    if !same_topology(file, &scene) {
        return Err(crate::Error::coefficient_file(
            path,
            format!(
                "baked for a mesh of {} vertices and topology {:016x}; {} has {count} vertices and \
                 topology {topology:016x} (a posed mesh must keep the baked mesh's vertices and \
                 triangles)",
                file.vertex_count,
                file.topology,
                scene.path.display(),
            ),
        ));
    }
    Ok((scene, warnings))
}

fn topology_of(scene: &Scene) -> u64 {
    topology_fingerprint(scene.vertex_count(), &scene.triangles)
}

fn same_topology(file: &LdprtFile, scene: &Scene) -> bool {
    scene.vertex_count() as u64 == file.vertex_count && topology_of(scene) == file.topology
}

/// Per-vertex linear RGB radiance of `file`'s lobes on `scene` (its pose) under `light`
/// (of the file's order, in the scene's frame).
pub fn ldprt_radiance(file: &LdprtFile, scene: &Scene, light: &LightCoefficients) -> Vec<[f32; 3]> {
    let frames = frame::vertex_frames(&scene.positions, &scene.normals, &scene.triangles);
    ldprt_radiance_axes(file, scene, &frame_axes(file, &frames), light)
}

/// The world axis of every lobe of `file` on `scene` (a pose of the baked mesh, read from
/// `mesh`): where the file was baked from a skinned glTF and `scene` is skinned, the baked
/// pose's frames (`mesh` read again in it) taken to the bind space and skinned to `scene`'s
/// pose ([`skinned_frames`]); otherwise each vertex's frame rebuilt from `scene`.
pub fn pose_axes(file: &LdprtFile, mesh: &Path, scene: &Scene) -> Result<Vec<DVec3>> {
    let frames = |s: &Scene| frame::vertex_frames(&s.positions, &s.normals, &s.triangles);
    let (Some(baked), Some(linear)) = (&file.pose, &scene.pose_linear) else {
        return Ok(frame_axes(file, &frames(scene)));
    };
    let pose: Pose = baked.parse().map_err(|problem| {
        crate::Error::scene(crate::support::error::Location::file(mesh), problem)
    })?;
    let (rest, _) = load_posed_as_baked(file, mesh, mesh, &pose)?;
    let rest_linear = rest.pose_linear.as_ref().unwrap_or(linear);
    let bind = bind_frames(&frames(&rest), rest_linear);
    Ok(frame_axes(file, &skinned_frames(&bind, linear)))
}

/// [`ldprt_radiance`] with the world axis of every lobe given ([`pose_axes`]).
pub fn ldprt_radiance_axes(
    file: &LdprtFile,
    scene: &Scene,
    axes: &[DVec3],
    light: &LightCoefficients,
) -> Vec<[f32; 3]> {
    let transfer = world_transfer_axes(file, axes);
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

/// Lights the LDPRT file `ldprt` on the mesh `mesh` (any pose of the baked mesh; a glTF in
/// `pose`) with the rig and writes a PLY to `output` atomically.
pub fn relight_ldprt(
    mesh: &Path,
    pose: &Pose,
    ldprt: &Path,
    rig: &Path,
    output: &Path,
    exposure: f64,
) -> Result<Relit> {
    let rig = Rig::load(rig)?;
    let file = LdprtFile::read(ldprt)?;
    let (scene, warnings) = load_posed_as_baked(&file, ldprt, mesh, pose)?;
    for warning in warnings {
        eprintln!("warning: {}: {warning}", mesh.display());
    }
    crate::export::relight::refuse_image_output(output, "an LDPRT bake relights to a .ply mesh")?;
    let output = crate::export::relight::relight_output(&scene, &[ldprt], &rig, output)?;
    let order = file.order as usize;
    let light = rig.project(order).in_scene_frame(file.up);
    let axes = pose_axes(&file, mesh, &scene)?;
    let radiance = ldprt_radiance_axes(&file, &scene, &axes, &light);
    let relit = Relit::vertices(scene.vertex_count(), order, &rig);
    let comment = format!(
        "prt-bake relight: mesh {} (pose {pose}), LDPRT {} ({} lobes), lights {} (order {order}, window {})",
        mesh.display(),
        ldprt.display(),
        file.lobes,
        rig.path.display(),
        rig.window.name()
    );
    write_vertex_ply(&output, &scene, &radiance, exposure, comment, relit)
}
