//! What the two unwrappers share: the padding between charts and the shape of their result.

use glam::Vec2;

/// Empty texels left between charts, so bilinear filtering of one chart does not read its
/// neighbour.
pub const PADDING: u32 = 2;

/// What an unwrapper returns: per triangle its corners in texels of the `resolution`²
/// atlas (`None`: left out) and its chart.
pub(super) struct Placed {
    pub texels: Vec<Option<[Vec2; 3]>>,
    pub chart: Vec<u32>,
    pub chart_count: usize,
}

impl Placed {
    pub fn empty(triangles: usize, chart_count: usize) -> Placed {
        Placed {
            texels: vec![None; triangles],
            chart: vec![u32::MAX; triangles],
            chart_count,
        }
    }
}
