//! docs/reference/gltf.md's WGSL snippets compile: every ```wgsl block is parsed and validated by naga
//! (the WGSL front end wgpu uses, already in the build through wgpu's `wgsl` feature). The
//! GLSL ES snippets are compiled by glslangValidator in `make browser`.

fn wgsl_blocks(markdown: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in markdown.lines() {
        match (&mut current, line) {
            (None, "```wgsl") => current = Some(String::new()),
            (Some(block), "```") => {
                blocks.push(std::mem::take(block));
                current = None;
            }
            (Some(block), line) => {
                block.push_str(line);
                block.push('\n');
            }
            (None, _) => {}
        }
    }
    blocks
}

#[test]
fn gltf_md_wgsl_snippets_compile() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/reference/gltf.md");
    let markdown = std::fs::read_to_string(path).unwrap_or_else(|err| panic!("{path}: {err}"));
    let blocks = wgsl_blocks(&markdown);
    assert!(!blocks.is_empty(), "{path}: no ```wgsl block");
    for (i, source) in blocks.iter().enumerate() {
        let module = naga::front::wgsl::parse_str(source).unwrap_or_else(|err| {
            panic!(
                "{path}: wgsl block {}: {}",
                i + 1,
                err.emit_to_string(source)
            )
        });
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|err| panic!("{path}: wgsl block {}: {err:?}", i + 1));
    }
}
