//! `prt-bake relight CHARACTER FILE.ldprt --pose P --probes PROBES.prt`: a posed LDPRT mesh (a
//! skinned character, docs/guides/characters.md) lit through the transfer probes of the scene
//! it walks through (docs/guides/probes.md): the probes' incident radiance at its position,
//! turned into the character's own frame, lights its lobes turned with the pose.
//!
//! A rigid object's light is turned by the object's rotation (`relight_rigid`); a character's
//! lobes are already turned into its file's frame by the pose, so its light is only turned
//! from the probes' up axis to the character's (a glTF character is y-up, a room z-up). The
//! position is the centre of the posed mesh's bounding box, in the probes' frame, so the
//! light follows the character as the animation carries it through the room.

use std::path::Path;

use glam::{DMat3, DVec3, Vec3};

use crate::export::probe_field::ProbeField;
use crate::export::relight::{Relit, write_vertex_ply};
use crate::export::relight_ldprt::{ldprt_radiance_axes, load_posed_as_baked, pose_axes};
use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::ldprt_file::LdprtFile;
use crate::light::{LightCoefficients, Rig};
use crate::math::sh::rotation::ShRotation;
use crate::scene::{Pose, Scene, Up};
use crate::support::error::{Error, Result};

/// The rotation taking directions of a frame with `from` up into one with `to` up.
fn between(from: Up, to: Up) -> DMat3 {
    to.from_z_up() * from.from_z_up().transpose()
}

/// The centre of `scene`'s bounding box (its own frame) in the frame of `probes_up`.
pub fn character_position(scene: &Scene, probes_up: Up) -> Vec3 {
    let (lo, hi) = scene.bounds();
    let centre = DVec3::from((lo + hi) * 0.5);
    (between(scene.up, probes_up) * centre).as_vec3()
}

/// The light a character posed as `scene` receives in its own frame at `position` (the
/// probes' frame; [`character_position`] if `None`), from `light` in the probes' frame.
pub fn character_light(
    field: &ProbeField,
    probes_up: Up,
    scene: &Scene,
    position: Option<Vec3>,
    light: &LightCoefficients,
) -> (Vec3, LightCoefficients) {
    let at = position.unwrap_or_else(|| character_position(scene, probes_up));
    let incident = field.incident(at, light, true);
    if scene.up == probes_up {
        return (at, incident);
    }
    let turn = ShRotation::from_matrix(incident.order(), between(probes_up, scene.up));
    (at, incident.rotated(&turn))
}

/// Per-vertex linear RGB radiance of `file`'s lobes (world axes `axes`, [`pose_axes`]) on the
/// posed `scene`, lit through the probes ([`character_light`]); and where it was lit.
pub fn character_radiance(
    file: &LdprtFile,
    (scene, axes): (&Scene, &[DVec3]),
    (field, probes_up): (&ProbeField, Up),
    position: Option<Vec3>,
    light: &LightCoefficients,
) -> (Vec3, Vec<[f32; 3]>) {
    let (at, local) = character_light(field, probes_up, scene, position, light);
    (at, ldprt_radiance_axes(file, scene, axes, &local))
}

/// The probes a character is lit through, and what it is.
pub struct CharacterPlacement<'a> {
    pub probes: &'a Path,
    /// Its position in the probes' frame; the centre of the posed mesh's bounds if `None`.
    pub position: Option<Vec3>,
}

/// Lights the LDPRT file `ldprt` on `mesh` in `pose` through the probes into the PLY
/// `output` (the posed mesh in its own frame); returns the summary and where it was lit.
pub fn relight_ldprt_probes(
    (mesh, pose): (&Path, &Pose),
    (ldprt, rig): (&Path, &Path),
    placement: &CharacterPlacement,
    output: &Path,
    exposure: f64,
) -> Result<(Relit, Vec3)> {
    let rig = Rig::load(rig)?;
    let file = LdprtFile::read(ldprt)?;
    let (scene, warnings) = load_posed_as_baked(&file, ldprt, mesh, pose)?;
    for warning in warnings {
        eprintln!("warning: {}: {warning}", mesh.display());
    }
    let probe_file = CoefficientFile::read(placement.probes)?;
    let field = ProbeField::new(&probe_file)
        .map_err(|message| Error::coefficient_file(placement.probes, message))?;
    let order = file.order as usize;
    let bake = format!("the LDPRT bake {}", ldprt.display());
    field.require_order(placement.probes, order, &bake)?;
    crate::export::relight::refuse_image_output(output, "an LDPRT bake relights to a .ply mesh")?;
    let files = [ldprt, placement.probes];
    let output = crate::export::relight::relight_output(&scene, &files, &rig, output)?;
    let probes_up = probe_file.header.up;
    let light = rig.project(order).in_scene_frame(probes_up);
    let axes = pose_axes(&file, mesh, &scene)?;
    let (at, radiance) = character_radiance(
        &file,
        (&scene, &axes),
        (&field, probes_up),
        placement.position,
        &light,
    );
    let comment = format!(
        "prt-bake relight: mesh {} (pose {pose}), LDPRT {} ({} lobes), probes {} at ({}, {}, {}), \
         lights {} (order {order})",
        mesh.display(),
        ldprt.display(),
        file.lobes,
        placement.probes.display(),
        at.x,
        at.y,
        at.z,
        rig.path.display()
    );
    let relit = Relit::vertices(scene.vertex_count(), order, &rig);
    Ok((
        write_vertex_ply(&output, &scene, &radiance, exposure, comment, relit)?,
        at,
    ))
}
