//! Applying a [`Filter`]: each cluster's kernel formed once, its fit's sums read by every
//! member at its own place.

use rayon::prelude::*;

use super::{Filter, clusters, normal_fit, vertices};

/// How [`Filter::apply_with_means`] writes a lattice's answer: over the values, or as the
/// mean of it and the other lattice's answer already there.
#[derive(Clone, Copy)]
enum Write {
    Replace,
    Average,
}

/// Clusters per block of [`Filter::apply_with_means`]: one lock per block's values, which
/// stay in a core's cache (about 400 texels' at 64).
const APPLY_BLOCK: usize = 64;

impl Filter<'_> {
    /// Member m's place about cluster c's centroid, in c's representative's tangent plane, in
    /// its spacings: (1, u, v).
    pub(super) fn member_place(&self, c: usize, m: usize) -> [f32; 3] {
        let g = self.guides;
        let r = self.clusters.reps[c] as usize;
        let (t1, t2) = self.frames[c];
        let d = (g.points[m] - self.clusters.points[c]) / g.spacing[r];
        [1.0, d.dot(t1), d.dot(t2)]
    }

    /// Member m's terms past the plane's, where its cluster c's fit has them: over a normal
    /// map, its shading normal's less c's representative's, in c's frame, and their squares
    /// and product ([`super::normal_fit`]); elsewhere its contact term less c's and its
    /// place's squares and product ([`super::texel_kernel`]).
    pub(super) fn member_extra(&self, c: usize, m: usize) -> [f32; normal_fit::NORMAL] {
        let g = self.guides;
        let r = self.clusters.reps[c] as usize;
        if !self.fitted_in_normal(g.groups[r]) {
            let contact = match (self.contact.terms.get(m), self.tap_contact.get(c)) {
                (Some(member), Some(cluster)) => member - cluster,
                _ => 0.0,
            };
            let [_, u, v] = self.member_place(c, m);
            return [contact, u * u, u * v, v * v, 0.0];
        }
        let offset = normal_fit::offset(g.normals[m], g.normals[r], self.frames[c]);
        normal_fit::normal_terms(offset, true)
    }

    /// Receiver i's weights on every receiver, normalised, in the receivers' order: its
    /// cluster's kernel at its place times each cluster's weights on its members, or the mean
    /// of those weights on the two lattices ([`super::Settings::second_lattice`]). Over a
    /// normal map [`Filter::apply_to_transfer`] adds to what they give each texel's lobe less
    /// their sum of its neighbours' ([`super::demodulate`]).
    pub fn row(&self, i: usize, out: &mut Vec<(u32, f32)>) {
        self.lattice_row(i, out);
        if let Some(shifted) = self.shifted.as_deref().filter(|_| !self.first_alone(i)) {
            let mut theirs = Vec::new();
            shifted.lattice_row(i, &mut theirs);
            let mine = std::mem::take(out);
            mean_of_rows(&mine, &theirs, out);
        }
    }

    /// Whether receiver i's answer is the first lattice's alone: a cluster of its own on
    /// both lattices ([`super::contact::Contacts::alone`]), whose two kernels would read the same
    /// neighbours but for their clustering.
    fn first_alone(&self, i: usize) -> bool {
        self.contact.alone(i)
    }

    /// [`Filter::row`] on this filter's lattice alone.
    fn lattice_row(&self, i: usize, out: &mut Vec<(u32, f32)>) {
        let c = self.cluster_of[i] as usize;
        let mut scratch = vertices::Scratch::default();
        self.cluster_kernel(c, &mut scratch);
        let place = self.member_place(c, i);
        let terms = vertices::terms(place[1], place[2]);
        let member_extra = self.member_extra(c, i);
        out.clear();
        for (n, &(k, e)) in scratch.kernel.iter().enumerate() {
            let mut w = match self.settings.quadratic {
                true => vertices::dot(&scratch.weights[n], &terms),
                false => e[0] * place[0] + e[1] * place[1] + e[2] * place[2],
            };
            if let Some(extra) = scratch.extra.get(n) {
                let terms = extra.iter().zip(&member_extra);
                w += terms.map(|(n, m)| n * m).sum::<f32>();
            }
            out.extend(
                self.clusters
                    .row(k as usize)
                    .iter()
                    .map(|&(j, m)| (j, w * m)),
            );
        }
        out.sort_unstable_by_key(|&(j, _)| j);
    }

    /// The filtered values: `values` holds `width` floats per receiver, and so does the
    /// result.
    pub fn apply(&self, values: &[f32], width: usize) -> Vec<f32> {
        let mut out = values.to_vec();
        self.apply_in_place(&mut out, width, &mut []);
        out
    }

    /// [`Filter::apply`] of `values` and of `scalars` (one float per receiver, or none)
    /// with the same kernels, in place: each cluster's kernel is formed once, and no
    /// receiver-sized buffer is allocated for the result.
    pub fn apply_in_place(&self, values: &mut [f32], width: usize, scalars: &mut [f32]) {
        let means = self.clusters.means(values, width);
        let shifted = self
            .shifted
            .as_ref()
            .map(|s| s.clusters.means(values, width));
        self.apply_on_lattices(values, (&means, shifted.as_deref()), width, scalars);
    }

    /// [`Filter::apply_in_place`] of the very transfer the filter was formed for (`width`
    /// floats per receiver, unchanged since): where that transfer was the filter's signal,
    /// its clusters' means are already at hand, the same floats. Over a normal map the
    /// filter smooths the transfer less each texel's unoccluded lobe
    /// ([`super::demodulate`]), and each texel's own is added back.
    pub fn apply_to_transfer(&self, transfer: &mut [f32], width: usize, scalars: &mut [f32]) {
        let demodulate = |transfer: &mut [f32], sign: f32| {
            if let Some(demodulation) = &self.demodulation {
                demodulation.shift(self.guides, transfer, sign);
            }
        };
        let at_hand = |f: &Filter| f.transfer_means && f.signal_width == width;
        match at_hand(self) && self.shifted.as_deref().is_none_or(at_hand) {
            // The means were formed from the demodulated signal, and every receiver's
            // value is written over: the transfer itself is not read, so not demodulated.
            true => {
                let shifted = self.shifted.as_deref().map(|s| s.transfer_means_of(width));
                let means = (self.transfer_means_of(width), shifted);
                self.apply_on_lattices(transfer, means, width, scalars)
            }
            false => {
                demodulate(transfer, -1.0);
                self.apply_in_place(transfer, width, scalars)
            }
        }
        demodulate(transfer, 1.0);
    }

    /// The clusters' means of the transfer the filter was formed for, `width` floats each.
    fn transfer_means_of(&self, width: usize) -> &[f32] {
        &self.tap_guide[..self.clusters.reps.len() * width]
    }

    /// [`Filter::apply_in_place`] with each cluster's mean of `values` given, on this
    /// filter's lattice and on the shifted one's where there is one (`shifted_means`, its
    /// clusters' means). Every mean is formed before any value is written.
    fn apply_on_lattices(
        &self,
        values: &mut [f32],
        (means, shifted_means): (&[f32], Option<&[f32]>),
        width: usize,
        scalars: &mut [f32],
    ) {
        if self.settings.quadratic {
            return self.apply_quadratic(values, means, width, scalars);
        }
        let scalar_means = |f: &Filter| match scalars.is_empty() {
            true => Vec::new(),
            false => f.clusters.means(scalars, 1),
        };
        let mine = scalar_means(self);
        let theirs = self.shifted.as_deref().map(scalar_means);
        self.apply_with_means(values, (means, &mine), width, scalars, Write::Replace);
        if let (Some(shifted), Some(means), Some(theirs)) =
            (self.shifted.as_deref(), shifted_means, theirs)
        {
            shifted.apply_with_means(values, (means, &theirs), width, scalars, Write::Average);
        }
    }

    /// One lattice's answer from each cluster's mean of the values and of the scalars,
    /// written over them or averaged with what they hold (`write`).
    fn apply_with_means(
        &self,
        values: &mut [f32],
        (means, scalar_means): (&[f32], &[f32]),
        width: usize,
        scalars: &mut [f32],
        write: Write,
    ) {
        // Per cluster, the fit's three sums Σ e_k · mean_k for each of (1, u, v), of the
        // values and then of the scalars: a member's value is their dot with its place, so
        // the clusters' means are read once per cluster, not once per member. The sums are
        // a thread's own, used up before its next cluster: no buffer of every cluster's
        // (12 MB of fresh pages on the courtyard, which cost more than forming the sums). A
        // block's members' values are formed outside the lock and copied in under it;
        // every receiver is one cluster's member, so the result is the same in any order of
        // blocks.
        let count = self.clusters.reps.len();
        let out = std::sync::Mutex::new((values, scalars));
        (0..count.div_ceil(APPLY_BLOCK))
            .into_par_iter()
            .for_each_init(
                || (vertices::Scratch::default(), Vec::new(), Vec::new()),
                |(scratch, sums, rows): &mut (_, Vec<f32>, Vec<f32>), b| {
                    let block = b * APPLY_BLOCK..((b + 1) * APPLY_BLOCK).min(count);
                    // On the second lattice, the clusters whose answer is the first's.
                    let answers = |&c: &usize| match write {
                        Write::Replace => true,
                        Write::Average => !self.first_alone(self.clusters.reps[c] as usize),
                    };
                    rows.clear();
                    for c in block.clone().filter(answers) {
                        self.cluster_kernel(c, scratch);
                        self.answer_members(c, scratch, (means, scalar_means), width, sums, rows);
                    }
                    let mut out = out.lock().expect("no block panicked");
                    let (values, scalars) = &mut *out;
                    let members = block.filter(answers).flat_map(|c| self.clusters.row(c));
                    for (&(m, _), row) in members.zip(rows.chunks_exact(width + 1)) {
                        let m = m as usize;
                        let value = &mut values[m * width..][..width];
                        match write {
                            Write::Replace => value.copy_from_slice(&row[..width]),
                            Write::Average => {
                                for (v, r) in value.iter_mut().zip(&row[..width]) {
                                    *v = 0.5 * (*v + r);
                                }
                            }
                        }
                        if let Some(s) = scalars.get_mut(m) {
                            *s = match write {
                                Write::Replace => row[width],
                                Write::Average => 0.5 * (*s + row[width]),
                            };
                        }
                    }
                },
            );
    }

    /// Appends each member of cluster c's answer, `width` values then its scalar, to `rows`,
    /// from c's kernel in `scratch` and each cluster's mean of the values and the scalars.
    /// A member's weight on neighbour k is e_k · p, p its terms (its place, and those past
    /// it: [`Filter::member_extra`]). Where c has at least as many members as its fit has
    /// terms, the fit's sums Σ e_k · mean_k are formed once, each term's, and every member
    /// dots them with its p: the neighbours' means are read once per term, not once per
    /// member. Where it has fewer (a texel alone, in contact or at a shadow's edge, whose fit
    /// has up to 8 terms), each member weighs the means with its own weights: on a terrain
    /// whose texels are mostly alone, 5 % of the filter's time.
    fn answer_members(
        &self,
        c: usize,
        scratch: &vertices::Scratch,
        (means, scalar_means): (&[f32], &[f32]),
        width: usize,
        sums: &mut Vec<f32>,
        rows: &mut Vec<f32>,
    ) {
        // The fit's terms: (1, u, v), and those past them where it has them.
        let terms = 3 + scratch.extra_terms;
        // Entry n's weights on the terms, and member m's terms.
        let entry = |n: usize| -> [f32; 3 + normal_fit::NORMAL] {
            let (e, extra) = (scratch.kernel[n].1, scratch.extra.get(n));
            std::array::from_fn(|t| match t {
                0..3 => e[t],
                _ => extra.map_or(0.0, |x| x[t - 3]),
            })
        };
        let member = |m: usize| -> [f32; 3 + normal_fit::NORMAL] {
            let place = self.member_place(c, m);
            let extra = match terms {
                3 => [0.0; normal_fit::NORMAL],
                _ => self.member_extra(c, m),
            };
            std::array::from_fn(|t| match t {
                0..3 => place[t],
                _ => extra[t - 3],
            })
        };
        let members = self.clusters.row(c);
        if members.len() < terms {
            for &(m, _) in members {
                let p = member(m as usize);
                let start = rows.len();
                rows.resize(start + width + 1, 0.0);
                let (row, scalar) = rows[start..].split_at_mut(width);
                for (n, &(k, _)) in scratch.kernel.iter().enumerate() {
                    let k = k as usize;
                    let w: f32 = entry(n).iter().zip(&p).map(|(e, p)| e * p).sum();
                    clusters::add_scaled(row, w, &means[k * width..][..width]);
                    if let Some(s) = scalar_means.get(k) {
                        scalar[0] += w * s;
                    }
                }
            }
            return;
        }
        sums.clear();
        sums.resize(terms * (width + 1), 0.0);
        let (sums, scalar_sums) = sums.split_at_mut(terms * width);
        for (n, &(k, _)) in scratch.kernel.iter().enumerate() {
            let k = k as usize;
            let e = entry(n);
            let mean = &means[k * width..(k + 1) * width];
            for (t, sums) in sums.chunks_exact_mut(width.max(1)).enumerate() {
                clusters::add_scaled(sums, e[t], mean);
            }
            if let Some(s) = scalar_means.get(k) {
                for t in 0..terms {
                    scalar_sums[t] += e[t] * s;
                }
            }
        }
        // Each member's values, then its scalar.
        for &(m, _) in members {
            let p = member(m as usize);
            match terms {
                3 => {
                    let (s0, rest) = sums.split_at(width);
                    let (s1, s2) = rest.split_at(width);
                    let dot = |(a, (b, d)): (&f32, (&f32, &f32))| a * p[0] + b * p[1] + d * p[2];
                    rows.extend(s0.iter().zip(s1.iter().zip(s2)).map(dot));
                }
                _ => rows.extend(
                    (0..width).map(|j| (0..terms).map(|t| sums[t * width + j] * p[t]).sum::<f32>()),
                ),
            }
            let s = &scalar_sums[..terms];
            rows.push(s.iter().zip(p).map(|(s, p)| s * p).sum());
        }
    }
}

/// The mean of two rows of weights (each sorted by receiver, one entry per receiver), sorted,
/// one entry per receiver.
fn mean_of_rows(a: &[(u32, f32)], b: &[(u32, f32)], out: &mut Vec<(u32, f32)>) {
    out.clear();
    let (mut i, mut j) = (0, 0);
    while i < a.len() || j < b.len() {
        let (ka, kb) = (a.get(i).map(|e| e.0), b.get(j).map(|e| e.0));
        match (ka, kb) {
            (Some(x), Some(y)) if x == y => {
                out.push((x, 0.5 * (a[i].1 + b[j].1)));
                (i, j) = (i + 1, j + 1);
            }
            (Some(x), Some(y)) if x < y => {
                out.push((x, 0.5 * a[i].1));
                i += 1;
            }
            (Some(x), None) => {
                out.push((x, 0.5 * a[i].1));
                i += 1;
            }
            _ => {
                out.push((b[j].0, 0.5 * b[j].1));
                j += 1;
            }
        }
    }
}
