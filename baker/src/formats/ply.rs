//! Writing triangle meshes with per-vertex colour and radiance as PLY, and reading back the
//! points and radiance of such a file (what tests and scripts compare).
//!
//! Binary little-endian PLY 1.0: a text header any pager shows, then packed records, so a
//! million-vertex scene stays compact and every float is stored exactly. Per vertex:
//! `float x y z`, `float nx ny nz`, `uchar red green blue` (the display colour), and
//! `float radiance_r radiance_g radiance_b` (linear radiance); per face a
//! `list uchar uint vertex_indices` of 3. MeshLab and Blender open it as a coloured mesh and
//! keep the extra floats as vertex attributes.

use std::path::Path;

use glam::Vec3;

use crate::support::error::Result;

/// A mesh to write: every per-vertex slice has the same length.
pub struct ColouredMesh<'a> {
    pub positions: &'a [Vec3],
    pub normals: &'a [Vec3],
    /// 8-bit display colour (sRGB-encoded).
    pub colours: &'a [[u8; 3]],
    /// Linear RGB radiance.
    pub radiance: &'a [[f32; 3]],
    pub triangles: &'a [[u32; 3]],
    /// Header comment lines (line breaks become spaces).
    pub comments: Vec<String>,
}

/// Bytes of one vertex record: 9 floats and 3 bytes.
pub const VERTEX_BYTES: usize = 9 * 4 + 3;
/// Bytes of one face record: a count byte and 3 indices.
pub const FACE_BYTES: usize = 1 + 3 * 4;

impl ColouredMesh<'_> {
    pub fn to_bytes(&self) -> Vec<u8> {
        let v = self.positions.len();
        assert!(
            self.normals.len() == v && self.colours.len() == v && self.radiance.len() == v,
            "per-vertex arrays of different lengths"
        );
        let mut header = String::from("ply\nformat binary_little_endian 1.0\n");
        for comment in &self.comments {
            header += &format!("comment {}\n", comment.replace(['\n', '\r'], " "));
        }
        header += &format!("element vertex {v}\n");
        for name in ["x", "y", "z", "nx", "ny", "nz"] {
            header += &format!("property float {name}\n");
        }
        for name in ["red", "green", "blue"] {
            header += &format!("property uchar {name}\n");
        }
        for name in ["radiance_r", "radiance_g", "radiance_b"] {
            header += &format!("property float {name}\n");
        }
        header += &format!(
            "element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
            self.triangles.len()
        );
        let mut bytes = header.into_bytes();
        bytes.reserve(v * VERTEX_BYTES + self.triangles.len() * FACE_BYTES);
        for i in 0..v {
            let floats = self.positions[i]
                .to_array()
                .into_iter()
                .chain(self.normals[i].to_array());
            bytes.extend(floats.flat_map(f32::to_le_bytes));
            bytes.extend(self.colours[i]);
            bytes.extend(self.radiance[i].iter().flat_map(|x| x.to_le_bytes()));
        }
        for t in self.triangles {
            bytes.push(3);
            bytes.extend(t.iter().flat_map(|i| i.to_le_bytes()));
        }
        bytes
    }

    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::support::atomic::write(path, &self.to_bytes())
    }
}

/// Why [`read_radiance`] could not read a file as this module writes them.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ReadError {
    #[error("no `end_header` line: not a PLY file")]
    NoHeader,
    #[error("no `element vertex` count in the header")]
    NoVertexCount,
    #[error("the records end before the header's {0} vertices")]
    Short(usize),
}

/// Each vertex's position and radiance, from a file [`ColouredMesh::write`] wrote (its
/// header's vertex count, records of [`VERTEX_BYTES`]).
pub fn read_radiance(bytes: &[u8]) -> std::result::Result<Vec<(Vec3, [f32; 3])>, ReadError> {
    let end = b"end_header\n";
    let start = bytes
        .windows(end.len())
        .position(|w| w == end)
        .ok_or(ReadError::NoHeader)?
        + end.len();
    let vertices: usize = String::from_utf8_lossy(&bytes[..start])
        .lines()
        .find_map(|l| l.strip_prefix("element vertex ")?.trim().parse().ok())
        .ok_or(ReadError::NoVertexCount)?;
    let records = bytes
        .get(start..)
        .and_then(|b| b.get(..vertices.checked_mul(VERTEX_BYTES)?))
        .ok_or(ReadError::Short(vertices))?;
    let floats = |b: &[u8]| -> [f32; 3] {
        std::array::from_fn(|c| {
            f32::from_le_bytes([b[4 * c], b[4 * c + 1], b[4 * c + 2], b[4 * c + 3]])
        })
    };
    Ok(records
        .chunks_exact(VERTEX_BYTES)
        .map(|r| {
            (
                Vec3::from(floats(&r[..12])),
                floats(&r[VERTEX_BYTES - 12..]),
            )
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_follow_the_header_at_the_stated_sizes() {
        let mesh = ColouredMesh {
            positions: &[Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: &[Vec3::Z; 3],
            colours: &[[1, 2, 3], [4, 5, 6], [7, 8, 9]],
            radiance: &[[0.5, 0.25, 0.125]; 3],
            triangles: &[[0, 1, 2]],
            comments: vec!["two\nlines".into()],
        };
        let bytes = mesh.to_bytes();
        let end = b"end_header\n";
        let header_len = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
        let header = std::str::from_utf8(&bytes[..header_len]).unwrap();
        assert!(header.contains("comment two lines\n"), "{header}");
        assert_eq!(bytes.len(), header_len + 3 * VERTEX_BYTES + FACE_BYTES);
        // Vertex 1's colour, then its radiance_r.
        let at = header_len + VERTEX_BYTES + 24;
        assert_eq!(&bytes[at..at + 3], &[4, 5, 6]);
        assert_eq!(&bytes[at + 3..at + 7], &0.5f32.to_le_bytes());
        assert_eq!(&bytes[bytes.len() - FACE_BYTES..][..5], &[3, 0, 0, 0, 0]);
        let read = read_radiance(&bytes).unwrap();
        assert_eq!(read.len(), 3);
        assert_eq!(read[1], (Vec3::X, [0.5, 0.25, 0.125]));
        assert_eq!(
            read_radiance(&bytes[..header_len + 40]),
            Err(ReadError::Short(3))
        );
        assert_eq!(read_radiance(b"ply\n"), Err(ReadError::NoHeader));
    }
}
