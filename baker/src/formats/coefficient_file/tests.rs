use super::*;
use crate::formats::header::{Aux, Mode};
use crate::math::sampling::Sampling;
use crate::trace::Backend;

/// An adaptive file of two vertices at order 1.
fn adaptive_file() -> CoefficientFile {
    CoefficientFile {
        header: Header {
            version: VERSION,
            order: 1,
            channels: 1,
            vertex_count: 2,
            samples_per_vertex: 4096,
            mode: Mode::Shadowed,
            transfer: Default::default(),
            bounces: 0,
            bounce_samples: 0,
            backend: Backend::Embree,
            sampling: Sampling::OwenSobol,
            seed: 3,
            scene_fingerprint: 0x1234,
            up: crate::scene::Up::Z,
            aux: Aux {
                ao: true,
                bent_normal: false,
            },
            checksum: 0,
            adaptive: Some(Adaptive {
                target_error: 1e-3,
                replicates: 16,
                rays_cast: 256 + 4096,
                after_denoise: false,
            }),
            receivers: None,
            denoised: false,
        },
        coefficients: vec![0.25, 0.5],
        ao: Some(vec![0.75, 1.0]),
        bent_normal: None,
        rays: Some(vec![256, 4096]),
        error_estimate: Some(vec![5e-4, 2e-3]),
        lightmap: None,
        probes: None,
    }
}

/// `bytes` with a new checksum, so only the change under test is wrong.
fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
    let sum = checksum(&bytes);
    bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
    bytes
}

#[test]
fn adaptive_files_round_trip_and_fixed_ones_keep_their_bytes() {
    let file = adaptive_file();
    let (bytes, sum) = file.to_bytes();
    // Header, 2 coefficients, 2 accessibilities, 2 ray counts, 2 errors.
    assert_eq!(bytes.len(), HEADER_SIZE + 8 * 4);
    assert_eq!(
        u32::from_le_bytes(bytes[68..72].try_into().unwrap()),
        1 | 4 | 8
    );
    let read = CoefficientFile::from_bytes(&bytes).unwrap();
    assert_eq!(read.header.checksum, sum);
    assert_eq!(
        read,
        CoefficientFile {
            header: Header {
                checksum: sum,
                ..file.header.clone()
            },
            ..file.clone()
        }
    );

    // Zero means "not adaptive": a fixed-sample file has zeros in 108..124 and no bits 2–3.
    let fixed = CoefficientFile {
        header: Header {
            adaptive: None,
            ..file.header.clone()
        },
        rays: None,
        error_estimate: None,
        ..file
    };
    let (bytes, _) = fixed.to_bytes();
    assert!(bytes[84..CHECKSUM_OFFSET].iter().all(|&b| b == 0));
    assert_eq!(u32::from_le_bytes(bytes[68..72].try_into().unwrap()), 1);
    let read = CoefficientFile::from_bytes(&bytes).unwrap();
    assert_eq!((read.header.adaptive, read.rays), (None, None));
}

/// A change to a file's bytes.
type Corruption = Box<dyn Fn(&mut Vec<u8>)>;

#[test]
fn inconsistent_adaptive_fields_are_refused() {
    let (good, _) = adaptive_file().to_bytes();
    let rays_at = HEADER_SIZE + 4 * 4;
    let errors_at = rays_at + 2 * 4;
    let cases: [(&str, Corruption); 7] = [
        (
            "without a target error",
            Box::new(|b: &mut Vec<u8>| b[108..112].fill(0)),
        ),
        (
            "is not a positive number",
            Box::new(|b: &mut Vec<u8>| b[108..112].copy_from_slice(&(-1e-3f32).to_le_bytes())),
        ),
        (
            "replicates cannot estimate",
            Box::new(|b: &mut Vec<u8>| b[112..116].copy_from_slice(&1u32.to_le_bytes())),
        ),
        (
            "without its per-vertex rays and errors",
            Box::new(|b: &mut Vec<u8>| b[68] = 1 | 4),
        ),
        (
            "the header says 4352 were cast",
            Box::new(move |b: &mut Vec<u8>| {
                b[rays_at..rays_at + 4].copy_from_slice(&512u32.to_le_bytes())
            }),
        ),
        (
            "vertex 1 cast 5000 rays, outside 1..=4096",
            Box::new(move |b: &mut Vec<u8>| {
                b[rays_at + 4..rays_at + 8].copy_from_slice(&5000u32.to_le_bytes())
            }),
        ),
        (
            "estimated error of vertex 0",
            Box::new(move |b: &mut Vec<u8>| {
                b[errors_at..errors_at + 4].copy_from_slice(&f32::NAN.to_le_bytes())
            }),
        ),
    ];
    for (message, corrupt) in cases {
        let mut bytes = good.clone();
        corrupt(&mut bytes);
        match CoefficientFile::from_bytes(&resealed(bytes)) {
            Err(m) => assert!(m.contains(message), "{message}: {m}"),
            Ok(_) => panic!("{message}: accepted"),
        }
    }
    // A target error in an interreflected file.
    let mut bytes = good.clone();
    bytes[36..40].copy_from_slice(&2u32.to_le_bytes());
    bytes[40..44].copy_from_slice(&1u32.to_le_bytes());
    bytes[80..84].copy_from_slice(&1u32.to_le_bytes());
    let m = CoefficientFile::from_bytes(&resealed(bytes)).unwrap_err();
    assert!(
        m.contains("a target error in a file of mode interreflected"),
        "{m}"
    );
}
