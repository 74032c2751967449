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

use rand_chacha::ChaCha8Rng;

use super::rng::uniform;
use crate::ir::{Region, ShapePart};

/// Re-draws before spreading sideways.
pub(crate) const REDRAWS: usize = 24;
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
    fn draw(self, rng: &mut ChaCha8Rng) -> f64 {
        match self {
            Axis::Fixed(v) => v,
            Axis::Range(lo, hi) => uniform(rng, lo, hi),
        }
    }
}

/// What a position must satisfy beyond not overlapping: the entity's relation, room for the
/// entities related to it, an entity it may overlap (the one it stands on), and where to go when
/// no draw satisfies it.
pub(crate) struct Must<'a> {
    pub test: &'a dyn Fn(f64, f64) -> bool,
    pub overlaps_ok: Option<usize>,
    pub rescue: Option<(f64, f64)>,
}

impl Must<'_> {
    /// No requirement: any position will do.
    pub fn none() -> Must<'static> {
        Must { test: &|_, _| true, overlaps_ok: None, rescue: None }
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
    // The last draw that the relation accepts, kept if none is also clear of the others.
    let mut kept = ok(&cand).then_some((cand.x, cand.y));
    if kept.is_some() && clear(&cand) {
        return (cand.x, cand.y);
    }
    let fixed = matches!((ax, ay), (Axis::Fixed(_), Axis::Fixed(_)));
    for _ in 0..if fixed { 0 } else { REDRAWS } {
        cand.x = ax.draw(rng);
        cand.y = ay.draw(rng);
        if ok(&cand) {
            if clear(&cand) {
                return (cand.x, cand.y);
            }
            kept = Some((cand.x, cand.y));
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
        if ok(&c) && clear(&c) {
            return (c.x, c.y);
        }
    }
    kept.or(must.rescue).unwrap_or((cand.x, cand.y))
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
        let mut rng = scene_rng(&[0; 32], ConceptSet(1), 0);
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
        let mut rng = scene_rng(&[1; 32], ConceptSet(1), 0);
        let fp = Footprint::of(&[part([0.5, 0.5, 1.0], [0.0; 3], 0.0)], 0.0);
        let lane = lane();
        let first = Placed { id: 0, region: 0, x: 3.0, y: 0.0, fp };
        let axes = (Axis::Range(2.0, 4.0), Axis::Fixed(0.0));
        let (x, y) = place(&mut rng, &[first], (0, &lane), axes, (3.0, 0.0), fp, &Must::none());
        assert!((2.0..=4.0).contains(&x) && (x - 3.0).abs() >= 0.7 && y == 0.0);
    }
}
