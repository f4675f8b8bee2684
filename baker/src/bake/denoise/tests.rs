//! The filter's geometric terms, on synthetic sheets of receivers.

use super::*;
use glam::Vec3;

use super::clipped_lobe::{ClippedLobes, LobeScratch};

/// A square 12 × 12 grid of receivers at spacing 1 from `origin` along `u`, `v`,
/// facing `normal`, in `group`.
fn sheet(guides: &mut Guides, origin: Vec3, u: Vec3, v: Vec3, normal: Vec3, group: u32) {
    for a in 0..12 {
        for b in 0..12 {
            guides.points.push(origin + u * a as f32 + v * b as f32);
            guides.normals.push(normal);
            guides.surfaces.push(normal);
            guides.groups.push(group);
            guides.spacing.push(1.0);
            guides.noise.push(1e-4);
        }
    }
}

/// The largest weight any receiver of the first sheet (the first 144) gives the second,
/// every receiver holding the same transfer, so only the geometric terms can tell them
/// apart. Every receiver's weights must sum to 1.
fn weight_across(guides: &Guides, settings: Settings) -> f32 {
    let transfer = vec![0.5f32; guides.points.len() * 4];
    let filter = Filter::new(guides, settings, &transfer, 1, 4);
    let mut row = Vec::new();
    let mut most = 0.0f32;
    for i in 0..144 {
        filter.row(i, &mut row);
        let total: f32 = row.iter().map(|&(_, w)| w).sum();
        assert!(
            (total - 1.0).abs() < 1e-4,
            "receiver {i}'s weights sum to {total}"
        );
        for &(j, w) in &row {
            if j >= 144 {
                most = most.max(w.abs());
            }
        }
    }
    most
}

#[test]
fn a_crease_a_step_and_another_object_get_no_weight() {
    // Texels (in clusters) and vertices (one by one, a second-order fit) alike.
    for settings in [Settings::TEXELS, Settings::VERTICES] {
        let across = |second: (Vec3, Vec3, Vec3, Vec3, u32)| {
            let mut guides = Guides::default();
            sheet(&mut guides, Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, 0);
            let (origin, u, v, normal, group) = second;
            sheet(&mut guides, origin, u, v, normal, group);
            weight_across(&guides, settings)
        };
        let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
        // A floor meeting a wall at a right angle.
        let crease = across((Vec3::new(0.0, 12.0, 0.5), x, z, -y, 0));
        assert!(crease < 1e-3, "{settings:?}: {crease}");
        // A slab three spacings above the floor, facing the same way.
        let step = across((Vec3::new(6.0, 0.0, 3.0), x, y, z, 0));
        assert!(step < 1e-3, "{settings:?}: {step}");
        // Two objects side by side in one plane.
        assert_eq!(across((Vec3::new(12.0, 0.0, 0.0), x, y, z, 1)), 0.0);
        // Two objects meeting closer than a spacing, within one cluster's reach: no cluster
        // takes in both.
        assert_eq!(across((Vec3::new(11.5, 0.0, 0.0), x, y, z, 1)), 0.0);
        // And one object continuing in that plane does share.
        let one = across((Vec3::new(12.0, 0.0, 0.0), x, y, z, 0));
        assert!(one > 1e-2, "{settings:?}: {one}");
    }
}

#[test]
fn a_quadratic_transfer_is_kept_exactly() {
    // A bowl of transfer over one sheet: the fit reproduces it at every vertex, border
    // and corner included (up to the ridge's small pull), whether the range term keeps a
    // few neighbours along the bowl's level lines (a low noise) or every one (a high noise:
    // the whole second-order fit at work).
    let mut g = Guides::default();
    sheet(&mut g, Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, 0);
    let value = |p: Vec3| 1.0 + 0.05 * p.x - 0.03 * p.y + 0.01 * (p.x * p.x + p.x * p.y);
    let transfer: Vec<f32> = g.points.iter().map(|&p| value(p)).collect();
    for noise in [1e-4, 1.0] {
        g.noise.fill(noise);
        let filter = Filter::new(&g, Settings::VERTICES, &transfer, 1, 1);
        let out = filter.apply(&transfer, 1);
        for (i, (&a, &b)) in out.iter().zip(&transfer).enumerate() {
            assert!(
                (a - b).abs() < 0.02 * b,
                "noise {noise}, vertex {i}: {a} against {b}"
            );
        }
    }
}

/// The texels' path applied to its own transfer reuses the clusters' means formed while
/// clustering: the very floats a fresh apply forms, so the same result bit for bit.
#[test]
fn applying_to_the_filters_own_transfer_reuses_the_same_means() {
    let mut guides = Guides::default();
    sheet(&mut guides, Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, 0);
    let mut rng = crate::math::sampling::Pcg32::new(7, 8);
    // Order 3, three channels: the signal is the whole transfer.
    let width = 27;
    let transfer: Vec<f32> = (0..guides.points.len() * width)
        .map(|_| 0.5 + 0.05 * rng.next_f32())
        .collect();
    let filter = Filter::new(&guides, Settings::TEXELS, &transfer, 3, 9);
    assert!(filter.transfer_means);
    let (mut fresh, mut reused) = (transfer.clone(), transfer.clone());
    let (mut a, mut b) = (vec![0.25f32; 144], vec![0.25f32; 144]);
    filter.apply_in_place(&mut fresh, width, &mut a);
    filter.apply_to_transfer(&mut reused, width, &mut b);
    assert_eq!(fresh, reused);
    assert_eq!(a, b);
    assert_ne!(fresh, transfer);
}

/// Applying the texels' filter (clusters' means, each cluster's fit sums read by its
/// members, written block by block) gives every receiver, values and scalar alike, what
/// its own row of weights gives ([`Filter::row`], formed receiver by receiver): the
/// independent path.
#[test]
fn applying_the_filter_gives_each_receiver_its_row_of_weights() {
    let mut guides = Guides::default();
    sheet(&mut guides, Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, 0);
    // A second object beside it, so clusters of two groups interleave.
    sheet(
        &mut guides,
        Vec3::new(12.0, 0.0, 0.0),
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        1,
    );
    let mut rng = crate::math::sampling::Pcg32::new(3, 5);
    let width = 9;
    let count = guides.points.len();
    // A slope across the sheets and a little noise: the fit's (u, v) terms count.
    let transfer: Vec<f32> = (0..count * width)
        .map(|n| 0.2 + 0.01 * (n / width % 12) as f32 + 0.02 * rng.next_f32())
        .collect();
    let scalars: Vec<f32> = (0..count)
        .map(|i| 0.3 + 0.02 * (i / 12 % 12) as f32 + 0.01 * rng.next_f32())
        .collect();
    let filter = Filter::new(&guides, Settings::TEXELS, &transfer, 1, 9);
    let (mut values, mut filtered) = (transfer.clone(), scalars.clone());
    filter.apply_in_place(&mut values, width, &mut filtered);
    let mut row = Vec::new();
    for i in 0..count {
        filter.row(i, &mut row);
        let scalar: f32 = row.iter().map(|&(j, w)| w * scalars[j as usize]).sum();
        assert!(
            (filtered[i] - scalar).abs() < 1e-5,
            "{i}: {} {scalar}",
            filtered[i]
        );
        for c in 0..width {
            let value: f32 = row
                .iter()
                .map(|&(j, w)| w * transfer[j as usize * width + c])
                .sum();
            let got = values[i * width + c];
            assert!((got - value).abs() < 1e-5, "{i}, {c}: {got} {value}");
        }
    }
}

/// A 24 × 24 sheet of texels one spacing apart whose shading normals a normal map tilts by up
/// to about 12°, each of noise variance `noise`.
fn bumpy_sheet(noise: f32) -> Guides {
    let mut guides = Guides::default();
    for a in 0..24 {
        for b in 0..24 {
            let tilt = Vec3::new(
                (a as f32 * 1.7).sin(),
                (b as f32 * 2.3 + a as f32).cos(),
                0.0,
            );
            guides.points.push(Vec3::new(a as f32, b as f32, 0.0));
            guides.normals.push((Vec3::Z + 0.15 * tilt).normalize());
            guides.surfaces.push(Vec3::Z);
            guides.groups.push(0);
            guides.spacing.push(1.0);
            guides.noise.push(noise);
        }
    }
    guides
}

/// A normal-mapped sheet whose transfer follows the shading normal (band 1 of an unoccluded
/// lobe is linear in it): the texels' filter fits the normal too ([`normal_fit`]), so it
/// keeps every bump (the largest change 0.004, from the ridge and the clusters' mean
/// normals), where a fit over the plane alone averages them away (0.050).
#[test]
fn a_transfer_that_follows_a_normal_map_is_kept() {
    let guides = bumpy_sheet(1e-4);
    let transfer: Vec<f32> = (guides.normals.iter())
        .flat_map(|n| [0.5, 0.3 * n.y, 0.3 * n.z, 0.3 * n.x])
        .collect();
    let filter = Filter::new(&guides, Settings::TEXELS, &transfer, 1, 4);
    let filtered = filter.apply(&transfer, 4);
    let most = (filtered.iter().zip(&transfer))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(most < 0.01, "largest change {most}");
}

/// A normal-mapped sheet whose noisy transfer follows its bumps and steps down across a
/// shadow's edge at x = 11.5: the filter halves the noise over the bumps and keeps the edge.
/// Without the range term of the fit in the normal ([`normal_fit::reweigh`]) light crosses
/// the edge (an error of 0.057 for a noise of 0.020).
#[test]
fn noise_over_a_normal_map_is_smoothed_and_its_shadow_edge_kept() {
    let sigma = 0.02f32;
    let guides = bumpy_sheet(sigma * sigma);
    let mut rng = crate::math::sampling::Pcg32::new(3, 4);
    let (mut clean, mut transfer) = (Vec::new(), Vec::new());
    for (p, n) in guides.points.iter().zip(&guides.normals) {
        let lit = if p.x < 12.0 { 1.0 } else { 0.2 };
        let value = [0.5, 0.3 * n.y, 0.3 * n.z, 0.3 * n.x].map(|t| t * lit);
        clean.extend(value);
        // Uniform noise of deviation sigma.
        transfer.extend(value.map(|t| t + sigma * 3f32.sqrt() * (2.0 * rng.next_f32() - 1.0)));
    }
    let filter = Filter::new(&guides, Settings::TEXELS, &transfer, 1, 4);
    let filtered = filter.apply(&transfer, 4);
    let rms = |values: &[f32]| {
        let squares: f32 = (values.iter().zip(&clean))
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        (squares / values.len() as f32).sqrt()
    };
    let (before, after) = (rms(&transfer), rms(&filtered));
    assert!(after < 0.6 * before, "noise {before} -> {after}");
    // The dark side's first column takes no light across the edge.
    for b in 0..24 {
        let i = (12 * 24 + b) * 4;
        let rise = filtered[i] - clean[i];
        assert!(rise < 2.0 * sigma, "texel (12, {b}) rose by {rise}");
    }
}

/// A normal-mapped sheet with a joint every 6 texels, whose two walls tilt the shading normal
/// 30° either way, and whose noisy order-3 transfer is the unoccluded lobe about the normal
/// over the sheet's hemisphere ([`clipped_lobe`]) less a part the scene blocks, the same for
/// every texel. With the lobe taken out ([`demodulate`]) the fit in the normal has little
/// left to follow, so the joints' texels read the whole sheet's neighbours: their noise falls
/// to 0.20 of the raw's. With the normal term at the power 32 (cos 30° to it: 0.01) they
/// read only their own wall's few: 0.31.
#[test]
fn a_normal_map_s_joints_read_every_neighbour() {
    let sigma = 0.02f32;
    let mut guides = bumpy_sheet(sigma * sigma);
    let wall = |a: usize| match a % 6 {
        0 => Some(1.0f32),
        1 => Some(-1.0),
        _ => None,
    };
    let tilt = 30f32.to_radians();
    for a in 0..24 {
        if let Some(side) = wall(a) {
            for b in 0..24 {
                guides.normals[a * 24 + b] = Vec3::new(side * tilt.sin(), 0.0, tilt.cos());
            }
        }
    }
    let (lobes, mut scratch) = (ClippedLobes::new(3), LobeScratch::default());
    let mut blocked = [0.0f32; 9];
    lobes.lobe(Vec3::X, Vec3::X, &mut blocked, &mut scratch);
    let mut rng = crate::math::sampling::Pcg32::new(5, 6);
    let (mut clean, mut transfer) = (Vec::new(), Vec::new());
    for (&n, &h) in guides.normals.iter().zip(&guides.surfaces) {
        let mut value = [0.0f32; 9];
        lobes.lobe(n, h, &mut value, &mut scratch);
        for (v, b) in value.iter_mut().zip(&blocked) {
            *v -= 0.2 * b;
        }
        clean.extend(value);
        transfer.extend(value.map(|t| t + sigma * 3f32.sqrt() * (2.0 * rng.next_f32() - 1.0)));
    }
    let filter = Filter::new(&guides, Settings::TEXELS, &transfer, 1, 9);
    let mut filtered = transfer.clone();
    filter.apply_to_transfer(&mut filtered, 9, &mut []);
    let joints = |values: &[f32]| {
        let (mut squares, mut count) = (0.0f32, 0);
        for (i, (a, b)) in values.chunks(9).zip(clean.chunks(9)).enumerate() {
            let (x, y) = (i / 24, i % 24);
            if wall(x).is_some() && (4..20).contains(&x) && (4..20).contains(&y) {
                squares += a.iter().zip(b).map(|(a, b)| (a - b) * (a - b)).sum::<f32>();
                count += 9;
            }
        }
        (squares / count as f32).sqrt()
    };
    let (before, after) = (joints(&transfer), joints(&filtered));
    assert!(
        after < 0.25 * before,
        "the joints' noise {before} -> {after}"
    );
}

/// A normal-mapped sheet whose order-3 transfer is the unoccluded lobe about each texel's
/// shading normal over the sheet's hemisphere ([`clipped_lobe`]): the filter takes the lobe
/// out and puts it back ([`demodulate`]), so every bump is kept to float rounding. The fit
/// in the normal alone follows the lobe only to second order.
#[test]
fn an_unoccluded_lobe_over_a_normal_map_is_kept() {
    let guides = bumpy_sheet(1e-6);
    let (lobes, mut scratch) = (ClippedLobes::new(3), LobeScratch::default());
    let transfer: Vec<f32> = (guides.normals.iter().zip(&guides.surfaces))
        .flat_map(|(&n, &h)| {
            let mut u = [0.0f32; 9];
            lobes.lobe(n, h, &mut u, &mut scratch);
            u
        })
        .collect();
    let filter = Filter::new(&guides, Settings::TEXELS, &transfer, 1, 9);
    let mut filtered = transfer.clone();
    filter.apply_to_transfer(&mut filtered, 9, &mut []);
    let most = (filtered.iter().zip(&transfer))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(most < 1e-6, "largest change {most}");
}

/// Texel bakes of many rays are filtered in finer clusters, and the merge of a bake's parts
/// picks the very same settings from its header's rays and order ([`Settings::texels`]).
#[test]
fn texels_are_clustered_finer_from_256_rays() {
    assert_eq!(
        Settings::texels(FINE_CLUSTERS_FROM - 1, 3),
        Settings::TEXELS
    );
    assert_eq!(Settings::texels(64, 3), Settings::TEXELS);
    let fine = Settings::texels(FINE_CLUSTERS_FROM, 3);
    assert_eq!(fine.step, Some(2.0));
    assert!(fine.normal_quadratic);
    assert_eq!(
        Settings {
            step: Some(3.0),
            normal_quadratic: false,
            ..fine
        },
        Settings::TEXELS
    );
}

/// From order 12 the range term of texels is stricter, whatever the rays, and only there.
#[test]
fn texels_of_high_orders_tolerate_less_difference() {
    for samples in [64, FINE_CLUSTERS_FROM] {
        let below = Settings::texels(samples, SHARP_FROM_ORDER - 1);
        let from = Settings::texels(samples, SHARP_FROM_ORDER);
        assert_eq!(below.kappa, 4.0);
        assert_eq!(from.kappa, 3.0);
        assert_eq!(Settings { kappa: 4.0, ..from }, below);
    }
}

/// A transfer that bends like a contact shadow's (dark at a wall's foot, x = 0, lighter
/// away from it), without noise: each cluster's fit, read at its members' places a texel
/// or two from its centroid, misses the bend, and the misses repeat with the clusters'
/// lattice. Each member blending the fits about it ([`super::blend`]) is closer to the
/// transfer.
#[test]
fn blended_fits_follow_a_bend_closer_than_one_cluster_s() {
    let mut g = Guides::default();
    floor(&mut g);
    g.noise.fill(3e-3);
    let value = |p: Vec3| 1.0 - 0.8 * (-p.x / 2.5).exp();
    let transfer: Vec<f32> = g.points.iter().map(|&p| value(p)).collect();
    let error = |settings| filtered_error(&g, settings, &transfer, g.points.len());
    let blended = error(Settings::TEXELS);
    let own = error(Settings {
        blend: false,
        ..Settings::TEXELS
    });
    // 0.0074 against 0.0085 (the mean of two lattices half a cluster apart, which the blend
    // replaced: 0.0076).
    eprintln!("blended {blended}, own cluster's {own}");
    assert!(
        blended < 0.9 * own,
        "blended {blended}, own cluster's {own}"
    );
}

/// A floor with a wall standing on it at x = −0.5, and a transfer that darkens towards the
/// wall's foot with the contact term (linear in it, so bending within 3 texels of the
/// wall), with noise: the fit in the contact term follows the bend that the first-order fit
/// over the plane misses.
#[test]
fn the_contact_term_follows_a_floor_darkening_at_a_wall_s_foot() {
    let (g, on_floor) = floor_and_wall();
    // The wall's closest texel to a floor texel at x lies (x + 0.5, 0.5) from it.
    let contact = |p: Vec3| contact::term(((p.x + 0.5).powi(2) + 0.25).sqrt());
    let value = |i: usize| match i < on_floor {
        true => 1.0 - 0.6 * contact(g.points[i]),
        false => 0.5,
    };
    let transfer: Vec<f32> = (0..g.points.len()).map(value).collect();
    let error = |settings| noisy_error(&g, settings, &transfer, on_floor, 0.1);
    let first_order = Settings {
        curved: false,
        ..Settings::TEXELS
    };
    let with = error(first_order);
    let without = error(Settings {
        contact: false,
        ..first_order
    });
    // 0.017 against 0.025; 0.024 with the fit in the contact term unwired (its clusters of
    // one alone), and 0.019 against 0.024 with the curved fit, which follows much of the bend
    // itself.
    assert!(
        with < 0.85 * without,
        "with the contact term {with}, without {without}"
    );
}

/// A floor whose transfer dips in a broad shade across it (a Gaussian 6 texels wide, as a
/// crate's shade darkens the floor towards its foot), with noise: the curved fit follows
/// the dip that the first-order fit flattens.
#[test]
fn the_curved_fit_follows_a_broad_shade() {
    let mut g = Guides::default();
    floor(&mut g);
    let value = |p: Vec3| 0.8 - 0.5 * (-((p.x - 18.0) / 6.0).powi(2)).exp();
    let transfer: Vec<f32> = g.points.iter().map(|&p| value(p)).collect();
    let error = |settings| noisy_error(&g, settings, &transfer, transfer.len(), 0.03);
    let curved = error(Settings::TEXELS);
    let first_order = error(Settings {
        curved: false,
        ..Settings::TEXELS
    });
    // 0.0105 against 0.0135.
    assert!(
        curved < 0.85 * first_order,
        "curved {curved}, first-order {first_order}"
    );
}

/// The floor and the wall of the test above: a texel within the contact term's reach of the
/// wall shares a cluster only with texels as far from it (a column along the wall's foot, a
/// row along its bottom), never with one farther out or not in contact; and no cluster of
/// the floor blends a fit of the wall's, or the wall's of the floor's
/// ([`Filter::blend_neighbours`]; they are two objects: a separating plane within one object
/// is held by `texels_beside_another_object_read_nothing_across_it`).
#[test]
fn texels_in_contact_share_clusters_only_at_one_distance() {
    let (g, on_floor) = floor_and_wall();
    let transfer = vec![0.5f32; g.points.len()];
    let filter = Filter::new(&g, Settings::TEXELS, &transfer, 1, 1);
    let (mut in_contact, mut joined) = (0, 0);
    let mut near = Vec::new();
    for c in 0..filter.clusters.reps.len() {
        let row = filter.clusters.row(c);
        let terms: Vec<f32> = (row.iter())
            .map(|&(m, _)| filter.contact.terms[m as usize])
            .collect();
        let touching = terms.iter().filter(|&&t| t > 0.0).count();
        assert!(
            touching == 0 || touching == row.len(),
            "cluster {c}: {terms:?}"
        );
        if touching > 0 {
            let (low, high) =
                (terms.iter()).fold((f32::MAX, f32::MIN), |(l, h), &t| (l.min(t), h.max(t)));
            assert!(high - low <= 0.01, "cluster {c}: {terms:?}");
            in_contact += row.len();
            joined += usize::from(row.len() > 1);
        }
        // The wall stands at x = −0.5: the floor's clusters lie at x > 0, the wall's above
        // the floor; none blends the other side's.
        filter.blend_neighbours(c, &mut near);
        let on_the_floor = |k: u32| (filter.clusters.row(k as usize)[0].0 as usize) < on_floor;
        let side = on_the_floor(c as u32);
        assert!(
            near.iter().all(|&k| on_the_floor(k) == side),
            "cluster {c} blends {near:?}"
        );
    }
    // The floor's first three columns (x = 0, 1, 2, within 3 texels of the wall's foot) and
    // the wall's first three rows, 36 texels each, in clusters along them.
    assert_eq!(in_contact, 6 * 36);
    assert!(joined > 0);
}

/// A thin card (another object) standing across the floor between its columns 17 and 18,
/// the floor's two sides a step apart that the range term cannot see (a noise 3 × the step):
/// the texels within the contact term's reach of the card keep their own side's value; each
/// would read the other side's through the fit without the card's plane (0.23 of the step
/// at x = 15).
#[test]
fn texels_beside_another_object_read_nothing_across_it() {
    let mut g = Guides::default();
    floor(&mut g);
    let on_floor = g.points.len();
    for b in 0..3 {
        let origin = Vec3::new(17.5, 12.0 * b as f32, 0.5);
        sheet(&mut g, origin, Vec3::Y, Vec3::Z, Vec3::X, 1);
    }
    g.noise.fill(1.0);
    let step = 0.3;
    let value = |i: usize| match (i < on_floor, g.points[i].x > 17.5) {
        (true, false) => 1.0,
        (true, true) => 1.0 + step,
        (false, _) => 0.5,
    };
    let transfer: Vec<f32> = (0..g.points.len()).map(value).collect();
    let out = Filter::new(&g, Settings::TEXELS, &transfer, 1, 1).apply(&transfer, 1);
    for i in 0..on_floor {
        let x = g.points[i].x;
        if (15.0..=20.0).contains(&x) {
            let moved = (out[i] - transfer[i]).abs();
            assert!(moved < 1e-5 * step, "{}: {moved}", g.points[i]);
        }
    }
}

/// The floor of [`floor`] and a wall of 36 × 12 standing on it at x = −0.5, facing it (group
/// 1); and how many receivers the floor holds (the first ones).
fn floor_and_wall() -> (Guides, usize) {
    let mut g = Guides::default();
    floor(&mut g);
    let on_floor = g.points.len();
    for b in 0..3 {
        let origin = Vec3::new(-0.5, 12.0 * b as f32, 0.5);
        sheet(&mut g, origin, Vec3::Y, Vec3::Z, Vec3::X, 1);
    }
    (g, on_floor)
}

/// A floor of 36 × 36 receivers at z = 0 facing up: 3 × 3 sheets side by side, in group 0.
fn floor(guides: &mut Guides) {
    for (a, b) in (0..3).flat_map(|a| (0..3).map(move |b| (a, b))) {
        let origin = Vec3::new(12.0 * a as f32, 12.0 * b as f32, 0.0);
        sheet(guides, origin, Vec3::X, Vec3::Y, Vec3::Z, 0);
    }
}

/// The RMS difference of the first `count` receivers' `transfer` (one float each) filtered
/// with `settings` from the transfer itself.
fn filtered_error(guides: &Guides, settings: Settings, transfer: &[f32], count: usize) -> f32 {
    let out = Filter::new(guides, settings, transfer, 1, 1).apply(transfer, 1);
    let squares: f32 = (out[..count].iter().zip(transfer))
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    (squares / count as f32).sqrt()
}

/// The RMS difference of the first `count` receivers' `transfer` (one float each) from the
/// filter's answer on it with uniform noise of deviation `sigma` added, over 8 draws; the
/// guides' noise estimates are σ².
fn noisy_error(
    guides: &Guides,
    settings: Settings,
    transfer: &[f32],
    count: usize,
    sigma: f32,
) -> f32 {
    let mut g = guides.clone();
    g.noise.fill(sigma * sigma);
    let mut squares = 0.0;
    for seed in 0..8 {
        let mut rng = crate::math::sampling::Pcg32::new(seed, 7);
        let noisy: Vec<f32> = (transfer.iter())
            .map(|t| t + sigma * 3f32.sqrt() * (2.0 * rng.next_f32() - 1.0))
            .collect();
        let out = Filter::new(&g, settings, &noisy, 1, 1).apply(&noisy, 1);
        squares += (out[..count].iter().zip(transfer))
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f32>();
    }
    (squares / (8 * count) as f32).sqrt()
}

/// A corrugated sheet whose surface normals turn about 6° a texel, as a terrain's do, with a
/// noisy transfer that follows the normal: it bends ([`normal_fit::groups`]), so it is fitted
/// in the normal with a normal term at the power 1, and keeps far less noise than a fit over
/// the plane does (0.0098 against 0.0168 for a noise of 0.05; at the power 32, 0.0127). A
/// flat sheet under a normal map does not bend.
#[test]
fn a_surface_that_bends_within_a_few_texels_is_fitted_in_its_normal() {
    let mut guides = Guides::default();
    for (a, b) in (0..32).flat_map(|a| (0..32).map(move |b| (a as f32, b as f32))) {
        let n = Vec3::new(-0.6 * (0.3 * a).cos(), 0.0, 1.0).normalize();
        guides.points.push(Vec3::new(a, b, 2.0 * (0.3 * a).sin()));
        guides.normals.push(n);
        guides.surfaces.push(n);
        guides.groups.push(0);
        guides.spacing.push(1.0);
    }
    let sigma = 0.05f32;
    guides.noise = vec![sigma * sigma; guides.points.len()];
    let fine = grid::Grid::new(&guides.points, 3.0);
    assert_eq!(
        normal_fit::groups(&guides, &fine),
        [normal_fit::Normals::Bends]
    );
    let clean: Vec<f32> = guides.normals.iter().map(|n| 0.5 + 0.4 * n.x).collect();
    let error = |bends: bool| {
        let mut squares = 0.0;
        for seed in 0..4 {
            let mut rng = crate::math::sampling::Pcg32::new(seed, 5);
            let noisy: Vec<f32> = (clean.iter())
                .map(|t| t + sigma * 3f32.sqrt() * (2.0 * rng.next_f32() - 1.0))
                .collect();
            let mut filter = Filter::new(&guides, Settings::TEXELS, &noisy, 1, 1);
            if !bends {
                filter.normal_groups = vec![normal_fit::Normals::Plane];
            }
            let out = filter.apply(&noisy, 1);
            squares += (out.iter().zip(&clean))
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f32>();
        }
        (squares / (4 * clean.len()) as f32).sqrt()
    };
    let (bends, plane) = (error(true), error(false));
    eprintln!("noise {sigma}: bending {bends}, over the plane {plane}");
    assert!(
        bends < 0.7 * plane,
        "bending {bends}, over the plane {plane}"
    );
    let flat = bumpy_sheet(0.0);
    let fine = grid::Grid::new(&flat.points, 3.0);
    assert_eq!(
        normal_fit::groups(&flat, &fine),
        [normal_fit::Normals::Mapped]
    );
}
