//! Closest hits on the back of a glTF `doubleSided` surface, reported on its back sheet.
//!
//! A back sheet ([`crate::scene::BackSheets`]) is not traced: its front stops rays from both
//! sides. But a closest hit is also read for what it hits (the bounces of interreflection,
//! the embedding and leak tests), and there the back of the front sheet is a *back face*,
//! which reflects nothing. [`TwinFacing`] turns such a hit into the hit on the twin
//! triangle of the back sheet, which faces the ray, as the hand-made twin sheets of
//! docs/guides/production-assets.md ("Two-sided surfaces") would answer when the coplanar pair resolves to the
//! facing one.

use std::sync::Arc;

use glam::Vec3;

use super::tracer::{Backend, Hit, Ray, Tracer};
use crate::scene::Scene;
use crate::support::error::Result;

/// No twin: the triangle has no back sheet.
const NONE: u32 = u32::MAX;

/// A tracer whose back-face hits on a twinned triangle land on its twin.
pub struct TwinFacing<'a> {
    inner: Box<dyn Tracer + 'a>,
    /// Per traced triangle, its back-sheet twin or [`NONE`].
    twin: Arc<[u32]>,
}

impl<'a> TwinFacing<'a> {
    /// `inner` as it is where `scene` has no back sheets, else wrapped.
    pub fn wrap(inner: Box<dyn Tracer + 'a>, scene: &Scene) -> Box<dyn Tracer + 'a> {
        let Some(first) = scene.first_back_sheet() else {
            return inner;
        };
        let mut twin = vec![NONE; scene.traced_triangles().len()];
        for (k, &front) in scene.back_sheets.fronts.iter().enumerate() {
            let (front, back) = (&scene.objects[front as usize], &scene.objects[first + k]);
            for (f, b) in front.triangles.clone().zip(back.triangles.clone()) {
                twin[f as usize] = b;
            }
        }
        Box::new(TwinFacing {
            inner,
            twin: twin.into(),
        })
    }

    /// The twin's hit for a back-face hit on a twinned triangle: its corners are the
    /// front's (a, c, b), so u and v swap and the geometric normal turns over.
    fn face(&self, dir: Vec3, hit: &mut Option<Hit>) {
        if let Some(h) = hit
            && h.instance.is_none()
            && h.ng.dot(dir) > 0.0
            && let Some(&twin) = self.twin.get(h.triangle as usize)
            && twin != NONE
        {
            *h = Hit {
                triangle: twin,
                u: h.v,
                v: h.u,
                ng: -h.ng,
                ..*h
            };
        }
    }
}

impl Tracer for TwinFacing<'_> {
    fn backend(&self) -> Backend {
        self.inner.backend()
    }

    fn occluded(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.inner.occluded(rays, occluded);
    }

    fn occluded_from(&self, origin: Vec3, dirs: &[Vec3], occluded: &mut [bool]) {
        self.inner.occluded_from(origin, dirs, occluded);
    }

    fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.inner.intersect(rays, hits);
        for (ray, hit) in rays.iter().zip(hits) {
            self.face(ray.dir, hit);
        }
    }

    fn intersect_within(&self, origin: Vec3, dirs: &[Vec3], tfar: f32, hits: &mut [Option<Hit>]) {
        self.inner.intersect_within(origin, dirs, tfar, hits);
        for (&dir, hit) in dirs.iter().zip(hits) {
            self.face(dir, hit);
        }
    }

    fn prepare_points(&self, scene: &Scene) {
        self.inner.prepare_points(scene);
    }

    fn release_points(&self) {
        self.inner.release_points();
    }

    fn seam_points(&self, scene: &Scene, origins: &[Vec3], own: &[u32]) -> Option<Vec<bool>> {
        self.inner.seam_points(scene, origins, own)
    }

    fn for_seam_points<'s>(
        &'s self,
        scene: &Scene,
        origins: &[Vec3],
        seam: &[bool],
    ) -> Result<Option<Box<dyn Tracer + 's>>> {
        Ok(self
            .inner
            .for_seam_points(scene, origins, seam)?
            .map(|inner| -> Box<dyn Tracer + 's> {
                Box::new(TwinFacing {
                    inner,
                    twin: self.twin.clone(),
                })
            }))
    }
}
