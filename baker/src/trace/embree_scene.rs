//! Building Embree's scenes from ours: the triangle meshes (cut-out triangles in a geometry of
//! their own, behind an alpha filter), the instances, and how a hit maps back to a triangle.
//! Kept apart from the tracer ([`super::embree`]), which only routes and casts rays.

use std::sync::Arc;

use embree_sys::{BuildQuality, CommittedScene, Device, SceneBuilder, SceneFlags};

use super::tracer::Hit;
use crate::scene::{Cutouts, Scene, world_normal};
use crate::support::error::{Error, Result};

/// Where hits point in the scene's triangles. A scene with cut-out triangles is two Embree
/// geometries, the opaque triangles (no filter: Embree's fast path) and the cut-out ones
/// (with an [`AlphaFilter`]); each lists its triangles' indices in the scene. Without cut-out
/// triangles there is one geometry, whose primitive ids are the triangle indices.
#[derive(Clone, Default)]
pub(super) struct TriangleIds {
    /// Per geometry id, its primitives' triangle indices; empty for the one-geometry case.
    pub(super) of_geometry: Vec<Arc<Vec<u32>>>,
    /// The scene's instances ([`Scene::instances`]): geometry ids from `first_instance` on,
    /// placement by placement, and each one's transform (hits on them are reported in mesh
    /// space).
    pub(super) first_instance: u32,
    pub(super) to_world: Arc<Vec<glam::Affine3A>>,
}

impl TriangleIds {
    #[inline]
    pub(super) fn triangle(&self, hit: &embree_sys::Hit) -> u32 {
        match self.of_geometry.get(hit.geom_id as usize) {
            Some(ids) => ids[hit.prim_id as usize],
            None => hit.prim_id,
        }
    }
}

/// The alpha test of the cut-out geometry's hits ([`Cutouts::stops`]).
struct AlphaFilter {
    cutouts: Arc<Cutouts>,
    triangles: Arc<Vec<u32>>,
}

impl embree_sys::HitFilter for AlphaFilter {
    fn accept(&self, prim_id: u32, u: f32, v: f32, origin: [f32; 3], dir: [f32; 3]) -> bool {
        let triangle = self.triangles[prim_id as usize];
        let (origin, dir) = (glam::Vec3::from_array(origin), glam::Vec3::from_array(dir));
        self.cutouts.stops(triangle, u, v, origin, dir)
    }
}

pub(super) fn to_hit(ids: &TriangleIds, hit: embree_sys::Hit) -> Hit {
    if let Some(geometry) = hit.inst_id {
        let instance = geometry - ids.first_instance;
        let to_world = &ids.to_world[instance as usize];
        return Hit {
            triangle: hit.prim_id,
            instance: Some(instance),
            u: hit.u,
            v: hit.v,
            t: hit.t,
            ng: world_normal(to_world, glam::Vec3::from_array(hit.ng)),
        };
    }
    Hit {
        triangle: ids.triangle(&hit),
        instance: None,
        u: hit.u,
        v: hit.v,
        t: hit.t,
        ng: glam::Vec3::from_array(hit.ng),
    }
}

pub(super) fn tracer_error(err: embree_sys::Error) -> Error {
    Error::Tracer {
        backend: "embree",
        message: err.to_string(),
    }
}

/// The scene's cut-out triangles and how hits map back to triangles ([`TriangleIds`]).
#[derive(Clone, Default)]
pub(super) struct Alpha {
    pub(super) cutouts: Option<Arc<Cutouts>>,
    pub(super) ids: TriangleIds,
}

impl Alpha {
    pub(super) fn of(scene: &Scene) -> Alpha {
        let mut alpha = Alpha::cutouts_of(scene);
        alpha.ids.first_instance = alpha.ids.of_geometry.len().max(1) as u32;
        alpha.ids.to_world = Arc::new(
            scene
                .instances
                .placements
                .iter()
                .map(|p| p.to_world)
                .collect(),
        );
        alpha
    }

    fn cutouts_of(scene: &Scene) -> Alpha {
        let Some(cutouts) = scene.cutouts() else {
            return Alpha::default();
        };
        let (cut, opaque): (Vec<u32>, Vec<u32>) =
            (0..scene.traced_triangles().len() as u32).partition(|&t| cutouts.is_cut(t));
        let of_geometry = [opaque, cut]
            .into_iter()
            .filter(|ids| !ids.is_empty())
            .map(Arc::new)
            .collect();
        Alpha {
            cutouts: Some(Arc::new(cutouts)),
            ids: TriangleIds {
                of_geometry,
                ..TriangleIds::default()
            },
        }
    }
}

/// How an Embree scene is built: robust mode or not, and the BVH quality.
#[derive(Clone, Copy)]
pub(super) struct Build {
    pub(super) robust: bool,
    pub(super) quality: BuildQuality,
}

/// Builds an Embree scene over `scene`'s triangles, robust or not: one geometry, or with
/// cut-out triangles, the geometries `alpha.ids` lists (the cut-out one filtered).
pub(super) fn commit(
    device: &Device,
    scene: &Scene,
    alpha: &Alpha,
    build: Build,
) -> Result<CommittedScene> {
    let Build { robust, quality } = build;
    let positions: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
    let mut builder = SceneBuilder::new(device).map_err(tracer_error)?;
    builder.set_build_quality(quality);
    builder.set_flags(SceneFlags {
        robust,
        compact: false,
    });
    match &alpha.cutouts {
        None => {
            builder
                .add_triangle_mesh(&positions, scene.traced_triangles())
                .map_err(tracer_error)?;
        }
        Some(cutouts) => {
            for (geometry, ids) in alpha.ids.of_geometry.iter().enumerate() {
                let triangles: Vec<[u32; 3]> =
                    ids.iter().map(|&t| scene.triangles[t as usize]).collect();
                let added = if cutouts.is_cut(ids[0]) {
                    let filter = AlphaFilter {
                        cutouts: cutouts.clone(),
                        triangles: ids.clone(),
                    };
                    builder.add_filtered_triangle_mesh(&positions, &triangles, Box::new(filter))
                } else {
                    builder.add_triangle_mesh(&positions, &triangles)
                };
                let id = added.map_err(tracer_error)?;
                debug_assert_eq!(id as usize, geometry, "Embree numbers geometries from 0");
            }
        }
    }
    add_instances(device, scene, &mut builder, build)?;
    builder.commit().map_err(tracer_error)
}

/// Builds one Embree scene per distinct instance mesh and places it at each of its
/// placements, as geometries numbered after the flat ones (`TriangleIds::first_instance`).
pub(super) fn add_instances(
    device: &Device,
    scene: &Scene,
    builder: &mut SceneBuilder,
    Build { robust, quality }: Build,
) -> Result<()> {
    let meshes = scene
        .instances
        .meshes
        .iter()
        .map(|mesh| {
            let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
            let mut one = SceneBuilder::new(device)?;
            one.set_build_quality(quality);
            one.set_flags(SceneFlags {
                robust,
                compact: false,
            });
            one.add_triangle_mesh(&positions, &mesh.triangles)?;
            one.commit().map(Arc::new)
        })
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(tracer_error)?;
    for placement in &scene.instances.placements {
        let m = placement.to_world;
        let columns = [
            m.matrix3.x_axis,
            m.matrix3.y_axis,
            m.matrix3.z_axis,
            m.translation,
        ];
        let matrix: [f32; 12] = std::array::from_fn(|i| columns[i / 3][i % 3]);
        builder
            .add_instance(&meshes[placement.mesh as usize], &matrix)
            .map_err(tracer_error)?;
    }
    Ok(())
}
