//! Transfer probes for moving meshes (docs/guides/probes.md), as runtime/three/probes.js: a
//! probe bake (`prt-bake bake SCENE --probes grid:NX,NY,NZ -o probes.prt`) gives per probe p a
//! matrix M_p that turns the distant light into the incident radiance there (shadowed and
//! interreflected by the scene). A rigid PRT mesh baked alone is relit, each frame, by
//! R⁻¹·Σ_p w_p M_p·L at its position (trilinear weights, probes inside geometry left out).

use std::path::{Path, PathBuf};

use bevy::math::DMat3;
use bevy::prelude::*;

use crate::light::PrtLight;
use crate::material::PrtMaterial;
use crate::sh;

const MAGIC: [u8; 8] = [0x89, 0x50, 0x52, 0x54, 0x0d, 0x0a, 0x1a, 0x0a];
const PROBE_HEADER_SIZE: usize = 176;
/// Above this back-face fraction a probe is inside geometry and left out.
pub const INSIDE_FRACTION: f32 = 0.25;

/// Why a probe file could not be read.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ProbeError {
    pub path: PathBuf,
    pub message: String,
}

/// A grid probe bake (the resource moving meshes are lit from).
#[derive(Resource, Clone, Debug)]
pub struct PrtProbes {
    pub order: usize,
    pub channels: usize,
    /// The probe scene's up axis: true for y (glTF scenes), false for z (OBJ, scene files).
    pub y_up: bool,
    pub counts: [usize; 3],
    pub lo: Vec3,
    pub hi: Vec3,
    pub backfaces: Vec<f32>,
    /// Per probe and channel an n² × n² row-major matrix.
    pub matrices: Vec<f32>,
}

/// A PRT mesh lit from [`PrtProbes`] where it stands; its [`PrtMaterial`] must be its own.
#[derive(Component, Default)]
pub struct ProbeLit;

impl PrtProbes {
    /// Reads a probe bake.
    pub fn load(path: &Path) -> Result<PrtProbes, ProbeError> {
        let error = |message: String| ProbeError {
            path: path.to_path_buf(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|e| error(e.to_string()))?;
        if bytes.len() < PROBE_HEADER_SIZE || bytes[..8] != MAGIC {
            return Err(error("not a PRT coefficient file".into()));
        }
        let u32_at =
            |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes")) as usize;
        let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        if u32_at(12) != PROBE_HEADER_SIZE {
            return Err(error("not a probe bake (bake --probes)".into()));
        }
        let (order, channels) = (u32_at(16), u32_at(20));
        let count = u64::from_le_bytes(bytes[24..32].try_into().expect("8 bytes")) as usize;
        let n = order * order;
        let floats = count * channels * n * n;
        let expected = PROBE_HEADER_SIZE + 4 * (floats + 4 * count);
        if bytes.len() != expected {
            return Err(error(format!(
                "{} bytes, {count} probes need {expected}",
                bytes.len()
            )));
        }
        let counts = [u32_at(136), u32_at(140), u32_at(144)];
        if counts.iter().product::<usize>() != count {
            return Err(error("not a grid probe bake (--probes grid:…)".into()));
        }
        let read = |offset: usize, len: usize| {
            (0..len)
                .map(|i| f32_at(offset + 4 * i))
                .collect::<Vec<f32>>()
        };
        Ok(PrtProbes {
            order,
            channels,
            y_up: u32_at(84) == 1,
            counts,
            lo: Vec3::new(f32_at(148), f32_at(152), f32_at(156)),
            hi: Vec3::new(f32_at(160), f32_at(164), f32_at(168)),
            matrices: read(PROBE_HEADER_SIZE, floats),
            backfaces: read(PROBE_HEADER_SIZE + 4 * (floats + 3 * count), count),
        })
    }

    /// Trilinear weights over the grid cell around x (scene frame; clamped to the cell
    /// centres), probes inside geometry left out and the others renormalised.
    pub fn weights(&self, x: Vec3) -> Vec<(usize, f32)> {
        let axis = |a: usize| {
            let n = self.counts[a];
            let size = ((self.hi[a] - self.lo[a]) / n as f32).max(f32::MIN_POSITIVE);
            let u = ((x[a] - self.lo[a]) / size - 0.5).clamp(0.0, (n - 1) as f32);
            let i = (u.floor() as usize).min(n.saturating_sub(2));
            let t = if n == 1 { 0.0 } else { u - i as f32 };
            [(i, 1.0 - t), ((i + 1).min(n - 1), t)]
        };
        let (ax, ay, az) = (axis(0), axis(1), axis(2));
        let mut weights = Vec::new();
        for (k, wz) in az {
            for (j, wy) in ay {
                for (i, wx) in ax {
                    let p = i + self.counts[0] * (j + self.counts[1] * k);
                    let w = wx * wy * wz;
                    if w > 0.0 && self.backfaces[p] <= INSIDE_FRACTION {
                        weights.push((p, w));
                    }
                }
            }
        }
        let total: f32 = weights.iter().map(|(_, w)| w).sum();
        weights.into_iter().map(|(p, w)| (p, w / total)).collect()
    }

    /// L_in = Σ w_p M_p·L at x; `light` (R, G, B, n² each) and x in the probes' scene frame.
    pub fn incident(&self, x: Vec3, light: &[Vec<f64>; 3]) -> [Vec<f64>; 3] {
        let n = self.order * self.order;
        let mut out = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        for (p, w) in self.weights(x) {
            for (c, o) in out.iter_mut().enumerate() {
                let channel = if self.channels == 1 { 0 } else { c };
                let start = (p * self.channels + channel) * n * n;
                for (i, oi) in o.iter_mut().enumerate() {
                    let dot: f64 = (0..n)
                        .map(|j| self.matrices[start + i * n + j] as f64 * light[c][j])
                        .sum();
                    *oi += w as f64 * dot;
                }
            }
        }
        out
    }

    /// The light, in the object's own frame, of a rigid PRT mesh placed by `transform` in
    /// Bevy's world (the glTF frame of the exports: the probe scene turned to +Y up when it
    /// is z-up): R⁻¹·L_in at its position. `light` is in the glTF frame, turned.
    pub fn light_for_object(
        &self,
        transform: &GlobalTransform,
        light: &[Vec<f64>; 3],
    ) -> [Vec<f64>; 3] {
        let (_, rotation, position) = transform.to_scale_rotation_translation();
        let to_gltf = if self.y_up {
            DMat3::IDENTITY
        } else {
            sh::z_up_to_gltf()
        };
        let order = self.order;
        let turn = |m: DMat3, c: &[Vec<f64>; 3]| {
            let bands = sh::rotation(order, m);
            c.clone().map(|x| sh::rotate(&bands, &x))
        };
        let mut fitted = light.clone();
        fitted.iter_mut().for_each(|c| c.resize(order * order, 0.0));
        let scene_light = turn(to_gltf.transpose(), &fitted);
        let x = (to_gltf.transpose() * position.as_dvec3()).as_vec3();
        let incident = turn(to_gltf, &self.incident(x, &scene_light));
        turn(DMat3::from_quat(rotation.as_dquat()).transpose(), &incident)
    }
}

/// Each frame, every [`ProbeLit`] mesh's material gets the probes' light where it stands.
pub(crate) fn light_probe_lit(
    probes: Option<Res<PrtProbes>>,
    light: Res<PrtLight>,
    lit: Query<(&GlobalTransform, &MeshMaterial3d<PrtMaterial>), With<ProbeLit>>,
    mut materials: ResMut<Assets<PrtMaterial>>,
) {
    let Some(probes) = probes else { return };
    let turned = light.turned(probes.order);
    for (transform, material) in &lit {
        if let Some(mut m) = materials.get_mut(&material.0) {
            m.extension.probe_lit = true;
            m.extension
                .set_light(&probes.light_for_object(transform, &turned));
        }
    }
}
