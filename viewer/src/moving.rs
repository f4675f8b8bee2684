//! A rigid object moving along a path through a probe-baked scene (docs/guides/probes.md), on the
//! CPU: where it is at each moment and the radiance of its vertices there.
//!
//! The object is baked alone (its own transfer T, its self-shadowing, in its local frame); the
//! scene only through its transfer probes. At position x with rotation q it receives, in its
//! frame, L_obj = R(q⁻¹)·L_in(x), L_in(x) = Σ w_p M_p·L (the probe grid's trilinear blend),
//! and a vertex's radiance is albedo · T·L_obj: exactly `prt-bake relight --probes --at
//! --turn` (`prt_baker::export::probe_field::rigid_radiance`), which the viewer's tests hold
//! it to. The dot products are done here, on the CPU: a moving prop has few vertices, and the
//! scene's own PRT stays on the GPU.

use std::path::Path;

use glam::{DQuat, Vec3};
use prt_baker::export::probe_field::{ProbeField, rigid_radiance};
use prt_baker::light::LightCoefficients;
use prt_baker::scene::Up;
use prt_baker::{CoefficientFile, Scene};

use crate::error::{Error, Result};

/// A probe bake (`prt-bake bake SCENE --probes grid:…`), checked to be a z-up grid.
#[derive(Clone, Debug)]
pub struct Probes {
    pub file: CoefficientFile,
}

impl Probes {
    pub fn load(path: &Path) -> Result<Probes> {
        Probes::new(CoefficientFile::read(path)?, path)
    }

    /// A probe file in memory (tests); `path` names it in messages.
    pub fn new(file: CoefficientFile, path: &Path) -> Result<Probes> {
        ProbeField::new(&file).map_err(|m| prt_baker::Error::coefficient_file(path, m))?;
        if file.header.up != Up::Z {
            return Err(Error::InvalidOption(format!(
                "{}: probes of a y-up scene: the viewer shows probes of z-up scenes only",
                path.display()
            )));
        }
        Ok(Probes { file })
    }

    pub fn field(&self) -> ProbeField<'_> {
        ProbeField::new(&self.file).expect("checked when loaded")
    }

    pub fn order(&self) -> usize {
        self.file.header.order as usize
    }
}

/// The object and its path.
#[derive(Clone, Debug)]
pub struct Mover {
    pub scene: Scene,
    pub file: CoefficientFile,
    albedo: Vec<Vec3>,
    path: Vec<Vec3>,
    /// Scene units per second along the path (there and back).
    pub speed: f32,
}

impl Mover {
    /// The object `scene` with its own vector bake `coefficients`, to move along `path`.
    pub fn load(scene: &Path, coefficients: &Path, path: Vec<Vec3>, speed: f32) -> Result<Mover> {
        let file = CoefficientFile::read(coefficients)?;
        let scene_data = file.load_scene(scene)?;
        file.check_scene(coefficients, &scene_data)?;
        Mover::new(scene_data, file, path, speed, coefficients)
    }

    /// As [`Mover::load`], from memory; `name` names the bake in messages.
    pub fn new(
        scene: Scene,
        file: CoefficientFile,
        path: Vec<Vec3>,
        speed: f32,
        name: &Path,
    ) -> Result<Mover> {
        if file.probes.is_some() || file.lightmap.is_some() || file.header.channels == 0 {
            return Err(Error::InvalidOption(format!(
                "{}: the moving object needs a per-vertex bake of its own (not probes, not a lightmap)",
                name.display()
            )));
        }
        if file.header.transfer != prt_baker::formats::header::TransferKind::Vector {
            return Err(Error::InvalidOption(format!(
                "{}: the moving object needs transfer vectors (diffuse PRT), not matrices",
                name.display()
            )));
        }
        if scene.up != Up::Z {
            return Err(Error::InvalidOption(format!(
                "{}: a y-up object: the viewer moves z-up objects only",
                name.display()
            )));
        }
        if path.is_empty() {
            return Err(Error::InvalidOption("--path: no points".into()));
        }
        let albedo = scene.vertex_albedo();
        Ok(Mover {
            scene,
            file,
            albedo,
            path,
            speed,
        })
    }

    pub fn order(&self) -> usize {
        self.file.header.order as usize
    }

    /// The path's length.
    pub fn length(&self) -> f32 {
        self.path.windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    /// Where the object is `distance` along the path (clamped to its ends), facing along it:
    /// its +x turned about +z to the segment's direction (no turn on a one-point path).
    pub fn placement(&self, distance: f32) -> (Vec3, DQuat) {
        let mut left = distance.max(0.0);
        let last = self.path.len().saturating_sub(2);
        for (i, w) in self.path.windows(2).enumerate() {
            let length = w[0].distance(w[1]);
            if left <= length || i == last {
                let t = if length > 0.0 {
                    (left / length).min(1.0)
                } else {
                    0.0
                };
                let d = w[1] - w[0];
                let yaw = f64::from(d.y).atan2(f64::from(d.x));
                return (w[0].lerp(w[1], t), DQuat::from_rotation_z(yaw));
            }
            left -= length;
        }
        (self.path[0], DQuat::IDENTITY)
    }

    /// The distance along the path after `seconds`: there and back at [`Mover::speed`].
    pub fn distance_at(&self, seconds: f64) -> f32 {
        let length = f64::from(self.length());
        if length <= 0.0 {
            return 0.0;
        }
        let s = (seconds * f64::from(self.speed)).rem_euclid(2.0 * length);
        (if s > length { 2.0 * length - s } else { s }) as f32
    }

    /// Per-vertex linear RGB radiance (albedo included) at `placement`, lit by `light` (the
    /// scene's frame) through `probes`.
    pub fn radiance(
        &self,
        probes: &Probes,
        placement: (Vec3, DQuat),
        light: &LightCoefficients,
    ) -> Vec<[f32; 3]> {
        rigid_radiance(&self.file, &self.albedo, &probes.field(), placement, light)
    }

    /// The object's vertices placed: q·p + x.
    pub fn world_positions(&self, (x, q): (Vec3, DQuat)) -> Vec<Vec3> {
        let q = q.as_quat();
        self.scene.positions.iter().map(|p| q * *p + x).collect()
    }
}

/// `--path`: points `x,y,z` separated by `;`.
pub fn parse_path(text: &str) -> Result<Vec<Vec3>> {
    text.split(';')
        .filter(|p| !p.trim().is_empty())
        .map(|point| {
            let v: Vec<f32> = point
                .split(',')
                .map(|c| c.trim().parse::<f32>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| {
                    Error::InvalidOption(format!("--path: {point:?} is not x,y,z numbers"))
                })?;
            match v[..] {
                [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
                _ => Err(Error::InvalidOption(format!(
                    "--path: {point:?} is not one x,y,z point"
                ))),
            }
        })
        .collect::<Result<Vec<_>>>()
        .and_then(|points| {
            if points.is_empty() {
                Err(Error::InvalidOption("--path: no points".into()))
            } else {
                Ok(points)
            }
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_parse_and_bad_ones_are_named() {
        let p = parse_path("0,0,1; 1,0,1;").unwrap();
        assert_eq!(p, vec![Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0)]);
        for bad in ["", "1,2", "1,2,x", "1,2,3,4", "1,2,inf"] {
            assert!(parse_path(bad).is_err(), "{bad}");
        }
    }
}
