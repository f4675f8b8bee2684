//! End-to-end tests of `prt-bake relight` on transfer-matrix bakes (docs/guides/glossy.md, "Glossy
//! rendering"): diffuse without `--view`, glossy with it, compressed matrix files, and the
//! usage errors (`--view` on a vector bake, a malformed `--view`).

mod common;

use common::{EXIT_BAD_COMMAND_LINE, Scratch};

/// A 3 × 3-vertex floor of a glossy material under a small roof (so some rays are blocked).
const OBJ: &str = "mtllib shiny.mtl\n\
    v -1 -1 0\nv 0 -1 0\nv 1 -1 0\nv -1 0 0\nv 0 0 0\nv 1 0 0\nv -1 1 0\nv 0 1 0\nv 1 1 0\n\
    v -0.3 -0.3 0.5\nv 0.3 -0.3 0.5\nv 0.3 0.3 0.5\nv -0.3 0.3 0.5\n\
    usemtl shiny\n\
    f 1 2 5\nf 1 5 4\nf 2 3 6\nf 2 6 5\nf 4 5 8\nf 4 8 7\nf 5 6 9\nf 5 9 8\n\
    usemtl matte\n\
    f 10 13 12\nf 10 12 11\n";
const MTL: &str = "newmtl shiny\nKd 0.3 0.3 0.3\nKs 0.5 0.4 0.3\nNs 20\n\
    newmtl matte\nKd 0.5 0.5 0.5\n";
const RIG: &str = "[[light]]\nkind = \"directional\"\ntheta = 30\nphi = 200\nintensity = 2\n\n\
    [[light]]\nkind = \"constant\"\nintensity = 0.1\n";

fn scratch() -> Scratch {
    let s = Scratch::new();
    s.write("floor.obj", OBJ);
    s.write("shiny.mtl", MTL);
    s.write("rig.toml", RIG);
    s
}

fn relight(s: &Scratch, file: &str, out: &str, view: Option<&str>) -> common::Run {
    let mut args = vec![
        "relight",
        "floor.obj",
        file,
        "--lights",
        "rig.toml",
        "-o",
        out,
    ];
    if let Some(view) = view {
        args.extend(["--view", view]);
    }
    s.run(&args)
}

#[test]
fn matrix_bakes_relight_diffuse_and_glossy_and_compressed() {
    let s = scratch();
    s.bake(
        "floor.obj",
        "m.prt",
        &["--transfer", "matrix", "--samples", "1024"],
    );
    let diffuse = relight(&s, "out/m.prt", "out/diffuse.ply", None).success();
    assert!(
        diffuse.stdout.contains("transfer matrices, diffuse"),
        "{}",
        diffuse.stdout
    );
    let glossy = relight(&s, "out/m.prt", "out/glossy.ply", Some("-0.2,0.4,1.5")).success();
    assert!(
        glossy.stdout.contains("transfer matrices, glossy"),
        "{}",
        glossy.stdout
    );
    let (d, g) = (
        s.ply_radiance("out/diffuse.ply"),
        s.ply_radiance("out/glossy.ply"),
    );
    // The floor (vertices 0..9) gains a glossy term proportional to Ks = (0.5, 0.4, 0.3) (the
    // diffuse term is grey, and MTL materials keep diffuse weight 1); the matte roof is
    // unchanged.
    for v in 0..9 {
        let added = |c: usize| g[v][c] - d[v][c];
        assert!(
            (added(0) * 0.3 - added(2) * 0.5).abs() < 1e-5,
            "vertex {v}: {:?} against {:?}",
            g[v],
            d[v]
        );
    }
    assert!((0..9).any(|v| g[v][0] > d[v][0] + 0.05), "{g:?} {d:?}");
    assert_eq!(g[9..], d[9..]);

    // One cluster per receiver reconstructs every matrix exactly (to f32 rounding): the
    // projection through the clusters gives the uncompressed radiance.
    s.run(&[
        "compress",
        "out/m.prt",
        "-o",
        "out/exact.prt",
        "--clusters",
        "13",
        "--pcs",
        "0",
    ])
    .success();
    relight(&s, "out/exact.prt", "out/exact.ply", Some("-0.2,0.4,1.5")).success();
    let exact = s.ply_radiance("out/exact.ply");
    for (a, b) in exact.iter().flatten().zip(g.iter().flatten()) {
        assert!((a - b).abs() <= 1e-5 * b.abs().max(1.0), "{a} against {b}");
    }
    s.run(&[
        "compress",
        "out/m.prt",
        "-o",
        "out/lossy.prt",
        "--clusters",
        "2",
        "--pcs",
        "1",
    ])
    .success();
    relight(&s, "out/lossy.prt", "out/lossy.ply", Some("-0.2,0.4,1.5")).success();
    s.assert_out_holds(&[
        "m.prt",
        "diffuse.ply",
        "glossy.ply",
        "exact.prt",
        "exact.ply",
        "lossy.prt",
        "lossy.ply",
    ]);
}

#[test]
fn a_view_is_a_usage_error_on_vector_bakes_and_when_malformed() {
    let s = scratch();
    s.bake("floor.obj", "v.prt", &[]);
    relight(&s, "out/v.prt", "out/x.ply", Some("0,0,2")).fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["--view renders the glossy layer", "v.prt"],
    );
    for bad in ["1,2", "1,2,3,4", "a,b,c", "1,2,inf", "1,,3"] {
        relight(&s, "out/v.prt", "out/x.ply", Some(bad)).fails_with(EXIT_BAD_COMMAND_LINE, &[bad]);
    }
    s.assert_out_holds(&["v.prt"]);
}
