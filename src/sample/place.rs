//! Positions inside regions, without overlaps between entities placed in the same region.
//!
//! An entity's footprint is the ground-plane bounding box of its resolved shape (rotated by its
//! yaw). A draw that overlaps an entity already placed in the region is re-drawn (only the free
//! axes: ranged `distance`/`lateral` attributes are re-drawn inside their range, fixed ones are
//! kept); after [`REDRAWS`] failures the entity is moved sideways to the nearest free lateral
//! position inside the region. If even that fails (the region is full) the last draw stands: an
//! overlap is a cosmetic flaw, never a change of ground truth.
//!
//! A relation is not cosmetic: every position tried must also pass the entity's `must` test
//! (its relation to its target, and room for the entities related to it). A draw that passes it
//! but overlaps is kept over one that fails it, and when no draw passes, the `rescue` position
//! (the nearest point the relation allows) stands.
//!
//! Occlusion is treated like an overlap, one rank below it: a position where the entity would be
//! hidden behind, or would hide, another entity of the scene by more than
//! [`MAX_HIDDEN`] of its projected area (`must.hidden`, estimated by
//! [`view`](super::view)) is re-drawn too, and after the re-draws one draw in each ninth of
//! where the entity may stand is tried (middle, edges, corners). When no position is both clear
//! and seen, the clear one that hides least stands.

use rand_chacha::ChaCha8Rng;

use super::rng::uniform;
use super::view::MAX_HIDDEN;
use crate::ir::{Region, ShapePart};

/// Re-draws before spreading sideways.
pub(crate) const REDRAWS: usize = 24;
/// Clear draws that are hidden before the re-draws stop.
const HIDDEN_REDRAWS: usize = 8;
/// Clearance kept between footprints (metres).
const GAP: f64 = 0.2;
/// Half-size of the footprint of an entity with no shape (metres).
const DEFAULT_HALF: f64 = 0.25;

/// Axis-aligned ground footprint relative to the entity origin: (min x, max x, min y, max y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Footprint {
    pub x0: f64,
    pub x1: f64,
    pub y0: f64,
    pub y1: f64,
}

impl Footprint {
    pub fn of(parts: &[ShapePart], yaw_deg: f64) -> Footprint {
        let mut f = Footprint { x0: f64::INFINITY, x1: f64::NEG_INFINITY, y0: f64::INFINITY, y1: f64::NEG_INFINITY };
        let (sy, cy) = yaw_deg.to_radians().sin_cos();
        for p in parts {
            let (ps, pc) = (yaw_deg + p.yaw_deg).to_radians().sin_cos();
            let (hx, hy) = (p.size[0] / 2.0, p.size[1] / 2.0);
            let (cx, cyy) = (p.at[0] * cy - p.at[1] * sy, p.at[0] * sy + p.at[1] * cy);
            let ex = (hx * pc).abs() + (hy * ps).abs();
            let ey = (hx * ps).abs() + (hy * pc).abs();
            f.x0 = f.x0.min(cx - ex);
            f.x1 = f.x1.max(cx + ex);
            f.y0 = f.y0.min(cyy - ey);
            f.y1 = f.y1.max(cyy + ey);
        }
        if f.x0 > f.x1 {
            return Footprint { x0: -DEFAULT_HALF, x1: DEFAULT_HALF, y0: -DEFAULT_HALF, y1: DEFAULT_HALF };
        }
        f
    }
}

/// One placed footprint, in the scene frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Placed {
    /// The entity's index in the scene (extras: `usize::MAX`).
    pub id: usize,
    pub region: usize,
    pub x: f64,
    pub y: f64,
    pub fp: Footprint,
}

impl Placed {
    fn overlaps(&self, o: &Placed) -> bool {
        self.region == o.region
            && self.x + self.fp.x0 < o.x + o.fp.x1 + GAP
            && o.x + o.fp.x0 < self.x + self.fp.x1 + GAP
            && self.y + self.fp.y0 < o.y + o.fp.y1 + GAP
            && o.y + o.fp.y0 < self.y + self.fp.y1 + GAP
    }
}

/// Where an axis's value comes from: a fixed attribute value, or a range to draw in (a ranged
/// attribute or the region's extent).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Axis {
    Fixed(f64),
    Range(f64, f64),
}

impl Axis {
    /// A point when the range is one, else a range to draw in.
    pub fn of((lo, hi): (f64, f64)) -> Axis {
        if lo == hi { Axis::Fixed(lo) } else { Axis::Range(lo, hi) }
    }
    pub fn extent(self) -> (f64, f64) {
        match self {
            Axis::Fixed(v) => (v, v),
            Axis::Range(lo, hi) => (lo, hi),
        }
    }
    pub fn draw(self, rng: &mut ChaCha8Rng) -> f64 {
        match self {
            Axis::Fixed(v) => v,
            Axis::Range(lo, hi) => uniform(rng, lo, hi),
        }
    }
}

/// What a position must satisfy beyond not overlapping: the entity's relation, room for the
/// entities related to it, an entity it may overlap (the one it stands on), where to go when
/// no draw satisfies it, and how much of it or of another entity it would hide there.
pub(crate) struct Must<'a> {
    pub test: &'a dyn Fn(f64, f64) -> bool,
    pub overlaps_ok: Option<usize>,
    pub rescue: Option<(f64, f64)>,
    /// The largest share of an entity's projected area hidden with this one at (x, y): its own,
    /// or that of an entity it would stand in front of (0..1).
    pub hidden: &'a dyn Fn(f64, f64) -> f64,
}

impl Must<'_> {
    /// No requirement: any position will do.
    #[cfg(test)]
    pub fn none() -> Must<'static> {
        Must { test: &|_, _| true, overlaps_ok: None, rescue: None, hidden: &|_, _| 0.0 }
    }
}

/// Place one entity. `first` is the (x, y) already drawn when its attributes were concretised;
/// returns the final (x, y).
pub(crate) fn place(
    rng: &mut ChaCha8Rng,
    placed: &[Placed],
    region: (usize, &Region),
    (ax, ay): (Axis, Axis),
    first: (f64, f64),
    fp: Footprint,
    must: &Must,
) -> (f64, f64) {
    let mut cand = Placed { id: usize::MAX, region: region.0, x: first.0, y: first.1, fp };
    let clear = |c: &Placed| !placed.iter().any(|p| Some(p.id) != must.overlaps_ok && p.overlaps(c));
    let ok = |c: &Placed| (must.test)(c.x, c.y);
    // The last draw that the relation accepts, kept if none is also clear of the others; and the
    // clear one that hides least, kept if none is also seen.
    let mut kept: Option<(f64, f64)> = None;
    let mut least_hidden: Option<((f64, f64), f64)> = None;
    let tried_hidden = std::cell::Cell::new(0);
    let mut good = |c: &Placed| {
        if !ok(c) {
            return false;
        }
        kept = Some((c.x, c.y));
        if !clear(c) {
            return false;
        }
        let hidden = (must.hidden)(c.x, c.y);
        if least_hidden.is_none_or(|(_, h)| hidden < h) {
            least_hidden = Some(((c.x, c.y), hidden));
        }
        tried_hidden.set(tried_hidden.get() + 1);
        hidden <= MAX_HIDDEN
    };
    if good(&cand) {
        return (cand.x, cand.y);
    }
    let fixed = matches!((ax, ay), (Axis::Fixed(_), Axis::Fixed(_)));
    for _ in 0..if fixed { 0 } else { REDRAWS } {
        cand.x = ax.draw(rng);
        cand.y = ay.draw(rng);
        if good(&cand) {
            return (cand.x, cand.y);
        }
        // Clear but hidden this often: the layout, not this draw, is the trouble (the caller
        // lays the scene out again).
        if tried_hidden.get() >= HIDDEN_REDRAWS {
            break;
        }
    }
    // Hidden wherever it was drawn: one draw in each ninth of where it may stand, the middle
    // first, then the edges and the corners (where a crowded view is usually still free).
    if tried_hidden.get() > 0 {
        let thirds = |a: Axis| {
            let (lo, hi) = a.extent();
            let w = (hi - lo) / 3.0;
            [(lo + w, hi - w), (lo, lo + w), (hi - w, hi)]
        };
        let (xs, ys) = (thirds(ax), thirds(ay));
        for (i, j) in [(0, 0), (0, 1), (0, 2), (1, 0), (2, 0), (1, 1), (1, 2), (2, 1), (2, 2)] {
            cand.x = Axis::of(xs[i]).draw(rng);
            cand.y = Axis::of(ys[j]).draw(rng);
            if good(&cand) {
                return (cand.x, cand.y);
            }
        }
    }
    // Spread sideways: the lateral positions that just clear each blocker, nearest first.
    let (ylo, yhi) = (region.1.y.0.min(region.1.y.1), region.1.y.0.max(region.1.y.1));
    let mut options: Vec<f64> = placed
        .iter()
        .filter(|p| p.overlaps(&cand))
        .flat_map(|p| [p.y + p.fp.y1 + GAP - fp.y0 + 1e-6, p.y + p.fp.y0 - GAP - fp.y1 - 1e-6])
        .filter(|y| (ylo..=yhi).contains(y))
        .collect();
    options.sort_by(|a, b| (a - cand.y).abs().total_cmp(&(b - cand.y).abs()).then(a.total_cmp(b)));
    for y in options {
        let c = Placed { y, ..cand };
        if good(&c) {
            return (c.x, c.y);
        }
    }
    least_hidden.map(|(at, _)| at).or(kept).or(must.rescue).unwrap_or((cand.x, cand.y))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::ConceptSet;
    use crate::ir::{Primitive, Span};
    use crate::sample::rng::scene_rng;

    fn part(size: [f64; 3], at: [f64; 3], yaw: f64) -> ShapePart {
        ShapePart {
            prim: Primitive::Box,
            size,
            at,
            color: [1.0; 4],
            yaw_deg: yaw,
            roll_deg: 0.0,
            pitch_deg: 0.0,
            material: "matte".into(),
            when: None,
            shadow: true,
        }
    }

    fn lane() -> Region {
        Region {
            name: "lane".into(),
            doc: String::new(),
            x: (0.0, 60.0),
            y: (-2.0, 2.0),
            z: (0.0, 0.0),
            scenic: None,
            span: Span::default(),
        }
    }

    #[test]
    fn footprint_rotates_with_yaw() {
        let f = Footprint::of(&[part([2.0, 1.0, 1.0], [1.0, 0.0, 0.0], 0.0)], 90.0);
        assert!((f.x0 + 0.5).abs() < 1e-9 && (f.x1 - 0.5).abs() < 1e-9);
        assert!((f.y0 - 0.0).abs() < 1e-9 && (f.y1 - 2.0).abs() < 1e-9);
        assert_eq!(Footprint::of(&[], 0.0).x1, DEFAULT_HALF);
    }

    #[test]
    fn fixed_axes_spread_sideways() {
        let mut rng = scene_rng(&[0; 32], ConceptSet::from_bits(1), 0);
        let fp = Footprint::of(&[part([0.5, 0.5, 1.0], [0.0; 3], 0.0)], 0.0);
        let lane = lane();
        let first = Placed { id: 0, region: 0, x: 3.0, y: 0.0, fp };
        let (x, y) =
            place(&mut rng, &[first], (0, &lane), (Axis::Fixed(3.0), Axis::Fixed(0.0)), (3.0, 0.0), fp, &Must::none());
        assert_eq!(x, 3.0);
        assert!((y.abs() - 0.7).abs() < 1e-3, "moved just clear of the blocker: {y}");
    }

    #[test]
    fn ranged_axes_redraw_inside_range() {
        let mut rng = scene_rng(&[1; 32], ConceptSet::from_bits(1), 0);
        let fp = Footprint::of(&[part([0.5, 0.5, 1.0], [0.0; 3], 0.0)], 0.0);
        let lane = lane();
        let first = Placed { id: 0, region: 0, x: 3.0, y: 0.0, fp };
        let axes = (Axis::Range(2.0, 4.0), Axis::Fixed(0.0));
        let (x, y) = place(&mut rng, &[first], (0, &lane), axes, (3.0, 0.0), fp, &Must::none());
        assert!((2.0..=4.0).contains(&x) && (x - 3.0).abs() >= 0.7 && y == 0.0);
    }
}
