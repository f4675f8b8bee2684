//! Per-vertex tangents of normal-mapped objects: the file's own (glTF `TANGENT`, w the
//! bitangent's sign) where it has them, else MikkTSpace's, as the glTF specification asks of
//! a client when `TANGENT` is absent (the `mikktspace` crate, over the positions, normals and
//! the texture coordinates the normal map is read with).

use glam::{Vec2, Vec3, Vec4};

/// The MikkTSpace tangents (xyz unit, w = ±1) of the vertices `vertices` of a mesh, from its
/// `triangles` (indices into the arrays, all within `vertices`); zero where MikkTSpace gives
/// none (no usable triangle), so such texels keep their surface normal.
pub fn mikktspace_tangents(
    positions: &[Vec3],
    normals: &[Vec3],
    uvs: &[Vec2],
    triangles: &[[u32; 3]],
    vertices: std::ops::Range<usize>,
) -> Vec<Vec4> {
    let mut mesh = MikkMesh {
        positions,
        normals,
        uvs,
        triangles,
        first: vertices.start,
        sums: vec![Vec4::ZERO; vertices.len()],
    };
    if !mikktspace::generate_tangents(&mut mesh) {
        return vec![Vec4::ZERO; vertices.len()];
    }
    mesh.sums.iter().map(|s| settle(*s)).collect()
}

/// A vertex's tangent from the sum of its corners' (MikkTSpace may split a vertex where
/// its corners' frames differ; an indexed mesh keeps one per vertex): the mean direction,
/// and the sign most corners give.
fn settle(sum: Vec4) -> Vec4 {
    match sum.truncate().try_normalize() {
        Some(t) => t.extend(if sum.w < 0.0 { -1.0 } else { 1.0 }),
        None => Vec4::ZERO,
    }
}

/// One object's triangles as MikkTSpace sees them; tangents are summed per vertex.
struct MikkMesh<'a> {
    positions: &'a [Vec3],
    normals: &'a [Vec3],
    uvs: &'a [Vec2],
    triangles: &'a [[u32; 3]],
    /// The object's first vertex: `sums[v − first]` is vertex v's.
    first: usize,
    sums: Vec<Vec4>,
}

impl MikkMesh<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.triangles[face][vert] as usize
    }
}

impl mikktspace::Geometry for MikkMesh<'_> {
    fn num_faces(&self) -> usize {
        self.triangles.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[self.vertex(face, vert)].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[self.vertex(face, vert)].to_array()
    }

    /// The scene's uv (v up): MikkTSpace's bitangent then follows increasing v, toward the
    /// image's top, which is where glTF's green (+y) points.
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.vertex(face, vert)].to_array()
    }

    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        let v = self.vertex(face, vert);
        let t = Vec4::from_array(tangent);
        if t.is_finite() {
            self.sums[v - self.first] += t;
        }
    }
}
