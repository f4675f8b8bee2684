//! `gen-scenes [DIR]`: writes the demo scenes into DIR (default: this crate's folder), where
//! they are committed. A test regenerates them and compares, so the files and this program
//! cannot drift apart.

fn main() -> std::io::Result<()> {
    let dir = std::env::args_os()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")));
    prt_scenes::write_all(&dir)?;
    println!(
        "wrote {}/torus, {}/tube and {}/cornell",
        dir.display(),
        dir.display(),
        dir.display()
    );
    Ok(())
}
