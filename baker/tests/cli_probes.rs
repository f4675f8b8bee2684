//! End-to-end tests of `prt-bake bake --probes` (docs/guides/probes.md): a grid and a list of points,
//! `inspect`'s probe block, the arrays of `export --npz`, bit-identical files for any thread
//! count, and the errors: a bad points file (file and line), an odd `--samples`, options that
//! do not apply, and the commands that refuse a probe file.

mod common;

use std::io::Read;

use common::{EXIT_BAD_COMMAND_LINE, Scratch};

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);

/// The npy header text and data of array `name` of an npz export (little-endian float32).
fn npz_array(s: &Scratch, file: &str, name: &str) -> (String, Vec<f32>) {
    let zip_file = std::fs::File::open(s.path(file)).unwrap();
    let mut zip = zip::ZipArchive::new(zip_file).expect("a zip archive");
    let mut bytes = Vec::new();
    zip.by_name(&format!("{name}.npy"))
        .unwrap_or_else(|_| panic!("no {name} in {file}"))
        .read_to_end(&mut bytes)
        .unwrap();
    let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let text = String::from_utf8_lossy(&bytes[10..10 + header]).into_owned();
    let data = bytes[10 + header..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    (text, data)
}

#[test]
fn a_probe_grid_bakes_inspects_and_exports() {
    let s = Scratch::new();
    let grid = ["--probes", "grid:2,2,2", "--order", "3", "--samples", "256"];
    let run = s.bake(CORNELL, "p.prt", &grid);
    assert!(run.stdout.contains("baked 8 probes"), "{}", run.stdout);
    let inspect = s.run(&["inspect", "out/p.prt"]).success();
    let json: serde_json::Value = serde_json::from_str(&inspect.stdout).unwrap();
    assert_eq!(json["transfer"], "matrix");
    assert_eq!(json["probes"]["count"], 8);
    assert_eq!(
        json["probes"]["grid"]["counts"],
        serde_json::json!([2, 2, 2])
    );

    s.run(&[
        "export",
        "out/p.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/p.npz",
    ])
    .success();
    let (header, positions) = npz_array(&s, "out/p.npz", "probe_positions");
    assert!(header.contains("'shape': (8, 3)"), "{header}");
    let (header, transfer) = npz_array(&s, "out/p.npz", "probe_transfer");
    assert!(header.contains("'shape': (8, 1, 9, 9)"), "{header}");
    let (_, backfaces) = npz_array(&s, "out/p.npz", "probe_backface_fraction");
    assert_eq!((positions.len(), backfaces.len()), (24, 8));
    // Above the boxes (the upper layer, z = 1.5) a probe sees only front faces.
    assert!(backfaces[4..].iter().all(|&b| b < 0.25), "{backfaces:?}");
    assert!(transfer.iter().all(|x| x.is_finite()));

    // The same file for any thread count; a list of the grid's points gives its matrices.
    let threads = s.bake(
        CORNELL,
        "p1.prt",
        &[&grid[..], &["--threads", "1"]].concat(),
    );
    drop(threads);
    assert_eq!(s.read("out/p.prt"), s.read("out/p1.prt"));
    let points: String = positions
        .chunks_exact(3)
        .map(|p| format!("{:e} {:e} {:e}\n", p[0], p[1], p[2]))
        .collect();
    s.write("points.txt", format!("# the grid's probes\n{points}"));
    let list = ["--probes", "points.txt", "--order", "3", "--samples", "256"];
    s.bake(CORNELL, "l.prt", &list);
    s.run(&[
        "export",
        "out/l.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/l.npz",
    ])
    .success();
    assert_eq!(npz_array(&s, "out/l.npz", "probe_transfer").1, transfer);
    let inspect = s.run(&["inspect", "out/l.prt"]).success();
    assert!(!inspect.stdout.contains("\"grid\""), "{}", inspect.stdout);

    // Compressed (CPCA), a probe file keeps its probes; 8 probes in 8 clusters of 4
    // components are exact up to rounding.
    let compress = [
        "compress",
        "out/p.prt",
        "-o",
        "out/c.prt",
        "--clusters",
        "8",
    ];
    s.run(&compress).success();
    let inspect = s.run(&["inspect", "out/c.prt"]).success();
    assert!(inspect.stdout.contains("\"probes\""), "{}", inspect.stdout);
    s.run(&[
        "export",
        "out/c.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/c.npz",
    ])
    .success();
    assert_eq!(npz_array(&s, "out/c.npz", "probe_positions").1, positions);
    let compressed = npz_array(&s, "out/c.npz", "probe_transfer").1;
    let worst = compressed
        .iter()
        .zip(&transfer)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "compressed probes off by {worst}");
}

#[test]
fn probe_errors_name_what_is_wrong() {
    let s = Scratch::new();
    s.write("bad.txt", "0 0 1\n\n1 2 x\n");
    let bad = s.run(&["bake", CORNELL, "-o", "out.prt", "--probes", "bad.txt"]);
    bad.fails_with_bad_input(&["bad.txt:3", "`x` is not a finite number"]);
    s.write("p.txt", "0 0 1\n");
    let odd = s.run(&[
        "bake",
        CORNELL,
        "-o",
        "out.prt",
        "--probes",
        "p.txt",
        "--samples",
        "7",
    ]);
    odd.fails_with(EXIT_BAD_COMMAND_LINE, &["even --samples"]);
    let grid = s.run(&["bake", CORNELL, "-o", "out.prt", "--probes", "grid:2,2"]);
    grid.fails_with(EXIT_BAD_COMMAND_LINE, &["three counts"]);
    let lightmap = s.run(&[
        "bake",
        CORNELL,
        "-o",
        "o.prt",
        "--probes",
        "p.txt",
        "--lightmap",
        "64",
    ]);
    assert_eq!(
        lightmap.code,
        Some(EXIT_BAD_COMMAND_LINE),
        "{}",
        lightmap.stderr
    );
    assert!(!s.path("out.prt").exists() && !s.path("o.prt").exists());

    // Readers of vertex bakes refuse a probe file, and say what it is.
    s.bake(CORNELL, "p.prt", &["--probes", "p.txt", "--samples", "64"]);
    s.write(
        "rig.toml",
        "[[light]]\nkind = \"constant\"\nintensity = 1\n",
    );
    let relight = s.run(&[
        "relight",
        CORNELL,
        "out/p.prt",
        "--lights",
        "rig.toml",
        "-o",
        "out/x.ply",
    ]);
    relight.fails_with_bad_input(&["a probe bake (1 probes)"]);
    s.assert_out_holds(&["p.prt"]);
}

#[test]
fn a_rigid_object_is_relit_through_the_probes() {
    let s = Scratch::new();
    // A patch facing +z in its own frame, baked alone.
    s.write(
        "patch.obj",
        "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
    );
    s.bake(
        "patch.obj",
        "patch.prt",
        &["--order", "3", "--mode", "unshadowed"],
    );
    let grid = ["--probes", "grid:3,3,3", "--order", "3", "--samples", "256"];
    s.bake(CORNELL, "p.prt", &grid);
    s.write(
        "sky.toml",
        "[[light]]\nkind = \"constant\"\nintensity = 1\n",
    );
    let relight = |out: &str, turn: Option<&str>| {
        let mut args = vec![
            "relight",
            "patch.obj",
            "out/patch.prt",
            "--lights",
            "sky.toml",
            "-o",
            out,
            "--probes",
            "out/p.prt",
            "--at",
            "0,0,1.5",
        ];
        if let Some(turn) = turn {
            args.extend(["--turn", turn]);
        }
        s.run(&args).success()
    };
    // Above the boxes, in the open-topped room: facing up the patch sees the sky, turned
    // upside down the floor and the boxes, darker.
    let up = relight("out/up.ply", None);
    assert!(up.stdout.contains("rigid object"), "{}", up.stdout);
    let up = s.ply_radiance("out/up.ply")[..3].to_vec();
    let down = relight("out/down.ply", Some("1,0,0,180"));
    drop(down);
    let down = s.ply_radiance("out/down.ply")[..3].to_vec();
    for (u, d) in up.iter().zip(&down) {
        assert!(
            u.iter().chain(d).all(|x| x.is_finite() && *x >= -1e-3),
            "{u:?} {d:?}"
        );
        assert!(u[0] > d[0] + 0.05, "{u:?} vs {d:?}");
    }

    // Probes of a list of points cannot be interpolated.
    s.write("p.txt", "0 0 0\n");
    s.bake(
        CORNELL,
        "l.prt",
        &["--probes", "p.txt", "--order", "3", "--samples", "64"],
    );
    let list = s.run(&[
        "relight",
        "patch.obj",
        "out/patch.prt",
        "--lights",
        "sky.toml",
        "-o",
        "out/x.ply",
        "--probes",
        "out/l.prt",
        "--at",
        "0,0,0",
    ]);
    list.fails_with_bad_input(&["needs a grid"]);
}
