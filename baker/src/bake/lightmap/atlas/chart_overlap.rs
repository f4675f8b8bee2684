//! Whether a planar chart's projection overlaps itself. Triangles grown within a cone of the
//! projection's axis never flip, and two that share an edge lie on its two sides; but a
//! surface that winds round (a spiral ramp, even one nearly flat) comes back over itself, and
//! two of its triangles would then share texels. A uniform grid over the chart finds the few
//! pairs worth testing, so a chart of n triangles costs O(n) for well-shaped triangles.

use glam::{DVec2, Vec2};

/// Whether two of `triangles` (projected corners) overlap with positive area. Triangles that
/// only touch (a shared edge or corner) do not.
pub(super) fn overlaps_itself(triangles: &[[Vec2; 3]]) -> bool {
    if triangles.len() < 3 {
        // Two triangles of an edge-connected chart share an edge and lie on its two sides.
        return false;
    }
    let grid = Grid::new(triangles);
    let mut cell_of = Vec::with_capacity(triangles.len() * 2);
    for (t, tri) in triangles.iter().enumerate() {
        let (lo, hi) = grid.cells(bounds(tri));
        for y in lo.1..=hi.1 {
            for x in lo.0..=hi.0 {
                cell_of.push((y * grid.nx + x, t as u32));
            }
        }
    }
    cell_of.sort_unstable();
    for cell in cell_of.chunk_by(|a, b| a.0 == b.0) {
        for (i, &(c, a)) in cell.iter().enumerate() {
            for &(_, b) in &cell[i + 1..] {
                let (ta, tb) = (&triangles[a as usize], &triangles[b as usize]);
                let (box_a, box_b) = (bounds(ta), bounds(tb));
                // A pair whose boxes share several cells is tested once: in the cell of the
                // lower corner of the boxes' intersection.
                let corner = box_a.0.max(box_b.0);
                let (owner, _) = grid.cells((corner, corner));
                if owner.1 * grid.nx + owner.0 == c && overlap(ta, tb) {
                    return true;
                }
            }
        }
    }
    false
}

/// Triangles let into a chart one at a time, each only where it overlaps none already in:
/// the growth of a chart that [`overlaps_itself`]. The grid is laid over `region` (the
/// chart as first grown), so the checks stay local.
pub(super) struct Admission {
    grid: Grid,
    cells: Vec<Vec<u32>>,
    admitted: Vec<[Vec2; 3]>,
}

impl Admission {
    pub fn new(region: &[[Vec2; 3]]) -> Admission {
        let grid = Grid::new(region);
        let cells = vec![Vec::new(); grid.nx * grid.ny];
        Admission {
            grid,
            cells,
            admitted: Vec::new(),
        }
    }

    /// Lets `tri` in, unless it overlaps a triangle already in.
    pub fn admit(&mut self, tri: [Vec2; 3]) -> bool {
        let (lo, hi) = self.grid.cells(bounds(&tri));
        let cells = (lo.1..=hi.1).flat_map(|y| (lo.0..=hi.0).map(move |x| (x, y)));
        let nx = self.grid.nx;
        if cells.clone().any(|(x, y)| {
            self.cells[y * nx + x]
                .iter()
                .any(|&t| overlap(&self.admitted[t as usize], &tri))
        }) {
            return false;
        }
        let index = self.admitted.len() as u32;
        cells.for_each(|(x, y)| self.cells[y * nx + x].push(index));
        self.admitted.push(tri);
        true
    }
}

/// A uniform grid over a chart: about one triangle per cell, and never more than about
/// three cells per triangle in all, however thin the chart.
struct Grid {
    min: Vec2,
    side: f32,
    nx: usize,
    ny: usize,
}

impl Grid {
    fn new(triangles: &[[Vec2; 3]]) -> Grid {
        let n = triangles.len() as f32;
        let (mut min, mut max) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for tri in triangles {
            let (lo, hi) = bounds(tri);
            (min, max) = (min.min(lo), max.max(hi));
        }
        let extent = max - min;
        let side = (extent.x * extent.y / n)
            .sqrt()
            .max(extent.max_element() / n)
            .max(f32::MIN_POSITIVE);
        let count = |e: f32| ((e / side) as usize).clamp(0, triangles.len()) + 1;
        Grid {
            min,
            side,
            nx: count(extent.x),
            ny: count(extent.y),
        }
    }

    /// The cells (x, y) of a box's lower and upper corners, clamped to the grid.
    fn cells(&self, (lo, hi): (Vec2, Vec2)) -> ((usize, usize), (usize, usize)) {
        let cell = |p: Vec2| {
            let c = ((p - self.min) / self.side).max(Vec2::ZERO);
            (
                (c.x as usize).min(self.nx - 1),
                (c.y as usize).min(self.ny - 1),
            )
        };
        (cell(lo), cell(hi))
    }
}

fn bounds(tri: &[Vec2; 3]) -> (Vec2, Vec2) {
    (
        tri[0].min(tri[1]).min(tri[2]),
        tri[0].max(tri[1]).max(tri[2]),
    )
}

/// Whether two triangles' interiors meet: no edge of either separates them (the separating
/// axis theorem), in f64. Triangles that meet by less than 10⁻⁶ of the coordinates' size
/// (about ten f32 roundings: corners that should coincide but were computed apart) touch.
fn overlap(a: &[Vec2; 3], b: &[Vec2; 3]) -> bool {
    let (a, b) = (a.map(|p| p.as_dvec2()), b.map(|p| p.as_dvec2()));
    let scale = a
        .iter()
        .chain(&b)
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max);
    for tri in [&a, &b] {
        for k in 0..3 {
            let e = tri[(k + 1) % 3] - tri[k];
            let axis = DVec2::new(-e.y, e.x);
            let tolerance = 1e-6 * axis.length() * scale;
            let range = |t: &[DVec2; 3]| {
                let d = t.map(|p| p.dot(axis));
                (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]))
            };
            let (ra, rb) = (range(&a), range(&b));
            if ra.1 <= rb.0 + tolerance || rb.1 <= ra.0 + tolerance {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32) -> Vec2 {
        Vec2::new(x, y)
    }

    #[test]
    fn triangles_that_touch_do_not_overlap_and_folded_ones_do() {
        // A fan of six triangles round the origin: shared edges and a shared corner.
        let ring: Vec<Vec2> = (0..6)
            .map(|k| {
                let a = k as f32 * std::f32::consts::TAU / 6.0;
                v(a.cos(), a.sin())
            })
            .collect();
        let fan: Vec<[Vec2; 3]> = (0..6)
            .map(|k| [v(0.0, 0.0), ring[k], ring[(k + 1) % 6]])
            .collect();
        assert!(!overlaps_itself(&fan));
        // A grid of quads split in two: many shared edges and corners.
        let mut quads = Vec::new();
        for y in 0..20 {
            for x in 0..30 {
                let (x, y) = (x as f32 * 0.1, y as f32 * 0.1);
                quads.push([v(x, y), v(x + 0.1, y), v(x, y + 0.1)]);
                quads.push([v(x + 0.1, y), v(x + 0.1, y + 0.1), v(x, y + 0.1)]);
            }
        }
        assert!(!overlaps_itself(&quads));
        // The fan wound a second time round (a spiral ramp seen from above): its second
        // turn lies over the first.
        let twice: Vec<[Vec2; 3]> = (0..12)
            .map(|k| [v(0.0, 0.0), ring[k % 6], ring[(k + 1) % 6]])
            .collect();
        assert!(overlaps_itself(&twice));
        // One triangle of the grid moved onto another, far from it in the list.
        let mut moved = quads.clone();
        moved[500] = quads[3].map(|p| p + v(0.02, 0.02));
        assert!(overlaps_itself(&moved));
        // Let in one at a time, the second turn stays out and the first comes in whole.
        let mut admission = Admission::new(&twice);
        let admitted: Vec<bool> = twice.iter().map(|&t| admission.admit(t)).collect();
        assert_eq!(admitted, [[true; 6], [false; 6]].concat());
    }
}
