//! A ribbed tube, straight and bent 90° at its middle: the LDPRT guide's and tests' mesh
//! (docs/guides/characters.md). Both OBJs have the same vertices and triangles, so an LDPRT
//! bake of the straight one relights on the bent one.

use std::fmt::Write as _;
use std::path::Path;

use glam::Vec3;

const RADIUS: f32 = 0.2;
const AROUND: usize = 24;
const ALONG: usize = 96;
const LENGTH: f32 = 2.0;
const BEND_RADIUS: f32 = 0.3;

/// The tube along +z, radius 0.2 ± 12 % (a rib every 0.125), and its triangles.
pub fn tube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::new();
    for j in 0..=ALONG {
        let z = LENGTH * j as f32 / ALONG as f32;
        let r = RADIUS * (1.0 + 0.12 * (std::f32::consts::TAU * z / 0.125).cos());
        for i in 0..AROUND {
            let phi = std::f32::consts::TAU * i as f32 / AROUND as f32;
            positions.push(Vec3::new(r * phi.cos(), r * phi.sin(), z));
        }
    }
    let at = |i: usize, j: usize| (j * AROUND + i % AROUND) as u32;
    let mut triangles = Vec::new();
    for j in 0..ALONG {
        for i in 0..AROUND {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (positions, triangles)
}

/// The tube bent 90° towards +x: a quarter circle of radius 0.3 about the middle, the far
/// half turned rigidly.
pub fn bend(p: Vec3) -> Vec3 {
    let arc = BEND_RADIUS * std::f32::consts::FRAC_PI_2;
    let (z0, z1) = (0.5 * (LENGTH - arc), 0.5 * (LENGTH + arc));
    let arm = BEND_RADIUS - p.x;
    if p.z <= z0 {
        p
    } else if p.z <= z1 {
        let theta = (p.z - z0) / BEND_RADIUS;
        Vec3::new(BEND_RADIUS - arm * theta.cos(), p.y, z0 + arm * theta.sin())
    } else {
        Vec3::new(BEND_RADIUS + (p.z - z1), p.y, z0 + arm)
    }
}

fn obj(positions: &[Vec3], triangles: &[[u32; 3]]) -> String {
    let mut text =
        String::from("# a ribbed tube (prt-scenes); no normals: readers compute them\no tube\n");
    for p in positions {
        let _ = writeln!(text, "v {:.6} {:.6} {:.6}", p.x, p.y, p.z);
    }
    for t in triangles {
        let _ = writeln!(text, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    text
}

/// Writes `tube.obj`, `tube-bent.obj` and `tube-skinned.glb` into `dir`.
pub fn tube_scene(dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let (positions, triangles) = tube();
    let bent: Vec<Vec3> = positions.iter().map(|p| bend(*p)).collect();
    std::fs::write(dir.join("tube.obj"), obj(&positions, &triangles))?;
    std::fs::write(dir.join("tube-bent.obj"), obj(&bent, &triangles))?;
    std::fs::write(
        dir.join("tube-skinned.glb"),
        crate::skinned_tube::skinned_tube_glb(),
    )
}
