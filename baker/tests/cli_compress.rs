//! End-to-end tests of `prt-bake compress` and of version-2 (CPCA-compressed) coefficient
//! files in `inspect`, `export --npz` and `relight` (docs/reference/coefficient-format.md, "Compressed
//! files").

mod common;

use std::io::Read;

use common::{EXIT_BAD_COMMAND_LINE, Scratch};

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);
const RIG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../viewer/src/default-rig.toml"
);

fn inspect(s: &Scratch, file: &str) -> serde_json::Value {
    let run = s.run(&["inspect", file]).success();
    serde_json::from_str(&run.stdout).expect("inspect prints JSON")
}

/// The `transfer` array of an npz export (little-endian float32 after the .npy header).
fn npz_transfer(s: &Scratch, name: &str) -> Vec<f32> {
    let file = std::fs::File::open(s.path(name)).unwrap();
    let mut zip = zip::ZipArchive::new(file).expect("a zip archive");
    let mut bytes = Vec::new();
    zip.by_name("transfer.npy")
        .unwrap()
        .read_to_end(&mut bytes)
        .unwrap();
    let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    bytes[10 + header..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// RMS of a − b relative to the RMS of b.
fn relative_rms(a: &[f32], b: &[f32]) -> f64 {
    assert_eq!(a.len(), b.len());
    let d: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
        .sum();
    let n: f64 = b.iter().map(|y| f64::from(*y).powi(2)).sum();
    (d / n).sqrt()
}

/// `bytes` with a fresh checksum (bytes 124..128), so only the change under test is wrong.
fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&bytes[..124]);
    hasher.update(&[0; 4]);
    hasher.update(&bytes[128..]);
    let sum = hasher.finalize();
    bytes[124..128].copy_from_slice(&sum.to_le_bytes());
    bytes
}

#[test]
fn one_cluster_per_vertex_is_lossless_and_the_input_is_untouched() {
    let s = Scratch::new();
    s.bake(CORNELL, "c.prt", &["--order", "3", "--aux", "ao"]);
    let original = s.read("out/c.prt");
    s.run(&[
        "compress",
        "out/c.prt",
        "-o",
        "out/z.prt",
        "--clusters",
        "100000",
        "--pcs",
        "1",
    ])
    .success();
    assert_eq!(s.read("out/c.prt"), original, "the input changed");
    let json = inspect(&s, "out/z.prt");
    assert_eq!(json["version"], 2);
    assert_eq!(json["compression"]["clusters"], 2944);
    assert_eq!(json["compression"]["rms_error"], 0.0);
    // The version-1 file reads as before: no compression, version 1.
    let v1 = inspect(&s, "out/c.prt");
    assert_eq!(v1["version"], 1);
    assert!(v1.get("compression").is_none());
    for (file, npz) in [("out/c.prt", "out/c.npz"), ("out/z.prt", "out/z.npz")] {
        s.run(&["export", file, "--scene", CORNELL, "--npz", npz])
            .success();
    }
    let (a, b) = (npz_transfer(&s, "out/c.npz"), npz_transfer(&s, "out/z.npz"));
    let bits = |x: &[f32]| x.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a), bits(&b));
}

#[test]
fn relit_error_falls_with_clusters_and_components() {
    let s = Scratch::new();
    s.bake(
        CORNELL,
        "ir.prt",
        &["--mode", "interreflected", "--samples", "1024"],
    );
    s.run(&[
        "relight",
        CORNELL,
        "out/ir.prt",
        "--lights",
        RIG,
        "-o",
        "out/ir.ply",
    ])
    .success();
    let reference = s.ply_radiance("out/ir.ply").concat();
    let mut errors = Vec::new();
    for (k, m) in [(4, 4), (16, 4), (64, 4), (64, 1), (64, 2), (64, 8)] {
        let (k, m) = (k.to_string(), m.to_string());
        let run = s
            .run(&[
                "compress",
                "out/ir.prt",
                "-o",
                "out/z.prt",
                "--clusters",
                &k,
                "--pcs",
                &m,
            ])
            .success();
        assert!(run.stdout.starts_with("compressed to "), "{}", run.stdout);
        s.run(&[
            "relight",
            CORNELL,
            "out/z.prt",
            "--lights",
            RIG,
            "-o",
            "out/z.ply",
        ])
        .success();
        let json = inspect(&s, "out/z.prt");
        let c = &json["compression"];
        let floats = c["floats_per_vertex"].as_f64().unwrap();
        errors.push((
            c["rms_error"].as_f64().unwrap(),
            relative_rms(&s.ply_radiance("out/z.ply").concat(), &reference),
            floats,
        ));
    }
    // K = 4, 16, 64 at M = 4, then M = 1, 2, 4, 8 at K = 64.
    println!("(coefficient rms, relit relative rms, floats per vertex): {errors:?}");
    let [k4, k16, k64, m1, m2, m8] = errors[..] else {
        unreachable!()
    };
    for (more, fewer) in [(k16, k4), (k64, k16), (m2, m1), (k64, m2), (m8, k64)] {
        assert!(more.0 < fewer.0, "coefficient error {errors:?}");
        assert!(more.1 < fewer.1, "relit error {errors:?}");
    }
    // Against 48 floats per vertex raw. 64 × 4 stores under a third of them but misses 1 % on
    // this small room (2.1 %; docs/explanation/performance.md, "CPCA compression"); 64 × 8 meets 1 %.
    assert!(k64.1 < 0.025, "relit rms error {}", k64.1);
    assert!(k64.2 <= 48.0 / 3.0, "{} floats per vertex", k64.2);
    assert!(m8.1 < 0.01, "relit rms error {}", m8.1);
}

#[test]
fn texel_bakes_compress_and_export() {
    let s = Scratch::new();
    s.bake(CORNELL, "lm.prt", &["--lightmap", "32", "--order", "3"]);
    s.run(&[
        "compress",
        "out/lm.prt",
        "-o",
        "out/z.prt",
        "--clusters",
        "32",
        "--pcs",
        "3",
    ])
    .success();
    let json = inspect(&s, "out/z.prt");
    assert_eq!(json["lightmap"]["width"], 32);
    assert_eq!(json["compression"]["pcs"], 3);
    for (file, npz) in [("out/lm.prt", "out/lm.npz"), ("out/z.prt", "out/z.npz")] {
        s.run(&["export", file, "--scene", CORNELL, "--npz", npz])
            .success();
    }
    let (a, b) = (
        npz_transfer(&s, "out/lm.npz"),
        npz_transfer(&s, "out/z.npz"),
    );
    let rms = json["compression"]["rms_error"].as_f64().unwrap();
    let found = (relative_rms(&b, &a)
        * (a.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>() / a.len() as f64).sqrt())
    .abs();
    assert!((found - rms).abs() <= 1e-3 * rms + 1e-7, "{found} vs {rms}");
    s.run(&[
        "relight",
        CORNELL,
        "out/z.prt",
        "--lights",
        RIG,
        "-o",
        "out/z.exr",
    ])
    .success();
}

#[test]
fn corrupted_compressed_files_are_refused_with_exit_3() {
    let s = Scratch::new();
    s.bake(CORNELL, "c.prt", &["--order", "2"]);
    s.run(&[
        "compress",
        "out/c.prt",
        "-o",
        "out/z.prt",
        "--clusters",
        "8",
        "--pcs",
        "2",
    ])
    .success();
    let good = s.read("out/z.prt");
    // Cluster means: 8 × 4 floats from byte 160, bases 8 × 2 × 4, then 2944 indices.
    let indices = 160 + 4 * (8 * 4 + 8 * 2 * 4);
    let weights = indices + 4 * 2944;
    let mut flipped = good.clone();
    flipped[200] ^= 4;
    let set = |at: usize, value: u32| {
        let mut b = good.clone();
        b[at..at + 4].copy_from_slice(&value.to_le_bytes());
        resealed(b)
    };
    let cases: [(&str, Vec<u8>, &str); 7] = [
        ("flipped.prt", flipped, "checksum mismatch"),
        ("short.prt", good[..good.len() - 8].to_vec(), "truncated"),
        (
            "index.prt",
            set(indices + 40, 8),
            "receiver 10 is in cluster 8, of 8",
        ),
        (
            "weight.prt",
            set(weights + 4, f32::NAN.to_bits()),
            "weight 1 of receiver 0",
        ),
        (
            "mean.prt",
            set(164, f32::INFINITY.to_bits()),
            "mean 1 of cluster 0",
        ),
        (
            "clusters.prt",
            set(128, 3000),
            "3000 clusters for 2944 receivers",
        ),
        ("pcs.prt", set(132, 9), "9 principal components"),
    ];
    for (name, bytes, message) in cases {
        s.write(name, bytes);
        for args in [
            vec!["inspect", name],
            vec!["export", name, "--scene", CORNELL, "--npz", "out/x.npz"],
            vec!["relight", CORNELL, name, "--lights", RIG, "-o", "out/x.ply"],
            vec!["compress", name, "-o", "out/x.prt"],
        ] {
            s.run(&args)
                .fails_with_bad_input(&[&format!("{name}: {message}")]);
        }
    }
    // Bad options are a bad command line, and nothing is written.
    for (k, m, message) in [
        ("0", "2", "--clusters must be at least 1"),
        ("8", "5", "--pcs 5"),
    ] {
        s.run(&[
            "compress",
            "out/c.prt",
            "-o",
            "out/x.prt",
            "--clusters",
            k,
            "--pcs",
            m,
        ])
        .fails_with(EXIT_BAD_COMMAND_LINE, &[message]);
    }
    s.assert_out_holds(&["c.prt", "z.prt"]);
}

#[test]
fn bake_with_clusters_writes_what_compress_writes() {
    let s = Scratch::new();
    s.bake(CORNELL, "c.prt", &["--order", "3"]);
    let run = s.bake(
        CORNELL,
        "inline.prt",
        &["--order", "3", "--clusters", "16", "--pcs", "2"],
    );
    assert!(
        run.stdout
            .contains("compressed to 16 clusters × 2 components"),
        "{}",
        run.stdout
    );
    s.run(&[
        "compress",
        "out/c.prt",
        "-o",
        "out/z.prt",
        "--clusters",
        "16",
        "--pcs",
        "2",
    ])
    .success();
    assert_eq!(s.read("out/inline.prt"), s.read("out/z.prt"));
    // Fitted for lights above the horizon: the same file both ways, another fit.
    let upper = [
        "--clusters",
        "16",
        "--pcs",
        "2",
        "--light-prior",
        "upper-hemisphere",
    ];
    s.bake(
        CORNELL,
        "inline-up.prt",
        &[&["--order", "3"][..], &upper[..]].concat(),
    );
    s.run(
        &[
            &["compress", "out/c.prt", "-o", "out/z-up.prt"][..],
            &upper[..],
        ]
        .concat(),
    )
    .success();
    assert_eq!(s.read("out/inline-up.prt"), s.read("out/z-up.prt"));
    assert_ne!(s.read("out/z-up.prt"), s.read("out/z.prt"));
    // One start fits no better than the default four, and says which seeding it kept.
    let one = ["--clusters", "16", "--pcs", "2", "--starts", "1"];
    s.run(
        &[
            &["compress", "out/c.prt", "-o", "out/z-one.prt"][..],
            &one[..],
        ]
        .concat(),
    )
    .success();
    let (four, one) = (inspect(&s, "out/z.prt"), inspect(&s, "out/z-one.prt"));
    let rms = |j: &serde_json::Value| j["compression"]["rms_error"].as_f64().unwrap();
    assert!(rms(&four) <= rms(&one), "{four} {one}");
    assert_eq!(one["compression"]["seed"], "51072003c9ca0001");
    for (extra, message) in [
        (&["--clusters", "0"][..], "--clusters must be at least 1"),
        (
            &["--pcs", "10"][..],
            "--pcs 10 is more than the 9 coefficients",
        ),
        (
            &["--pcs", "2", "--shard", "0/2"][..],
            "cannot be used with '--shard",
        ),
        (
            &["--light-prior", "upper-hemisphere"][..],
            "--light-prior and --starts are for compressed bakes",
        ),
        (
            &["--starts", "2"][..],
            "--light-prior and --starts are for compressed bakes",
        ),
        (
            &["--pcs", "2", "--starts", "0"][..],
            "--starts must be at least 1",
        ),
    ] {
        let mut args = vec!["bake", CORNELL, "-o", "out/x.prt", "--order", "3"];
        args.extend(extra);
        s.run(&args).fails_with(EXIT_BAD_COMMAND_LINE, &[message]);
    }
    s.assert_out_holds(&[
        "c.prt",
        "inline.prt",
        "inline-up.prt",
        "z.prt",
        "z-one.prt",
        "z-up.prt",
    ]);
}
