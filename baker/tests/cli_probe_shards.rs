//! Probe bakes in parts (docs/guides/probes.md, "Shards and checkpoints"): `bake --probes --shard`,
//! `merge`, and `bake --probes --checkpoint`, through the real `prt-bake` binary. The oracle
//! is the single-machine probe bake: a merge of every shard's part, and a checkpointed bake
//! interrupted and run again, must give the same file byte for byte, shadowed and
//! interreflected (where every shard reads the vertices' bounce solution).

mod common;

use common::Scratch;

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);

/// Six probes at order 2 with few rays: milliseconds per bake.
const GRID: [&str; 6] = ["--probes", "grid:3,2,1", "--order", "2", "--samples", "64"];

fn with<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    GRID.iter().copied().chain(extra.iter().copied()).collect()
}

/// Bakes the grid whole and in three shards in `mode`; returns the parts' names.
fn bake_whole_and_parts(s: &Scratch, mode: &str) -> Vec<String> {
    s.bake(CORNELL, &format!("{mode}.prt"), &with(&["--mode", mode]));
    (0..3)
        .map(|k| {
            let part = format!("{mode}-{k}.part.prt");
            let shard = format!("{k}/3");
            let run = s.bake(CORNELL, &part, &with(&["--mode", mode, "--shard", &shard]));
            let range = ["probes 0..2 of 6", "probes 2..4 of 6", "probes 4..6 of 6"][k];
            assert!(run.stdout.contains(range), "{}", run.stdout);
            format!("out/{part}")
        })
        .collect()
}

#[test]
fn merged_probe_shards_are_the_whole_bake_shadowed_and_interreflected() {
    let s = Scratch::new();
    for mode in ["shadowed", "interreflected"] {
        let parts = bake_whole_and_parts(&s, mode);
        let merged = format!("out/{mode}-merged.prt");
        let mut args = vec!["merge", "--quiet", "-o", &merged];
        args.extend(parts.iter().rev().map(String::as_str));
        let run = s.run(&args).success();
        assert!(
            run.stdout.contains("merged 3 parts, 6 probes"),
            "{}",
            run.stdout
        );
        assert!(
            s.read(&format!("out/{mode}-merged.prt")) == s.read(&format!("out/{mode}.prt")),
            "{mode}: the merged probe file differs from the whole bake"
        );
    }
    // More shards than probes: the empty parts merge too.
    let mut args = vec![
        "merge".to_string(),
        "--quiet".into(),
        "-o".into(),
        "out/8.prt".into(),
    ];
    for k in 0..8 {
        let shard = format!("{k}/8");
        s.bake(CORNELL, &format!("8-{k}.prt"), &with(&["--shard", &shard]));
        args.push(format!("out/8-{k}.prt"));
    }
    s.run(&args.iter().map(String::as_str).collect::<Vec<_>>())
        .success();
    assert!(s.read("out/8.prt") == s.read("out/shadowed.prt"));
    let inspect = s.run(&["inspect", "out/shadowed-1.part.prt"]).success();
    let json: serde_json::Value = serde_json::from_str(&inspect.stdout).unwrap();
    assert_eq!(json["shard"]["first_vertex"], 2, "{json}");
    assert_eq!(
        json["probes"]["grid"]["counts"],
        serde_json::json!([3, 2, 1])
    );
    // A shard baked through checkpoint blocks is the same part.
    let args = with(&[
        "--shard",
        "1/3",
        "--checkpoint",
        "out/ck",
        "--checkpoint-vertices",
        "1",
    ]);
    s.bake(CORNELL, "shadowed-1.ck.prt", &args);
    assert!(s.read("out/shadowed-1.ck.prt") == s.read("out/shadowed-1.part.prt"));
}

#[test]
fn merges_of_the_wrong_probe_parts_are_refused() {
    let s = Scratch::new();
    let parts = bake_whole_and_parts(&s, "shadowed");
    s.bake(
        CORNELL,
        "seed.part.prt",
        &with(&["--shard", "2/3", "--seed", "7"]),
    );
    s.bake(CORNELL, "two.part.prt", &with(&["--shard", "1/2"]));
    s.bake(CORNELL, "vertex.part.prt", &["--shard", "0/3"]);
    let merge = |inputs: &[&str]| {
        let mut args = vec!["merge", "--quiet", "-o", "out/m.prt"];
        args.extend(inputs);
        s.run(&args)
    };
    let (p0, p1, p2) = (parts[0].as_str(), parts[1].as_str(), parts[2].as_str());
    let cases: [(Vec<&str>, &[&str]); 6] = [
        (vec![p0, p2], &["shard 1 of 3 missing", "hold shards 0, 2"]),
        (
            vec![p0, p1, "out/seed.part.prt"],
            &["seed.part.prt: a part of another bake", "seed 7"],
        ),
        (vec![p0, p1, p1], &["both are shard 1 of 3"]),
        (vec![p0, p1, "out/two.part.prt"], &["split 2 ways"]),
        (
            vec![p0, p1, "out/vertex.part.prt"],
            &["vertex.part.prt", "not a probe bake's"],
        ),
        (
            vec!["out/vertex.part.prt", p0],
            &["shadowed-0.part.prt", "a probe bake's part"],
        ),
    ];
    for (inputs, needles) in cases {
        merge(&inputs).fails_with_bad_input(needles);
    }
    assert!(
        !s.path("out/m.prt").exists(),
        "a refused merge left an output"
    );
}

#[test]
fn an_interrupted_probe_checkpoint_resumes_to_the_same_file() {
    let s = Scratch::new();
    s.write(
        "points.txt",
        "0 1 0\n0.2 1.5 0.1\n-0.3 0.5 0.2\n0.4 1.8 -0.3\n0.1 0.1 0.1\n",
    );
    let probes = s.path("points.txt");
    let args = |extra: &[&'static str]| {
        let mut a = vec!["--probes", probes.to_str().unwrap(), "--order", "2"];
        a.extend(["--samples", "64", "--mode", "interreflected"]);
        a.extend(extra);
        a
    };
    let checkpoint = ["--checkpoint", "out/ck", "--checkpoint-vertices", "2"];
    s.bake(CORNELL, "whole.prt", &args(&[]));
    let first = s.bake(CORNELL, "first.prt", &args(&checkpoint));
    assert!(
        first.stdout.contains("3 blocks (0 resumed"),
        "{}",
        first.stdout
    );
    assert!(s.read("out/first.prt") == s.read("out/whole.prt"));
    // A run killed after its first and last blocks: the middle one was never written.
    std::fs::remove_file(s.path("out/ck/block-000001.prt")).unwrap();
    let resumed = s.bake(CORNELL, "resumed.prt", &args(&checkpoint));
    assert!(
        resumed.stdout.contains("3 blocks (2 resumed"),
        "{}",
        resumed.stdout
    );
    assert!(
        s.read("out/resumed.prt") == s.read("out/whole.prt"),
        "the resumed probe bake differs from the uninterrupted one"
    );
    // Every block done: no rays, not even the vertices' bounce solution.
    let done = s.bake(CORNELL, "done.prt", &args(&checkpoint));
    assert!(done.stdout.contains(", 0 rays"), "{}", done.stdout);
    assert!(s.read("out/done.prt") == s.read("out/whole.prt"));
    // Another bake's blocks are refused, not overwritten.
    let mut other = vec!["bake", CORNELL, "-o", "out/other.prt", "--quiet"];
    other.extend(args(&checkpoint));
    other.extend(["--seed", "9"]);
    s.run(&other)
        .fails_with_bad_input(&["a checkpoint of another bake", "seed 0 instead of 9"]);
    let mut split = vec!["bake", CORNELL, "-o", "out/split.prt", "--quiet"];
    split.extend(args(&[
        "--checkpoint",
        "out/ck",
        "--checkpoint-vertices",
        "3",
    ]));
    s.run(&split)
        .fails_with_bad_input(&["not a block of this bake", "3 per block"]);
}
