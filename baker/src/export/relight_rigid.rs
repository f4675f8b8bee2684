//! `prt-bake relight OBJECT OBJECT.prt --lights RIG --probes PROBES.prt --at X,Y,Z [--turn …]`:
//! a rigid object, baked alone in its own frame, placed in a probe-baked scene and lit there
//! (docs/guides/probes.md, "Rigid objects that move"): the probes' incident radiance at its position,
//! turned into its frame, through its own transfer. Written as `relight` writes a vertex
//! bake: a PLY of the object in its own frame, with per-vertex radiance.

use std::path::Path;

use glam::{DQuat, Vec3};

use crate::export::probe_field::{ProbeField, into_object_frame};
use crate::export::relight::{Relit, vertex_radiance, write_vertex_ply};
use crate::formats::coefficient_file::CoefficientFile;
use crate::light::Rig;
use crate::support::error::{Error, Result};

/// Where the object stands: its position in the probes' scene and its rotation.
pub struct Placement<'a> {
    pub probes: &'a Path,
    pub position: Vec3,
    pub rotation: DQuat,
}

/// Relights the object `scene` (its vector bake `coefficients`) at `placement`, lit by `rig`
/// through the probes, into the PLY `output`.
pub fn relight_rigid(
    (scene, coefficients): (&Path, &Path),
    rig: &Path,
    placement: &Placement,
    output: &Path,
    exposure: f64,
) -> Result<Relit> {
    let rig_path = rig;
    let rig = Rig::load(rig)?;
    let object = CoefficientFile::read(coefficients)?;
    let scene_path = scene;
    let scene = object.load_scene(scene)?;
    object.check_scene(coefficients, &scene)?;
    let probe_file = CoefficientFile::read(placement.probes)?;
    let field = ProbeField::new(&probe_file)
        .map_err(|message| Error::coefficient_file(placement.probes, message))?;
    let order = object.header.order as usize;
    let bake = format!("the object {}", coefficients.display());
    field.require_order(placement.probes, order, &bake)?;
    let files = [coefficients, placement.probes];
    let output = crate::export::relight::relight_output(&scene, &files, &rig, output)?;
    // The rig, turned to the probes' scene's up axis; the incident radiance there, turned
    // into the object's frame.
    let light = rig.project(order).in_scene_frame(probe_file.header.up);
    let incident = field.incident(placement.position, &light, true);
    let local = into_object_frame(&incident, placement.rotation);
    let albedo = scene.vertex_albedo();
    let radiance = vertex_radiance(&object, &albedo, &local);
    let (p, q) = (placement.position, placement.rotation);
    let comment = format!(
        "prt-bake relight: rigid object {}, transfer {}, probes {} at ({}, {}, {}) turned by \
         quaternion ({}, {}, {}, {}), lights {} (order {order})",
        scene_path.display(),
        coefficients.display(),
        placement.probes.display(),
        p.x,
        p.y,
        p.z,
        q.x,
        q.y,
        q.z,
        q.w,
        rig_path.display()
    );
    let relit = Relit::vertices(scene.vertex_count(), order, &rig);
    write_vertex_ply(&output, &scene, &radiance, exposure, comment, relit)
}
