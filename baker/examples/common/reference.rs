//! The high-sample reference the adaptive-sampling examples measure errors against, cached
//! under target/ (a 65,536-ray bake of the demo scene takes about 20 s).

use std::path::Path;

/// The reference of `scene` for every `stride`-th vertex at `rays` rays: read from the cache,
/// or made by `bake` and cached.
pub fn cached(
    root: &Path,
    scene: &prt_baker::Scene,
    stride: usize,
    rays: u32,
    bake: impl FnOnce() -> Vec<f32>,
) -> Vec<f32> {
    let cache = root.join(format!(
        "target/adaptive-reference-{:016x}-{stride}-{rays}.f32",
        scene.fingerprint()
    ));
    if let Ok(bytes) = std::fs::read(&cache) {
        return bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
            .collect();
    }
    let started = std::time::Instant::now();
    let reference = bake();
    let bytes: Vec<u8> = reference.iter().flat_map(|c| c.to_le_bytes()).collect();
    std::fs::write(&cache, bytes).expect("write the reference cache");
    println!(
        "reference baked in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    reference
}
