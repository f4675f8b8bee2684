//! A skinned glTF lit by its LDPRT bake (`prt-view SKINNED.glb FILE.ldprt [--pose P]`,
//! docs/guides/characters.md): each frame the mesh is posed at the animation's time (looping;
//! fixed by `--pose`) and its lobes turned with the skin, both by the baker's own code, as
//! `prt-bake relight SKINNED.glb FILE.ldprt --pose P` does:
//!
//! * [`Scene::load_posed`] poses the mesh by linear-blend skinning;
//! * [`pose_axes`] takes each vertex's baked frame to the bind space and skins it (the frame
//!   rule of docs/reference/gltf.md), giving every lobe's world axis;
//! * [`world_transfer_axes`] rotates each lobe's zonal harmonics to that axis: a per-vertex
//!   SH transfer vector in the scene's frame.
//!
//! That vector is uploaded as the transfer of an ordinary vertex bake, with the posed
//! positions and normals, and the renderer's tested vertex-PRT path dots it with the turning
//! light and multiplies by the albedo: the same sum as relight's `ldprt_radiance_axes`,
//! in f32 (tests/ldprt.rs holds the two to 1 code). Posing is done on the CPU because the
//! meshes are small and the baker's skinning is then the only skinning: the test tube (2328
//! vertices, order 4, 3 lobes) costs 1.8 ms a frame in a release build on 2 cores (measured
//! by tests/ldprt.rs), reading the glb twice included (`pose_axes` reads the baked pose
//! again). The normal lines (N) stay those of the first frame's pose.
//!
//! A character walking through a probe-baked scene (`prt-view SCENE FILE --probes P
//! --character SKINNED.glb --character-ldprt FILE.ldprt`) is posed the same way and lit on the
//! CPU by [`Skinned::lit_through_probes`] (relight --probes's own function), then drawn by the
//! probe scene's mover pipeline (probe_scene.rs) beside the scene.

use std::path::{Path, PathBuf};

use prt_baker::bake::ldprt::world_transfer_axes;
use prt_baker::export::probe_field::ProbeField;
use prt_baker::export::relight_ldprt::{load_posed_as_baked, pose_axes};
use prt_baker::export::relight_ldprt_probes::character_radiance;
use prt_baker::formats::ldprt_file::LdprtFile;
use prt_baker::light::LightCoefficients;
use prt_baker::scene::{Pose, Up};
use prt_baker::{BakeOptions, CoefficientFile, Scene};

use crate::bake::{Bake, turn_to_z_up};
use crate::error::{Error, Result};

/// The mesh, its LDPRT bake and which pose each frame shows.
#[derive(Clone, Debug)]
pub struct Skinned {
    mesh: PathBuf,
    ldprt: PathBuf,
    file: LdprtFile,
    /// The glTF's first animation and its length in seconds (its last keyframe time).
    animation: Option<(String, f32)>,
    /// `--pose`: every frame shows this pose.
    pub frozen: Option<Pose>,
}

/// One frame's posed mesh (turned to z-up, as [`Bake`] turns scenes) and its transfer.
pub struct Posed {
    pub scene: Scene,
    pub transfer: Vec<f32>,
}

impl Skinned {
    /// Reads the LDPRT file and the glTF's first animation; the bake returned shows the
    /// first frame's pose.
    pub fn load(mesh: &Path, ldprt: &Path, frozen: Option<Pose>) -> Result<(Skinned, Bake)> {
        let skinned = Skinned::open(mesh, ldprt, frozen)?;
        let (scene, transfer) = skinned.posed_in_scene_frame(&skinned.pose_at(0.0))?;
        let bake = Bake::new(
            scene.clone(),
            skinned.coefficient_file(&scene, transfer),
            ldprt,
        )?;
        Ok((skinned, bake))
    }

    /// Reads the LDPRT file and the glTF's first animation, and checks the mesh's rest pose
    /// against the file's topology.
    pub fn open(mesh: &Path, ldprt: &Path, frozen: Option<Pose>) -> Result<Skinned> {
        let file = LdprtFile::read(ldprt)?;
        load_posed_as_baked(&file, ldprt, mesh, &Pose::Rest)?;
        Ok(Skinned {
            mesh: mesh.to_path_buf(),
            ldprt: ldprt.to_path_buf(),
            file,
            animation: first_animation(mesh)?,
            frozen,
        })
    }

    /// The baked order.
    pub fn order(&self) -> usize {
        self.file.order as usize
    }

    /// The mesh's triangles (the same in every pose).
    pub fn triangles(&self) -> Result<Vec<[u32; 3]>> {
        Ok(
            load_posed_as_baked(&self.file, &self.ldprt, &self.mesh, &Pose::Rest)?
                .0
                .triangles,
        )
    }

    /// The mesh in `pose` walking through a probe-baked scene (docs/guides/characters.md):
    /// its vertices turned to z-up and their linear radiance, lit by the probes' incident
    /// radiance at the centre of the posed bounds (`light` in the probes' z-up frame), as
    /// `prt-bake relight MESH FILE --pose P --probes PROBES` lights them
    /// ([`character_radiance`]).
    pub fn lit_through_probes(
        &self,
        pose: &Pose,
        field: &ProbeField,
        light: &LightCoefficients,
    ) -> Result<(Vec<glam::Vec3>, Vec<[f32; 3]>)> {
        let (mut scene, _warnings) =
            load_posed_as_baked(&self.file, &self.ldprt, &self.mesh, pose)?;
        let axes = pose_axes(&self.file, &self.mesh, &scene)?;
        let (_, radiance) =
            character_radiance(&self.file, (&scene, &axes), (field, Up::Z), None, light);
        let up = scene.up;
        turn_to_z_up(&mut scene, up);
        Ok((scene.positions, radiance))
    }

    /// The pose at `seconds` since the start: `--pose` if given, else the first animation
    /// looping, else the rest pose.
    pub fn pose_at(&self, seconds: f64) -> Pose {
        if let Some(pose) = &self.frozen {
            return pose.clone();
        }
        match &self.animation {
            Some((name, length)) if *length > 0.0 => Pose::Time {
                animation: name.clone(),
                seconds: seconds.rem_euclid(f64::from(*length)) as f32,
            },
            _ => Pose::Rest,
        }
    }

    /// The mesh in `pose`, turned to z-up, and its transfer there.
    pub fn posed(&self, pose: &Pose) -> Result<Posed> {
        let (mut scene, transfer) = self.posed_in_scene_frame(pose)?;
        turn_to_z_up(&mut scene, self.file.up);
        Ok(Posed { scene, transfer })
    }

    fn posed_in_scene_frame(&self, pose: &Pose) -> Result<(Scene, Vec<f32>)> {
        let (scene, _warnings) = load_posed_as_baked(&self.file, &self.ldprt, &self.mesh, pose)?;
        let axes = pose_axes(&self.file, &self.mesh, &scene)?;
        let transfer = world_transfer_axes(&self.file, &axes)
            .into_iter()
            .map(|t| t as f32)
            .collect();
        Ok((scene, transfer))
    }

    /// A vector-transfer file of the file's order and channels holding `transfer`.
    fn coefficient_file(&self, scene: &Scene, transfer: Vec<f32>) -> CoefficientFile {
        let options = BakeOptions {
            order: self.file.order as usize,
            samples: self.file.samples_per_vertex,
            mode: self.file.mode,
            bounces: self.file.bounces,
            seed: self.file.seed,
            ..BakeOptions::default()
        };
        CoefficientFile::from_bake(
            scene,
            &prt_baker::Transfer {
                options,
                channels: self.file.channels as usize,
                receiver_count: scene.vertex_count(),
                coefficients: transfer,
                visibility: Vec::new(),
                backend: prt_baker::trace::Backend::None,
                rays_cast: 0,
                seconds: 0.0,
                hit_cache_bytes: None,
            },
        )
    }
}

/// The glTF's first animation: its name (its index if unnamed) and its last keyframe time
/// (glTF requires the min and max of an animation's input accessors).
fn first_animation(mesh: &Path) -> Result<Option<(String, f32)>> {
    let document = gltf::Gltf::open(mesh)
        .map_err(|err| Error::InvalidOption(format!("{}: {err}", mesh.display())))?;
    let Some(animation) = document.animations().next() else {
        return Ok(None);
    };
    let length = animation
        .samplers()
        .filter_map(|s| s.input().max())
        .filter_map(|max| max.get(0).and_then(|v| v.as_f64()))
        .fold(0.0f64, f64::max);
    let name = animation
        .name()
        .map_or_else(|| animation.index().to_string(), str::to_owned);
    Ok(Some((name, length as f32)))
}
