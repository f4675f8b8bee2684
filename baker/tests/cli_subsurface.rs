//! `prt-bake bake --materials` (issue 31): a translucent cube's bake is RGB and glows, a bad
//! materials file is refused with its file, line and key (exit 3), and what subsurface bakes
//! do not support yet is refused as usage (exit 2), with nothing written. Texel bakes
//! (`--lightmap`) of translucent materials work as vertex bakes do.

use std::path::Path;
use std::process::{Command, Output};

/// A closed unit cube of material `jade`, its faces' vertices of their own.
const CUBE: &str = "mtllib cube.mtl\nusemtl jade\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";

fn bake(dir: &Path, mats: &str, extra: &[&str]) -> Output {
    std::fs::write(dir.join("cube.obj"), CUBE).unwrap();
    std::fs::write(dir.join("cube.mtl"), "newmtl jade\nKd 1 1 1\n").unwrap();
    std::fs::write(dir.join("mats.toml"), mats).unwrap();
    Command::new(env!("CARGO_BIN_EXE_prt-bake"))
        .arg("bake")
        .arg(dir.join("cube.obj"))
        .arg("--materials")
        .arg(dir.join("mats.toml"))
        .arg("-o")
        .arg(dir.join("out.prt"))
        .args(["--samples", "64", "--quiet"])
        .args(extra)
        .output()
        .unwrap()
}

const JADE: &str = "[material.jade.subsurface]\nscattering = [3, 4, 3]\nabsorption = [0.2, 0.05, 0.2]\nior = 1.5\n";

#[test]
fn a_translucent_bake_is_rgb() {
    // Per vertex and per texel, shadowed and interreflected.
    for extra in [
        &[][..],
        &["--lightmap", "32"][..],
        &["--lightmap", "32", "--mode", "interreflected"][..],
    ] {
        let dir = tempfile::tempdir().unwrap();
        let out = bake(dir.path(), JADE, extra);
        assert!(
            out.status.success(),
            "{extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let inspect = Command::new(env!("CARGO_BIN_EXE_prt-bake"))
            .arg("inspect")
            .arg(dir.path().join("out.prt"))
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&inspect.stdout);
        assert!(text.contains("\"channels\": 3"), "{extra:?}: {text}");
    }
}

#[test]
fn bad_materials_are_refused_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    for (mats, expected) in [
        (
            "[material.jade.subsurface]\nscattering = 1\nabsorption = -1\n",
            "mats.toml:3",
        ),
        (
            "[material.jade.subsurface]\nscattering = 1\nabsorption = 0\nior = inf\n",
            "mats.toml:4",
        ),
        ("[material.jade.subsurface]\nscatter = 1\n", "mats.toml:2"),
        (
            "\n[material.jadde.subsurface]\nscattering = 1\nabsorption = 0\n",
            "mats.toml:2",
        ),
    ] {
        let out = bake(dir.path(), mats, &[]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{mats}: {stderr}");
        assert!(stderr.contains(expected), "{mats}: {stderr}");
        assert!(!dir.path().join("out.prt").exists());
    }
}

#[test]
fn what_subsurface_bakes_lack_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    for extra in [
        &["--mode", "unshadowed"][..],
        &["--transfer", "matrix"][..],
    ] {
        let out = bake(dir.path(), JADE, extra);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(!dir.path().join("out.prt").exists());
    }
}
