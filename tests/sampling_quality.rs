//! The sampling beats the thesis's (independent uniform directions over the sphere, those
//! below the horizon not traced), and converges as the sample count grows. Measured on the
//! point under a coaxial disk, whose every coefficient is known in closed form.

use glam::{DVec3, Vec3};
use prt_baker::math::sampling::Sampling;
use prt_baker::{BakeOptions, Mode};
use prt_tests::*;

const ORDER: usize = 3;
const SEEDS: u64 = 32;

/// Root-mean-square error over all coefficients and `SEEDS` seeds.
fn rms_error(sampling: Sampling, samples: u32) -> f64 {
    // A 4,096-gon: a coarser polygon's area deficit (1e-4 relative for 256 sides) would be a
    // bias of about 1e-5 that no sample count removes.
    let scene = scene(vec![
        patch(Vec3::ZERO, Vec3::Z, 0.1),
        disk(Vec3::Z, 1.0, 4096),
    ]);
    let exact = band_moments(ORDER, DVec3::Z, 0.0, std::f64::consts::FRAC_1_SQRT_2).mean;
    let mut sum = 0.0;
    for seed in 0..SEEDS {
        let options = BakeOptions {
            order: ORDER,
            samples,
            mode: Mode::Shadowed,
            seed,
            sampling,
            ..BakeOptions::default()
        };
        let got = &bake_vertices(&scene, &options, &[0])[0];
        sum += got
            .iter()
            .zip(&exact)
            .map(|(g, e)| (g - e).powi(2))
            .sum::<f64>();
    }
    (sum / (SEEDS as f64 * exact.len() as f64)).sqrt()
}

#[test]
fn owen_sobol_beats_the_theses_random_sampling() {
    for samples in [256, 4096] {
        let ours = rms_error(Sampling::OwenSobol, samples);
        let thesis = rms_error(Sampling::ThesisRandom, samples);
        eprintln!(
            "{samples} rays: RMS error {ours:.2e} (owen-sobol) vs {thesis:.2e} (thesis-random), {:.1}x lower",
            thesis / ours
        );
        // Cosine weighting alone removes the cosine's variance; stratification does the rest.
        assert!(
            ours * 4.0 < thesis,
            "{samples} rays: {ours:.3e} is not 4x below {thesis:.3e}"
        );
    }
}

#[test]
fn error_falls_at_least_as_fast_as_independent_sampling() {
    let counts = [256u32, 1024, 4096, 16384];
    let errors: Vec<f64> = counts
        .iter()
        .map(|&n| rms_error(Sampling::OwenSobol, n))
        .collect();
    for (pair, n) in errors.windows(2).zip(counts.windows(2)) {
        let rate = (pair[0] / pair[1]).ln() / (f64::from(n[1]) / f64::from(n[0])).ln();
        eprintln!(
            "{} -> {} rays: RMS {:.2e} -> {:.2e}, error ∝ N^-{rate:.2}",
            n[0], n[1], pair[0], pair[1]
        );
        // Independent samples give N^-0.5; stratified nets at least that on this integrand.
        assert!(
            rate > 0.5,
            "convergence rate {rate:.2} between {} and {} rays",
            n[0],
            n[1]
        );
    }
    let thesis: Vec<f64> = counts
        .iter()
        .map(|&n| rms_error(Sampling::ThesisRandom, n))
        .collect();
    let rate = (thesis[0] / thesis[3]).ln() / 64f64.ln();
    eprintln!(
        "thesis-random: RMS {:.2e} -> {:.2e}, error ∝ N^-{rate:.2}",
        thesis[0], thesis[3]
    );
    assert!(
        (0.35..0.65).contains(&rate),
        "independent sampling should converge as N^-0.5, got N^-{rate:.2}"
    );
}
