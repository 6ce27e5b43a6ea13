//! A batch's fragments as lanes: the arrays the tiled scan loop already
//! has per pixel (position, depth, 1/w) kept as arrays rather than as a
//! [`Fragment`] each, so that the lane program reads a batch's quad
//! offsets and 1/w as vectors (the quad λ of its lookups,
//! [`quad_lod_lanes`](super::raster::quad_lod_lanes)) and knows a batch of
//! one triangle by a count rather than by testing every fragment. A
//! [`Fragment`] is made from a lane where one-lane code needs it.

use super::raster::Fragment;
use super::BATCH;

/// The length of each lane array: a batch's [`BATCH`] lanes and room for
/// the scan loop's eight-lane stores past its last fragment.
pub(crate) const LANE_ROOM: usize = BATCH + 8;

/// Up to [`BATCH`] fragments of one tile, of one triangle or of several,
/// stored by component (lanes past [`FragmentLanes::len`] hold anything).
pub struct FragmentLanes<'a> {
    pub(crate) len: usize,
    pub(crate) x: [u32; LANE_ROOM],
    pub(crate) y: [u32; LANE_ROOM],
    pub(crate) depth: [f32; LANE_ROOM],
    pub(crate) inv_w: [f32; LANE_ROOM],
    /// −(x & 1) and −(y & 1): the offsets of each lane's 2×2 quad's
    /// top-left pixel ([`Fragment::quad_derivatives`]).
    pub(crate) ox: [f32; LANE_ROOM],
    pub(crate) oy: [f32; LANE_ROOM],
    /// Each lane's triangle, an index into `triangles`.
    pub(crate) triangle: [u8; LANE_ROOM],
    /// The batch's triangles' gradients ([`Fragment`]'s) and facing, in the
    /// order of their first lanes; a triangle met again after another is
    /// listed again.
    pub(crate) triangles: [(&'a [f32], bool); BATCH],
    pub(crate) n_triangles: usize,
}

impl Default for FragmentLanes<'_> {
    fn default() -> Self {
        FragmentLanes {
            len: 0,
            x: [0; LANE_ROOM],
            y: [0; LANE_ROOM],
            depth: [0.0; LANE_ROOM],
            inv_w: [0.0; LANE_ROOM],
            ox: [0.0; LANE_ROOM],
            oy: [0.0; LANE_ROOM],
            triangle: [0; LANE_ROOM],
            triangles: [(&[], false); BATCH],
            n_triangles: 0,
        }
    }
}

impl<'a> FragmentLanes<'a> {
    /// `fragments` (at most [`BATCH`]) as lanes.
    pub fn from_fragments(fragments: &[Fragment<'a>]) -> FragmentLanes<'a> {
        let mut lanes = FragmentLanes::default();
        for f in fragments.iter().take(BATCH) {
            let i = lanes.len;
            let t = lanes.triangle_of(f.gradients, f.front_facing);
            (lanes.x[i], lanes.y[i], lanes.depth[i], lanes.inv_w[i]) = (f.x, f.y, f.depth, f.inv_w);
            (lanes.ox[i], lanes.oy[i]) = (-((f.x & 1) as f32), -((f.y & 1) as f32));
            lanes.triangle[i] = t;
            lanes.len += 1;
        }
        lanes
    }

    /// The number of fragments.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// No fragments.
    pub(crate) fn clear(&mut self) {
        (self.len, self.n_triangles) = (0, 0);
    }

    /// Lane `i` as a [`Fragment`].
    #[inline(always)]
    pub fn fragment(&self, i: usize) -> Fragment<'a> {
        let (gradients, front_facing) = self.triangles[self.triangle[i] as usize];
        Fragment {
            x: self.x[i],
            y: self.y[i],
            depth: self.depth[i],
            front_facing,
            inv_w: self.inv_w[i],
            gradients,
        }
    }

    /// The gradients of the batch's one triangle, where all its fragments
    /// are of one.
    #[inline(always)]
    pub(crate) fn one_triangle(&self) -> Option<&'a [f32]> {
        (self.n_triangles == 1).then(|| self.triangles[0].0)
    }

    /// The index of the triangle of `gradients` and facing `front_facing`
    /// for lanes added next: the last one listed where it is that one, else
    /// a new one.
    #[inline(always)]
    pub(crate) fn triangle_of(&mut self, gradients: &'a [f32], front_facing: bool) -> u8 {
        if let Some(&(g, f)) = self.n_triangles.checked_sub(1).map(|l| &self.triangles[l]) {
            if std::ptr::eq(g, gradients) && f == front_facing {
                return (self.n_triangles - 1) as u8;
            }
        }
        self.triangles[self.n_triangles] = (gradients, front_facing);
        self.n_triangles += 1;
        (self.n_triangles - 1) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fragments made lanes and made fragments again are themselves; a
    /// batch is of one triangle only where every lane's gradients are the
    /// first one's.
    #[test]
    fn lanes_keep_each_fragment_and_its_triangle() {
        let (a, b) = ([0.25f32; 6], [0.5f32; 6]);
        let fragment = |i: u32, g| Fragment {
            x: 3 * i + 1,
            y: i / 2,
            depth: i as f32 / 40.0,
            front_facing: i % 3 == 0,
            inv_w: 1.0 / (i + 1) as f32,
            gradients: g,
        };
        let one: Vec<Fragment> =
            (0..BATCH as u32).map(|i| Fragment { front_facing: true, ..fragment(i, &a) }).collect();
        let lanes = FragmentLanes::from_fragments(&one);
        assert_eq!(lanes.len(), BATCH);
        assert!(lanes.one_triangle().is_some_and(|g| std::ptr::eq(g, &a[..])));
        let mixed: Vec<Fragment> = (0..9).map(|i| fragment(i, if i == 4 { &b } else { &a })).collect();
        let lanes = FragmentLanes::from_fragments(&mixed);
        assert!(lanes.one_triangle().is_none());
        for (i, f) in mixed.iter().enumerate() {
            let g = lanes.fragment(i);
            assert_eq!(
                (g.x, g.y, g.depth, g.front_facing, g.inv_w),
                (f.x, f.y, f.depth, f.front_facing, f.inv_w)
            );
            assert!(std::ptr::eq(g.gradients, f.gradients), "lane {i}");
            assert_eq!((lanes.ox[i], lanes.oy[i]), (-((f.x & 1) as f32), -((f.y & 1) as f32)), "lane {i}");
        }
    }
}
