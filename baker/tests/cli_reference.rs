//! `docs/reference/cli.md` and `docs/reference/cli/*.md` are `prt-bake`'s own help, so the reference cannot drift from the
//! command line: this test runs the built binary's `--help` and every subcommand's `--help`,
//! renders them as Markdown pages and compares them with the committed files.
//!
//! After changing an option or its doc comment, regenerate the page with
//!
//! ```sh
//! PRT_BLESS=1 cargo test --release -p prt-baker --test cli_reference
//! ```
//!
//! (or `make cli-reference`) and commit the pages. The help of a build without the `embree` feature
//! differs in the default backend, so the comparison runs only in the default build.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_prt-bake");
const REFERENCE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/reference");

/// One `prt-bake … --help`, at a fixed width so that the page does not depend on the terminal.
fn help(args: &[&str]) -> String {
    let out = Command::new(BIN)
        .args(args)
        .arg("--help")
        .env("COLUMNS", "100")
        .env_remove("LINES")
        .output()
        .expect("run prt-bake");
    assert!(out.status.success(), "prt-bake {args:?} --help failed");
    let text = String::from_utf8(out.stdout).expect("help is UTF-8");
    text.lines()
        .map(str::trim_end)
        .collect::<Vec<_>>()
        .join("\n")
}

/// The heading of the cluster stages the top-level help lists after its commands (they are
/// hidden from "Commands:"; each still has its page).
const STAGES: &str = "Cluster stages";

/// The subcommands listed under `heading` ("Commands:", or [`STAGES`]) in the top-level help,
/// without `help`, each with the first line of its description.
fn subcommands(top: &str, heading: &str) -> Vec<(String, String)> {
    top.lines()
        .skip_while(|line| !line.starts_with(heading))
        .skip(1)
        .take_while(|line| line.starts_with("  "))
        .filter_map(|line| {
            // A name is indented by two spaces; a description's continuation lines by more.
            let indent = line.len() - line.trim_start().len();
            let mut words = line.split_whitespace();
            let name = words.next()?;
            let about = words.collect::<Vec<_>>().join(" ");
            (indent == 2 && name != "help").then(|| (name.to_string(), about))
        })
        .filter(|(name, _)| name.chars().all(|c| c.is_ascii_lowercase() || c == '-'))
        .collect()
}

const HEADER: &str = "<!-- Generated from clap's help by baker/tests/cli_reference.rs: do not edit by hand.\n     \
     Regenerate with `make cli-reference` (PRT_BLESS=1 cargo test --release -p prt-baker \
     --test cli_reference). -->\n\n";

/// The pages: `cli.md` (the top-level help and an index) and `cli/NAME.md` per subcommand, as
/// (path relative to docs/reference, text). One page per subcommand keeps every page short.
fn render() -> Vec<(String, String)> {
    let top = help(&[]);
    let (commands, stages) = (subcommands(&top, "Commands:"), subcommands(&top, STAGES));
    let mut index = format!(
        "# `prt-bake` command-line reference\n\n{HEADER}\
         Each subcommand's page is its `--help`, as the binary prints it. Exit codes: 0 success, \
         1 failure (I/O, backend), 2 bad command line, 3 bad input files. The \
         [guides](../README.md) show the options at work.\n\n\
         | command | what it does |\n|---|---|\n"
    );
    let row = |(name, about): &(String, String)| {
        format!("| [`prt-bake {name}`](cli/{name}.md) | {about} |\n")
    };
    commands.iter().for_each(|c| index.push_str(&row(c)));
    index.push_str(
        "\nThe staged pipeline's own commands, which the cluster scripts call \
         ([clusters](../guides/clusters.md)), are listed after the others:\n\n\
         | cluster stage | what it does |\n|---|---|\n",
    );
    stages.iter().for_each(|c| index.push_str(&row(c)));
    index.push_str(&format!("\n## prt-bake\n\n```text\n{top}\n```\n"));
    let mut pages = vec![("cli.md".to_string(), index)];
    for (name, _) in commands.iter().chain(&stages) {
        let text = help(&[name]);
        pages.push((
            format!("cli/{name}.md"),
            format!(
                "# `prt-bake {name}`\n\n{HEADER}[All commands](../cli.md)\n\n```text\n{text}\n```\n"
            ),
        ));
    }
    pages
}

#[test]
fn the_cli_reference_is_the_binarys_help() {
    if !cfg!(feature = "embree") {
        eprintln!("cli_reference: skipped in a build without Embree (its help differs)");
        return;
    }
    let pages = render();
    assert!(
        pages.iter().any(|(p, _)| p == "cli/bake.md")
            && pages.iter().any(|(p, _)| p == "cli/merge.md")
            && pages.iter().any(|(p, _)| p == "cli/stitch.md"),
        "could not read the subcommands from the help"
    );
    let dir = Path::new(REFERENCE);
    if std::env::var_os("PRT_BLESS").is_some() {
        let _ = std::fs::remove_dir_all(dir.join("cli"));
        std::fs::create_dir_all(dir.join("cli")).unwrap();
        for (path, text) in &pages {
            std::fs::write(dir.join(path), text).expect("write the CLI reference");
        }
        return;
    }
    let mut stale = Vec::new();
    for (path, text) in &pages {
        if std::fs::read_to_string(dir.join(path)).ok().as_deref() != Some(text.as_str()) {
            stale.push(path.clone());
        }
    }
    // A page of a subcommand that no longer exists is stale too.
    for entry in std::fs::read_dir(dir.join("cli"))
        .into_iter()
        .flatten()
        .flatten()
    {
        let path = format!("cli/{}", entry.file_name().to_string_lossy());
        if !pages.iter().any(|(p, _)| *p == path) {
            stale.push(path);
        }
    }
    assert!(
        stale.is_empty(),
        "docs/reference/{stale:?} differ from prt-bake's help: run `make cli-reference` and \
         commit the pages"
    );
}
