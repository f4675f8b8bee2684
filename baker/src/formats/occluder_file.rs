//! The occluder file (`bake OBJ --occluder -o OBJ_OCC.prt`): a moving object's sphere set, in
//! the object's own coordinates, which `relight --occluder` places with `--at` and `--turn`.
//!
//! Layout (little-endian; docs/reference/coefficient-format.md, "Occluder files"):
//!
//! | bytes | field |
//! |---|---|
//! | 8 | magic `\x89PRTOCC\n` |
//! | 4 | version (u32, 1) |
//! | 4 | sphere count K (u32, 1 ≤ K ≤ 4096) |
//! | 16·K | per sphere: centre x, y, z and radius (f32) |
//!
//! So one ball costs 32 bytes, an 8-sphere character 144.

use std::path::Path;

use glam::{DQuat, DVec3, Vec3};

use crate::math::occlusion::Sphere;
use crate::support::error::{Error, Result};

pub const OCCLUDER_MAGIC: [u8; 8] = *b"\x89PRTOCC\n";
pub const OCCLUDER_VERSION: u32 = 1;
/// The most spheres a file may hold (each costs every nearby receiver a triple product).
pub const MAX_SPHERES: usize = 4096;

/// One fitted sphere, in the object's coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalSphere {
    pub centre: Vec3,
    pub radius: f32,
}

/// An occluder: its spheres in the object's own frame.
#[derive(Clone, Debug, PartialEq)]
pub struct OccluderFile {
    pub spheres: Vec<LocalSphere>,
}

impl OccluderFile {
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut bytes = Vec::with_capacity(16 + 16 * self.spheres.len());
        bytes.extend(OCCLUDER_MAGIC);
        bytes.extend(OCCLUDER_VERSION.to_le_bytes());
        bytes.extend((self.spheres.len() as u32).to_le_bytes());
        for s in &self.spheres {
            for x in [s.centre.x, s.centre.y, s.centre.z, s.radius] {
                bytes.extend(x.to_le_bytes());
            }
        }
        bytes
    }

    /// Parses a file's bytes; the message says what is wrong.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<OccluderFile, String> {
        if bytes.len() < 16 || bytes[..8] != OCCLUDER_MAGIC {
            return Err("not an occluder file (`prt-bake bake OBJ --occluder`): bad magic".into());
        }
        let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
        let version = word(8);
        if version != OCCLUDER_VERSION {
            return Err(format!(
                "occluder file version {version}; this build reads version {OCCLUDER_VERSION}"
            ));
        }
        let count = word(12) as usize;
        if count == 0 || count > MAX_SPHERES {
            return Err(format!(
                "{count} spheres; an occluder holds 1 to {MAX_SPHERES}"
            ));
        }
        if bytes.len() != 16 + 16 * count {
            return Err(format!(
                "{} bytes; {count} spheres make {}",
                bytes.len(),
                16 + 16 * count
            ));
        }
        let float = |at: usize| f32::from_bits(word(at));
        let spheres: Vec<LocalSphere> = (0..count)
            .map(|s| {
                let at = 16 + 16 * s;
                LocalSphere {
                    centre: Vec3::new(float(at), float(at + 4), float(at + 8)),
                    radius: float(at + 12),
                }
            })
            .collect();
        if let Some(s) = spheres
            .iter()
            .position(|s| !(s.centre.is_finite() && s.radius.is_finite() && s.radius > 0.0))
        {
            return Err(format!(
                "sphere {s}: centre and radius must be finite, the radius positive"
            ));
        }
        Ok(OccluderFile { spheres })
    }

    /// Reads and validates `path`.
    pub fn read(path: &Path) -> Result<OccluderFile> {
        let bytes = crate::support::limits::read_file(path)?;
        OccluderFile::from_bytes(&bytes).map_err(|message| Error::coefficient_file(path, message))
    }

    /// The spheres in world space, the object turned by `rotation` about its origin and its
    /// origin moved to `position`.
    pub fn placed(&self, position: DVec3, rotation: DQuat) -> Vec<Sphere> {
        self.spheres
            .iter()
            .map(|s| Sphere {
                centre: position + rotation * s.centre.as_dvec3(),
                radius: f64::from(s.radius),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_refuses_damage() {
        let file = OccluderFile {
            spheres: vec![
                LocalSphere {
                    centre: Vec3::new(1.0, 2.0, 3.0),
                    radius: 0.5,
                },
                LocalSphere {
                    centre: Vec3::ZERO,
                    radius: 0.25,
                },
            ],
        };
        let bytes = file.to_bytes();
        assert_eq!(bytes.len(), 48);
        assert_eq!(OccluderFile::from_bytes(&bytes).unwrap(), file);
        assert!(OccluderFile::from_bytes(&bytes[..47]).is_err());
        let mut negative = bytes.clone();
        negative[28..32].copy_from_slice(&(-1.0f32).to_le_bytes());
        assert!(
            OccluderFile::from_bytes(&negative)
                .unwrap_err()
                .contains("sphere 0")
        );
        let mut magic = bytes;
        magic[1] = b'Q';
        assert!(OccluderFile::from_bytes(&magic).is_err());
    }

    #[test]
    fn placement_turns_about_the_origin_then_moves() {
        let file = OccluderFile {
            spheres: vec![LocalSphere {
                centre: Vec3::X,
                radius: 1.0,
            }],
        };
        let q = DQuat::from_axis_angle(DVec3::Z, std::f64::consts::FRAC_PI_2);
        let placed = file.placed(DVec3::new(0.0, 0.0, 5.0), q);
        assert!((placed[0].centre - DVec3::new(0.0, 1.0, 5.0)).length() < 1e-12);
    }
}
