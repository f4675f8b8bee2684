//! Texel bakes distributed stage by stage (docs/guides/clusters.md, "Stages"): `prepare-lightmap`
//! once, `bake --shard K/N --prepared`, `merge --direct`, per bounce `gather` per shard and
//! `merge --lower`; `factor-seams` once, then the last merge `--factor` (stitching with it), or
//! `--unstitched` and `stitch --columns J/M --factor` per shard and `stitch --join`. The
//! oracle is the whole bake's file, byte for byte.

mod common;

use common::*;

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);
const TORUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/torus/torus.scene");

/// Runs every stage of a bake of `scene` with `opts` in `n` shards and `m` stitch shards
/// (texel bakes; `m` = 0: a vertex bake, nothing to prepare or stitch) into `out/NAME.prt`.
fn staged(s: &Scratch, scene: &str, name: &str, opts: &[&str], n: u32, m: u32) -> String {
    let texels = m > 0;
    let out = |f: &str| format!("out/{name}-{f}");
    let prep = out("prep.lmp");
    let mut with_prep: Vec<&str> = opts.to_vec();
    if texels {
        let args = [&["prepare-lightmap", scene, "-o", &prep][..], opts].concat();
        let run = s.run(&args).success();
        assert!(run.stdout.contains("prepared "), "{}", run.stdout);
        with_prep.extend(["--prepared", &prep]);
    }
    // The seams' system factored once (`factor-seams`), beside the shards.
    let factor = out("seams.fac");
    if texels {
        let run = s.run(&["factor-seams", &prep, "-o", &factor]).success();
        assert!(run.stdout.contains("factored "), "{}", run.stdout);
    }
    let parts: Vec<String> = (0..n).map(|k| out(&format!("part-{k}.prt"))).collect();
    for (k, part) in parts.iter().enumerate() {
        let shard = format!("{k}/{n}");
        let args = [&with_prep[..], &["--shard", &shard]].concat();
        s.bake(scene, &part["out/".len()..], &args);
    }
    let lower = out("bounce-0.bnc");
    let mut args = vec!["merge", "--quiet", "--direct", "-o", &lower];
    args.extend(parts.iter().rev().map(String::as_str));
    s.run(&args).success();
    let bounces = 2;
    let mut lower = lower;
    let result = out("merged.prt");
    let unstitched = out("unstitched.prt");
    for b in 1..=bounces {
        let gathers: Vec<String> = (0..n).map(|k| out(&format!("g{b}-{k}.bnc"))).collect();
        for (part, gather) in parts.iter().zip(&gathers) {
            s.run(&["gather", "--quiet", part, "--lower", &lower, "-o", gather])
                .success();
        }
        let next = match (b == bounces, texels) {
            (false, _) => out(&format!("bounce-{b}.bnc")),
            (true, true) => unstitched.clone(),
            (true, false) => result.clone(),
        };
        let mut args = vec!["merge", "--quiet", "--lower", &lower, "-o", &next];
        if b == bounces && texels {
            args.push("--unstitched");
        }
        args.extend(gathers.iter().map(String::as_str));
        s.run(&args).success();
        if b == bounces && texels {
            // The last merge may stitch itself (`submit.sh --stitch-shards 0`).
            let stitched = out("merge-stitched.prt");
            let mut args = vec!["merge", "--quiet", "--lower", &lower, "-o", &stitched];
            args.extend(gathers.iter().rev().map(String::as_str));
            s.run(&args).success();
            // Or stitch with the factor (`submit.sh --stages`' default), writing the file.
            let with_factor = out("merge-factor.prt");
            let mut args = vec!["merge", "--quiet", "--lower", &lower, "--factor", &factor];
            args.extend(["-o", &with_factor]);
            args.extend(gathers.iter().map(String::as_str));
            let run = s.run(&args).success();
            assert!(run.stdout.contains("stitched with"), "{}", run.stdout);
            assert!(
                s.read(&with_factor) == s.read(&stitched),
                "{name}: the last merge's stitch with the factor differs from its own"
            );
        }
        lower = next;
    }
    if texels {
        // The stitch shards solve with the factor, the even ones checking it against the
        // prepared lightmap too.
        let columns: Vec<String> = (0..m).map(|j| out(&format!("c{j}.col"))).collect();
        for (j, column) in columns.iter().enumerate() {
            let shard = format!("{j}/{m}");
            let mut args = vec!["stitch", &unstitched, "--factor", &factor];
            if j % 2 == 0 {
                args.extend(["--prepared", &prep]);
            }
            args.extend(["--columns", &shard, "-o", column]);
            s.run(&args).success();
        }
        // Without the factor, a shard factors the system itself: the same columns.
        let factored_here = out("c0-prepared.col");
        let args = ["stitch", &unstitched, "--prepared", &prep, "--columns"];
        let shard = format!("0/{m}");
        s.run(&[&args[..], &[&shard, "-o", &factored_here]].concat())
            .success();
        assert!(
            s.read(&factored_here) == s.read(&columns[0]),
            "{name}: a stitch shard's columns differ with the stored factor"
        );
        let mut args = vec!["stitch", &unstitched, "-o", &result, "--join"];
        args.extend(columns.iter().rev().map(String::as_str));
        s.run(&args).success();
        assert!(
            s.read(&result) == s.read(&out("merge-stitched.prt")),
            "{name}: the last merge's stitch differs from the stitch in {m} column shards"
        );
    }
    result
}

fn assert_staged_is_whole(s: &Scratch, scene: &str, name: &str, opts: &[&str], n: u32, m: u32) {
    s.bake(scene, &format!("{name}.prt"), opts);
    let merged = staged(s, scene, name, opts, n, m);
    assert!(
        s.read(&format!("out/{name}.prt")) == s.read(&merged),
        "{name}: the staged bake ({n} shards, {m} stitch shards) differs from the whole bake"
    );
}

#[test]
fn staged_bakes_equal_the_whole_bake() {
    let s = Scratch::new();
    let lightmap = [
        "--mode",
        "interreflected",
        "--bounces",
        "2",
        "--lightmap",
        "40",
    ];
    // The room: RGB bounces (T₀ grey, then 3 channels), leaking texels moved and left out.
    let room = [
        &lightmap[..],
        &["--aux", "ao,bent-normal", "--samples", "32"],
    ]
    .concat();
    assert_staged_is_whole(&s, CORNELL, "room", &room, 3, 3);
    // Denoised: the last bounce's gathers carry their parts' guides (and aux arrays), and the
    // last merge denoises the total before placing the lightmap, as the whole bake does.
    let denoised = [&room[..], &["--denoise", "on"]].concat();
    assert_staged_is_whole(&s, CORNELL, "room-denoised", &denoised, 2, 2);
    assert!(s.read("out/room-denoised.prt") != s.read("out/room.prt"));
    // The torus's unwrapped charts meet at smooth seams: the stitch shards do the work.
    let torus = [
        &lightmap[..],
        &["--atlas", "unwrap", "--aux", "ao", "--samples", "32"],
    ]
    .concat();
    assert_staged_is_whole(&s, TORUS, "torus1", &torus, 1, 1);
    assert_staged_is_whole(&s, TORUS, "torus2", &torus, 2, 2);
    assert!(
        s.read("out/torus2-unstitched.prt") != s.read("out/torus2.prt"),
        "stitching changed nothing: the test would not see a wrong stitch"
    );
    // A vertex bake distributed bounce by bounce, too.
    let vertices = [
        "--mode",
        "interreflected",
        "--bounces",
        "2",
        "--samples",
        "32",
    ];
    assert_staged_is_whole(&s, CORNELL, "vertices", &vertices, 2, 0);
    let denoised = [&vertices[..], &["--denoise", "on"]].concat();
    assert_staged_is_whole(&s, CORNELL, "vertices-denoised", &denoised, 2, 0);
}

#[test]
fn mismatched_stage_files_are_refused() {
    let s = Scratch::new();
    let opts = [
        "--mode",
        "interreflected",
        "--bounces",
        "2",
        "--lightmap",
        "24",
    ];
    let opts = [&opts[..], &["--samples", "16"]].concat();
    staged(&s, CORNELL, "a", &opts, 2, 2);
    // A prepared lightmap of another seed.
    let args = [&opts[..], &["--seed", "7", "--shard", "0/2"]].concat();
    let args = [&args[..], &["--prepared", "out/a-prep.lmp"]].concat();
    let run = s.run(&[&["bake", CORNELL, "-o", "out/x.prt"][..], &args].concat());
    run.fails_with(
        3,
        &[
            "out/a-prep.lmp",
            "a prepared lightmap of another scene or other options",
        ],
    );
    // A corrupted prepared lightmap (one byte of a texel's point changed).
    let mut bytes = s.read("out/a-prep.lmp");
    let at = bytes.len() - 5;
    bytes[at] ^= 1;
    s.write("out/bad.lmp", &bytes);
    let args = [&opts[..], &["--shard", "0/2", "--prepared", "out/bad.lmp"]].concat();
    let run = s.run(&[&["bake", CORNELL, "-o", "out/x.prt"][..], &args].concat());
    run.fails_with(3, &["out/bad.lmp", "checksum mismatch"]);
    // A prepared lightmap of another atlas, to stitch with.
    let planar = [&opts[..], &["--atlas", "planar"]].concat();
    s.run(
        &[
            &["prepare-lightmap", CORNELL, "-o", "out/planar.lmp"][..],
            &planar,
        ]
        .concat(),
    )
    .success();
    let run = s.run(&[
        "stitch",
        "out/a-unstitched.prt",
        "--prepared",
        "out/planar.lmp",
        "--columns",
        "0/2",
        "-o",
        "out/x.col",
    ]);
    run.fails_with(3, &["out/a-unstitched.prt", "another atlas"]);
    // A seam factor of another prepared lightmap: refused against the file and against the
    // prepared lightmap; a corrupted one; a stitch shard with neither.
    s.run(&["factor-seams", "out/planar.lmp", "-o", "out/planar.fac"])
        .success();
    let stitch = ["stitch", "out/a-unstitched.prt", "--columns", "0/2"];
    s.run(
        &[
            &stitch[..],
            &["--factor", "out/planar.fac", "-o", "out/x.col"],
        ]
        .concat(),
    )
    .fails_with(
        3,
        &["out/planar.fac", "the seam factor of another prepared"],
    );
    let both = [
        "--factor",
        "out/a-seams.fac",
        "--prepared",
        "out/planar.lmp",
    ];
    s.run(&[&stitch[..], &both, &["-o", "out/x.col"]].concat())
        .fails_with(3, &["out/a-seams.fac", "than out/planar.lmp"]);
    let mut bytes = s.read("out/a-seams.fac");
    let at = bytes.len() - 3;
    bytes[at] ^= 1;
    s.write("out/bad.fac", &bytes);
    s.run(&[&stitch[..], &["--factor", "out/bad.fac", "-o", "out/x.col"]].concat())
        .fails_with(3, &["out/bad.fac", "checksum mismatch"]);
    s.run(&[&stitch[..], &["-o", "out/x.col"]].concat())
        .fails_with(2, &["--prepared FILE or --factor FILE"]);
    // --factor before the last bounce: refused (the merge writes a bounce file).
    let args = [
        "merge",
        "--lower",
        "out/a-bounce-0.bnc",
        "--factor",
        "out/a-seams.fac",
    ];
    s.run(
        &[
            &args[..],
            &["-o", "out/x.prt", "out/a-g1-0.bnc", "out/a-g1-1.bnc"],
        ]
        .concat(),
    )
    .fails_with(
        3,
        &["bounce 1 of 2", "give --factor to the last bounce's merge"],
    );
    // A missing gather, a gather of another bounce, a missing column file.
    let lower = ["merge", "--lower", "out/a-bounce-0.bnc", "-o", "out/x.bnc"];
    s.run(&[&lower[..], &["out/a-g1-0.bnc"]].concat())
        .fails_with(3, &["shards 1 of 2 are missing"]);
    s.run(&[&lower[..], &["out/a-g2-0.bnc", "out/a-g2-1.bnc"]].concat())
        .fails_with(3, &["out/a-g2-0.bnc", "bounce 2"]);
    s.run(&[
        "stitch",
        "out/a-unstitched.prt",
        "--join",
        "out/a-c1.col",
        "-o",
        "out/x.prt",
    ])
    .fails_with(3, &["shards 0 of 2 are missing"]);
    // A bounce file of the first format (aux and guides in every merged file): refused by
    // its magic, naming the file.
    let mut bytes = s.read("out/a-bounce-0.bnc");
    bytes[7] = 1;
    s.write("out/old.bnc", &bytes);
    let gather = ["gather", "out/a-part-0.prt", "-o", "out/x.bnc", "--lower"];
    s.run(&[&gather[..], &["out/old.bnc"]].concat())
        .fails_with(3, &["out/old.bnc", "older prt-bake (version 1)"]);
    // A gather from a part of another bake (another seed's part, same lightmap size).
    let other = [&opts[..], &["--seed", "7", "--shard", "0/2"]].concat();
    s.bake(CORNELL, "b-part-0.prt", &other);
    s.run(&[
        "gather",
        "out/b-part-0.prt",
        "--lower",
        "out/a-bounce-0.bnc",
        "-o",
        "out/x.bnc",
    ])
    .fails_with(3, &["out/b-part-0.prt", "of another bake"]);
}

#[test]
fn the_merge_stitches_with_the_seam_factor() {
    let s = Scratch::new();
    // A shadowed lightmap: the plain merge of its parts stitches with the factor.
    let opts = ["--lightmap", "32", "--samples", "16", "--aux", "ao"];
    s.bake(
        TORUS,
        "whole.prt",
        &[&opts[..], &["--atlas", "unwrap"]].concat(),
    );
    let unwrap = [&opts[..], &["--atlas", "unwrap"]].concat();
    let prepare = ["prepare-lightmap", TORUS, "-o", "out/prep.lmp"];
    s.run(&[&prepare[..], &unwrap].concat()).success();
    s.run(&["factor-seams", "out/prep.lmp", "-o", "out/seams.fac"])
        .success();
    for k in 0..2 {
        let shard = format!("{k}/2");
        let args = [
            &unwrap[..],
            &["--prepared", "out/prep.lmp", "--shard", &shard],
        ]
        .concat();
        s.bake(TORUS, &format!("part-{k}.prt"), &args);
    }
    let merge = ["merge", "--quiet", "out/part-1.prt", "out/part-0.prt"];
    s.run(
        &[
            &merge[..],
            &["--factor", "out/seams.fac", "-o", "out/merged.prt"],
        ]
        .concat(),
    )
    .success();
    assert!(
        s.read("out/merged.prt") == s.read("out/whole.prt"),
        "the merge stitched with the factor differs from the whole bake"
    );
    s.run(&[&merge[..], &["--unstitched", "-o", "out/unstitched.prt"]].concat())
        .success();
    assert!(
        s.read("out/unstitched.prt") != s.read("out/whole.prt"),
        "stitching changed nothing: the test would not see a wrong stitch"
    );
    // The factor of another lightmap (40², the same atlas): refused, naming it.
    let other = ["--lightmap", "40", "--samples", "16", "--atlas", "unwrap"];
    let prepare = ["prepare-lightmap", TORUS, "-o", "out/other.lmp"];
    s.run(&[&prepare[..], &other].concat()).success();
    s.run(&["factor-seams", "out/other.lmp", "-o", "out/other.fac"])
        .success();
    s.run(
        &[
            &merge[..],
            &["--factor", "out/other.fac", "-o", "out/x.prt"],
        ]
        .concat(),
    )
    .fails_with(3, &["out/other.fac", "the seam factor of another prepared"]);
    // With --unstitched: a usage error. Vertex parts: refused.
    s.run(
        &[
            &merge[..],
            &[
                "--factor",
                "out/seams.fac",
                "--unstitched",
                "-o",
                "out/x.prt",
            ],
        ]
        .concat(),
    )
    .fails_with(2, &["--unstitched"]);
    for k in 0..2 {
        let shard = format!("{k}/2");
        s.bake(
            TORUS,
            &format!("v-{k}.prt"),
            &["--samples", "16", "--shard", &shard],
        );
    }
    let vertices = [
        "merge",
        "out/v-0.prt",
        "out/v-1.prt",
        "--factor",
        "out/seams.fac",
    ];
    s.run(&[&vertices[..], &["-o", "out/x.prt"]].concat())
        .fails_with(3, &["out/v-0.prt", "a vertex bake"]);
    s.assert_out_holds(&[
        "whole.prt",
        "prep.lmp",
        "seams.fac",
        "part-0.prt",
        "part-1.prt",
        "merged.prt",
        "unstitched.prt",
        "other.lmp",
        "other.fac",
        "v-0.prt",
        "v-1.prt",
    ]);
}
