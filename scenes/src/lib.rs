//! The demo scenes, generated so that their vertex counts and layout are exact and documented.
//!
//! World space is z-up (the SH convention measures θ from +z, so the sky is +z).
//!
//! * `torus/`: the thesis's demo. A torus of exactly 10,800 unique vertices (119 × 89 quads
//!   plus the texture seams: 120 × 90 vertices), tilted and resting on a floor, in a corner of
//!   two walls; the three planes have 30 × 30 vertices each, 2,700 in all. Thesis scene-file
//!   format, TGA textures. `torus/glossy.scene` is the same scene with the torus glossy
//!   (`torus-glossy.obj`, the same mesh with an MTL Phong layer: the glossy demo).
//!   `torus/translucent.scene` adds a wax sphere (`wax.obj`) whose medium is in
//!   `translucent.toml` (the subsurface demo). `torus/torus-fine.scene` and
//!   `torus/glossy-fine.scene` mesh the planes at 60 × 60 vertices each (`planes-fine.obj`),
//!   for the denoiser's vertex measurements.
//! * `cornell/`: a Cornell-box-like room open at the front and the top (so distant light gets
//!   in): white floor and back wall, red left wall, green right wall (the original box's
//!   reflectances), a short and a tall white box. Materials in MTL, no textures.

pub mod skinned_tube;
pub mod tube;

use std::fmt::Write as _;
use std::path::Path;

use glam::{Mat3, Vec2, Vec3};

/// A triangle mesh with per-vertex normals and texture coordinates.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// A (nu+1) × (nv+1) vertex grid over the parameter square, two triangles per cell,
    /// wound so the face normal is ∂p/∂u × ∂p/∂v.
    fn grid(nu: u32, nv: u32, mut vertex: impl FnMut(f32, f32) -> (Vec3, Vec3, Vec2)) -> Mesh {
        let mut mesh = Mesh::default();
        for j in 0..=nv {
            for i in 0..=nu {
                let (p, n, uv) = vertex(i as f32 / nu as f32, j as f32 / nv as f32);
                mesh.positions.push(p);
                mesh.normals.push(n);
                mesh.uvs.push(uv);
            }
        }
        let at = |i: u32, j: u32| j * (nu + 1) + i;
        for j in 0..nv {
            for i in 0..nu {
                mesh.triangles
                    .push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                mesh.triangles
                    .push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        mesh
    }

    /// A flat rectangle `origin + u·edge_u + v·edge_v` with (n+1)² vertices; its normal is
    /// edge_u × edge_v. Texture coordinates repeat `tiles` times.
    pub fn plane(origin: Vec3, edge_u: Vec3, edge_v: Vec3, cells: u32, tiles: f32) -> Mesh {
        let normal = edge_u.cross(edge_v).normalize();
        Mesh::grid(cells, cells, |u, v| {
            (
                origin + edge_u * u + edge_v * v,
                normal,
                Vec2::new(u, v) * tiles,
            )
        })
    }

    /// A torus around the z axis: ring radius `major`, tube radius `minor`.
    pub fn torus(major: f32, minor: f32, ring_cells: u32, tube_cells: u32) -> Mesh {
        use std::f32::consts::TAU;
        Mesh::grid(ring_cells, tube_cells, |u, v| {
            let (sp, cp) = (TAU * u).sin_cos();
            let (st, ct) = (TAU * v).sin_cos();
            let normal = Vec3::new(ct * cp, ct * sp, st);
            let p = Vec3::new(
                (major + minor * ct) * cp,
                (major + minor * ct) * sp,
                minor * st,
            );
            (p, normal, Vec2::new(u * 4.0, v))
        })
    }

    /// A sphere of `radius` about the origin: a (θ, φ) grid, the poles' rows collapsed to
    /// points (their triangles have zero area).
    pub fn sphere(radius: f32, rings: u32, segments: u32) -> Mesh {
        use std::f32::consts::{PI, TAU};
        Mesh::grid(segments, rings, |u, v| {
            let (sp, cp) = (TAU * u).sin_cos();
            let (st, ct) = (PI * (1.0 - v)).sin_cos();
            let normal = Vec3::new(st * cp, st * sp, ct);
            (normal * radius, normal, Vec2::new(u, v))
        })
    }

    pub fn transformed(mut self, rotation: Mat3, translation: Vec3) -> Mesh {
        for p in &mut self.positions {
            *p = rotation * *p + translation;
        }
        for n in &mut self.normals {
            *n = (rotation * *n).normalize();
        }
        self
    }
}

/// Accumulates OBJ text; indices are global across the objects written into it.
#[derive(Default)]
struct ObjWriter {
    text: String,
    vertices: u32,
}

impl ObjWriter {
    fn new(header: &str) -> ObjWriter {
        let mut w = ObjWriter::default();
        for line in header.lines() {
            writeln!(w.text, "# {line}").unwrap();
        }
        w
    }

    fn object(&mut self, name: &str, material: Option<&str>, mesh: &Mesh) {
        let t = &mut self.text;
        writeln!(t, "o {name}").unwrap();
        if let Some(material) = material {
            writeln!(t, "usemtl {material}").unwrap();
        }
        for p in &mesh.positions {
            writeln!(t, "v {:.6} {:.6} {:.6}", p.x, p.y, p.z).unwrap();
        }
        for uv in &mesh.uvs {
            writeln!(t, "vt {:.6} {:.6}", uv.x, uv.y).unwrap();
        }
        for n in &mesh.normals {
            writeln!(t, "vn {:.6} {:.6} {:.6}", n.x, n.y, n.z).unwrap();
        }
        for tri in &mesh.triangles {
            let [a, b, c] = tri.map(|i| i + self.vertices + 1);
            writeln!(t, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}").unwrap();
        }
        self.vertices += mesh.positions.len() as u32;
    }
}

fn write_tga(
    path: &Path,
    width: u32,
    height: u32,
    pixel: impl Fn(u32, u32) -> [u8; 3],
) -> std::io::Result<()> {
    let mut data = Vec::with_capacity((width * height * 3) as usize);
    for y in 0..height {
        for x in 0..width {
            data.extend(pixel(x, y));
        }
    }
    image::save_buffer_with_format(
        path,
        &data,
        width,
        height,
        image::ColorType::Rgb8,
        image::ImageFormat::Tga,
    )
    .map_err(std::io::Error::other)
}

/// The torus demo: ring radius 1, tube radius 0.35, tilted 25° about x, touching the floor.
pub fn torus_scene(dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let (major, minor, tilt) = (1.0f32, 0.35f32, 25f32.to_radians());
    // The tilted ring's lowest point is major·sin(tilt) below its centre; the tube adds minor.
    let centre = Vec3::new(0.3, -0.2, major * tilt.sin() + minor);
    let torus = Mesh::torus(major, minor, 119, 89).transformed(Mat3::from_rotation_x(tilt), centre);
    let mut obj = ObjWriter::new(
        "The thesis's demo object: a torus of 10,800 unique vertices.\nGenerated by prt-scenes (gen-scenes); do not edit.",
    );
    obj.object("torus", None, &torus);
    std::fs::write(dir.join("torus.obj"), obj.text)?;
    glossy_torus(dir, &torus)?;
    translucent_sphere(dir)?;

    std::fs::write(dir.join("planes.obj"), planes(29))?;
    fine_planes(dir)?;

    write_tga(&dir.join("checker.tga"), 256, 256, |x, y| {
        if ((x / 32) + (y / 32)) % 2 == 0 {
            [200, 200, 196]
        } else {
            [120, 122, 128]
        }
    })?;
    write_tga(&dir.join("torus.tga"), 256, 128, |x, y| {
        // Warm bands along the ring with a thin darker stripe around the tube.
        let band = ((x as f32 / 256.0 * std::f32::consts::TAU * 6.0).sin() * 0.5 + 0.5) * 60.0;
        let stripe = if y % 32 < 3 { 0.55 } else { 1.0 };
        [
            ((190.0 + band) * stripe) as u8,
            ((120.0 + band * 0.5) * stripe) as u8,
            (60.0 * stripe) as u8,
        ]
    })?;
    std::fs::write(
        dir.join("torus.scene"),
        "# The thesis's demo scene: a torus casting shadows on surrounding planes.\n\
         # One object per line: \"object.obj\" \"texture.tga\" (paths relative to this file).\n\
         \"torus.obj\" \"torus.tga\"\n\
         \"planes.obj\" \"checker.tga\"\n",
    )
}

/// The floor and two walls around the torus, each `cells` × `cells` quads over 6 × 6 units,
/// as OBJ text.
fn planes(cells: u32) -> String {
    let size = 6.0f32;
    let half = size / 2.0;
    let corner = Vec3::new(-half, -half, 0.0);
    let floor = Mesh::plane(corner, Vec3::X * size, Vec3::Y * size, cells, 3.0);
    let back = Mesh::plane(corner, Vec3::Y * size, Vec3::Z * size, cells, 3.0);
    let side = Mesh::plane(
        Vec3::new(-half, half, 0.0),
        Vec3::X * size,
        Vec3::Z * size,
        cells,
        3.0,
    );
    let per_plane = (cells + 1) * (cells + 1);
    let mut obj = ObjWriter::new(&format!(
        "Floor and two walls around the torus: 3 × {per_plane} vertices.\nGenerated by prt-scenes (gen-scenes); do not edit."
    ));
    obj.object("floor", None, &floor);
    obj.object("back_wall", None, &back);
    obj.object("side_wall", None, &side);
    obj.text
}

/// The demo with its floor and walls meshed twice as finely (`planes-fine.obj`, a vertex every
/// 0.1 units): `torus-fine.scene` and `glossy-fine.scene`. The demo's planes, a vertex every
/// 0.2 units, are coarser than the torus's contact shadow, which changes within 2–3 of their
/// vertices; a vertex bake can only be as sharp as its mesh, and a filter over the mesh's
/// neighbours no sharper. The denoiser's vertex measurements use both.
fn fine_planes(dir: &Path) -> std::io::Result<()> {
    std::fs::write(dir.join("planes-fine.obj"), planes(59))?;
    for (name, torus, what) in [
        ("torus-fine.scene", "torus.obj", "The thesis's demo scene"),
        ("glossy-fine.scene", "torus-glossy.obj", "The glossy demo"),
    ] {
        std::fs::write(
            dir.join(name),
            format!(
                "# {what} with its floor and walls meshed at a vertex every 0.1 units, twice as\n\
                 # finely: fine enough for a vertex bake to resolve the torus's contact shadow.\n\
                 \"{torus}\" \"torus.tga\"\n\
                 \"planes-fine.obj\" \"checker.tga\"\n"
            ),
        )?;
    }
    Ok(())
}

/// The glossy demo (`glossy.scene`): the same torus and planes, the torus with a
/// Phong layer from `torus-glossy.mtl` (Ks 0.25, Ns 24: at the order-4 matrix bakes it is
/// shown with, sharper lobes lose their shape to the band limit, see docs/guides/glossy.md). The
/// scene file cannot reach into another folder, so the torus is written again, with a
/// `mtllib`; the planes and textures are shared.
fn glossy_torus(dir: &Path, torus: &Mesh) -> std::io::Result<()> {
    let mut obj = ObjWriter::new(
        "The thesis's demo torus with a glossy material (glossy.scene).\nGenerated by prt-scenes (gen-scenes); do not edit.",
    );
    obj.text.push_str("mtllib torus-glossy.mtl\n");
    obj.object("torus", Some("glossy"), torus);
    std::fs::write(dir.join("torus-glossy.obj"), obj.text)?;
    std::fs::write(
        dir.join("torus-glossy.mtl"),
        "# A diffuse base (times torus.tga, which glossy.scene gives) under a Phong lobe:\n\
         # Ks is the fraction the lobe reflects, Ns its exponent (docs/guides/glossy.md).\n\
         newmtl glossy\nKd 0.75 0.75 0.75\nKs 0.25 0.25 0.25\nNs 24\n",
    )?;
    std::fs::write(
        dir.join("glossy.scene"),
        "# The thesis's demo scene with a glossy torus: bake it with\n\
         # `prt-bake bake glossy.scene --transfer matrix` and view it in prt-view.\n\
         \"torus-glossy.obj\" \"torus.tga\"\n\
         \"planes.obj\" \"checker.tga\"\n",
    )
}

/// The subsurface demo (`translucent.scene`, docs/guides/subsurface.md): the torus
/// scene with a wax sphere beside the torus, whose medium `translucent.toml` gives
/// (`prt-bake bake translucent.scene --materials translucent.toml`).
fn translucent_sphere(dir: &Path) -> std::io::Result<()> {
    let sphere =
        Mesh::sphere(0.55, 48, 96).transformed(Mat3::IDENTITY, Vec3::new(-1.4, -2.15, 0.55));
    let mut obj = ObjWriter::new(
        "A wax sphere beside the torus (translucent.scene).\nGenerated by prt-scenes (gen-scenes); do not edit.",
    );
    obj.text.push_str("mtllib wax.mtl\n");
    obj.object("wax", Some("wax"), &sphere);
    std::fs::write(dir.join("wax.obj"), obj.text)?;
    std::fs::write(
        dir.join("wax.mtl"),
        "# White: the wax's colour is its medium's (translucent.toml), baked into the transfer.\n\
         newmtl wax\nKd 1 1 1\n",
    )?;
    std::fs::write(
        dir.join("translucent.toml"),
        "# The wax sphere's medium (docs/guides/subsurface.md): per scene unit, R G B.\n\
         [material.wax.subsurface]\n\
         # σt = σs′ + σa is 8 in every channel, so the three channels share their walks.\n\
         scattering = [7.96, 7.76, 6.8]  # reduced scattering coefficient σs′\n\
         absorption = [0.04, 0.24, 1.2]  # absorption coefficient σa\n\
         ior = 1.4\n",
    )?;
    std::fs::write(
        dir.join("translucent.scene"),
        "# The thesis's demo scene with a translucent wax sphere: bake it with\n\
         # `prt-bake bake translucent.scene --materials translucent.toml`.\n\
         \"torus.obj\" \"torus.tga\"\n\
         \"planes.obj\" \"checker.tga\"\n\
         \"wax.obj\"\n",
    )
}

/// A box of the given size standing on the floor, rotated about z; five faces (no bottom),
/// each a grid of `cells`², with flat per-face normals.
fn open_box(centre: Vec2, size: Vec3, angle_degrees: f32, cells: u32) -> Vec<(String, Mesh)> {
    let (hx, hy, h) = (size.x / 2.0, size.y / 2.0, size.z);
    let faces = [
        (
            "top",
            Vec3::new(-hx, -hy, h),
            Vec3::X * size.x,
            Vec3::Y * size.y,
        ),
        (
            "front",
            Vec3::new(-hx, -hy, 0.0),
            Vec3::X * size.x,
            Vec3::Z * h,
        ),
        (
            "back",
            Vec3::new(hx, hy, 0.0),
            -Vec3::X * size.x,
            Vec3::Z * h,
        ),
        (
            "left",
            Vec3::new(-hx, hy, 0.0),
            -Vec3::Y * size.y,
            Vec3::Z * h,
        ),
        (
            "right",
            Vec3::new(hx, -hy, 0.0),
            Vec3::Y * size.y,
            Vec3::Z * h,
        ),
    ];
    let rotation = Mat3::from_rotation_z(angle_degrees.to_radians());
    faces
        .into_iter()
        .map(|(name, origin, eu, ev)| {
            let mesh =
                Mesh::plane(origin, eu, ev, cells, 1.0).transformed(rotation, centre.extend(0.0));
            (name.to_string(), mesh)
        })
        .collect()
}

/// The Cornell-like room: x in [−1, 1] (red at −1, green at +1), y in [−1, 1] (open at −1),
/// floor at z = 0, walls 2 high, no ceiling.
pub fn cornell_scene(dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let cells = 23; // 24 × 24 vertices per wall
    let mut obj = ObjWriter::new(
        "A Cornell-box-like room, open at the front (−y) and the top.\nGenerated by prt-scenes (gen-scenes); do not edit.",
    );
    obj.text.push_str("mtllib cornell.mtl\n");
    let floor = Mesh::plane(
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::X * 2.0,
        Vec3::Y * 2.0,
        cells,
        1.0,
    );
    let back = Mesh::plane(
        Vec3::new(-1.0, 1.0, 0.0),
        Vec3::X * 2.0,
        Vec3::Z * 2.0,
        cells,
        1.0,
    );
    let left = Mesh::plane(
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::Y * 2.0,
        Vec3::Z * 2.0,
        cells,
        1.0,
    );
    let right = Mesh::plane(
        Vec3::new(1.0, 1.0, 0.0),
        -Vec3::Y * 2.0,
        Vec3::Z * 2.0,
        cells,
        1.0,
    );
    obj.object("floor", Some("white"), &floor);
    obj.object("back_wall", Some("white"), &back);
    obj.object("left_wall", Some("red"), &left);
    obj.object("right_wall", Some("green"), &right);
    for (name, mesh) in open_box(Vec2::new(0.35, -0.3), Vec3::new(0.6, 0.6, 0.6), -17.0, 7) {
        obj.object(&format!("short_box_{name}"), Some("white"), &mesh);
    }
    for (name, mesh) in open_box(Vec2::new(-0.35, 0.35), Vec3::new(0.6, 0.6, 1.2), 17.0, 7) {
        obj.object(&format!("tall_box_{name}"), Some("white"), &mesh);
    }
    std::fs::write(dir.join("cornell.obj"), obj.text)?;
    std::fs::write(
        dir.join("cornell.mtl"),
        "# Reflectances of the original Cornell box.\n\
         newmtl white\nKd 0.73 0.73 0.73\n\n\
         newmtl red\nKd 0.63 0.065 0.05\n\n\
         newmtl green\nKd 0.14 0.45 0.091\n",
    )?;
    std::fs::write(
        dir.join("cornell.scene"),
        "# A Cornell-box-like room with coloured walls and two boxes.\n\"cornell.obj\"\n",
    )
}

/// Writes every demo scene under `dir`.
pub fn write_all(dir: &Path) -> std::io::Result<()> {
    torus_scene(&dir.join("torus"))?;
    tube::tube_scene(&dir.join("tube"))?;
    cornell_scene(&dir.join("cornell"))
}
