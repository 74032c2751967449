//! The camera's rough view of the placed entities, so that the sampler can keep the entities of
//! a scene from standing behind one another (docs/sampling.md, "No entity behind another").
//!
//! Each part of an entity's look becomes a *patch*: the screen rectangle that bounds its box's
//! eight corners (rotated as the renderer turns it) and the distance of its centre along the
//! view axis. A point of one entity's patch is hidden when it lies in a nearer patch of another
//! entity. This is an estimate, not the renderer: rectangles bound round and slanted parts
//! generously, translucent parts (glass, smoke, flame, water, alpha below 1) and flat planes hide
//! nothing, and the scenery is not looked at (its layout is the domain's, see `stage` items).
//! What is actually seen is measured after rendering (the visibility guard).

use nalgebra::{Matrix3, Vector3};

use crate::ir::{Camera, Primitive, ShapePart};

/// The largest share of an entity's projected area that other entities of its scene may cover
/// where the sampler has a choice. A third leaves a partly hidden object recognisable, and the
/// rectangles overstate what round and slanted parts cover.
pub const MAX_HIDDEN: f64 = 1.0 / 3.0;
/// Points sampled per patch side when measuring how much of it is hidden.
const GRID: usize = 6;
/// Nearest distance along the view axis that still projects (metres).
const NEAR: f64 = 0.05;

/// A pinhole camera with the renderer's conventions: `fov` horizontal, x right and y down in
/// pixels, square pixels.
#[derive(Debug, Clone)]
pub(crate) struct View {
    eye: Vector3<f64>,
    forward: Vector3<f64>,
    right: Vector3<f64>,
    up: Vector3<f64>,
    focal: f64,
    width: f64,
    height: f64,
}

/// One part's screen rectangle (pixels) and depth (metres along the view axis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Patch {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
    pub depth: f64,
    /// Whether the part hides what is behind it (opaque and not flat).
    pub hides: bool,
}

/// An entity as the camera sees it: the patches of its parts that fall in the image, and the
/// rectangle that bounds them (empty when there are none).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Sight {
    pub patches: Vec<Patch>,
    bounds: [f64; 4],
}

impl Sight {
    fn meets(&self, o: &Sight) -> bool {
        let (a, b) = (self.bounds, o.bounds);
        a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
    }
}

/// A row-major rotation ([`crate::ir::rotation`]) as a matrix.
fn matrix(r: [[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_row_slice(r.as_flattened())
}

impl View {
    pub fn new(c: &Camera) -> View {
        let eye = Vector3::from(c.at);
        let mut forward = Vector3::from(c.look_at) - eye;
        if forward.norm_squared() < 1e-12 {
            forward = Vector3::x();
        }
        let forward = forward.normalize();
        let mut up = Vector3::z();
        if forward.cross(&up).norm_squared() < 1e-8 {
            up = Vector3::x();
        }
        let right = forward.cross(&up).normalize();
        let up = right.cross(&forward);
        let hfov = c.fov_deg.clamp(1.0, 170.0).to_radians();
        let width = f64::from(c.width.max(1));
        View {
            eye,
            forward,
            right,
            up,
            focal: width / 2.0 / (hfov / 2.0).tan(),
            width,
            height: f64::from(c.height.max(1)),
        }
    }

    /// Pixel position (x right, y down) and depth along the view axis; `None` behind the camera.
    pub fn project(&self, p: impl Into<Vector3<f64>>) -> Option<([f64; 2], f64)> {
        let d = p.into() - self.eye;
        let z = d.dot(&self.forward);
        if z <= NEAR {
            return None;
        }
        let (x, y) = (d.dot(&self.right), d.dot(&self.up));
        Some(([self.width / 2.0 + self.focal * x / z, self.height / 2.0 - self.focal * y / z], z))
    }

    /// The patches of an entity with these parts, turned by `yaw_deg` and standing at `at`.
    pub fn sight(&self, parts: &[ShapePart], yaw_deg: f64, at: [f64; 3]) -> Sight {
        let turn = matrix(crate::ir::rotation(yaw_deg, 0.0, 0.0));
        let mut patches = Vec::with_capacity(parts.len());
        for p in parts {
            let r = turn * matrix(p.rotation());
            let centre = turn * Vector3::from(p.at) + Vector3::from(at);
            let Some((_, depth)) = self.project(centre) else { continue };
            let (mut x0, mut y0, mut x1, mut y1) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
            for i in 0..8 {
                let corner = [0, 1, 2].map(|k| if i >> k & 1 == 1 { p.size[k] / 2.0 } else { -p.size[k] / 2.0 });
                if let Some((xy, _)) = self.project(centre + r * Vector3::from(corner)) {
                    (x0, y0, x1, y1) = (x0.min(xy[0]), y0.min(xy[1]), x1.max(xy[0]), y1.max(xy[1]));
                }
            }
            let (x0, y0, x1, y1) = (x0.max(0.0), y0.max(0.0), x1.min(self.width), y1.min(self.height));
            if x0 >= x1 || y0 >= y1 {
                continue;
            }
            let hides = !p.is_translucent() && p.prim != Primitive::Plane;
            patches.push(Patch { x0, y0, x1, y1, depth, hides });
        }
        let bounds =
            patches.iter().fold([f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY], |b, p| {
                [b[0].min(p.x0), b[1].min(p.y0), b[2].max(p.x1), b[3].max(p.y1)]
            });
        Sight { bounds: if patches.is_empty() { [0.0; 4] } else { bounds }, patches }
    }
}

impl Patch {
    fn contains(&self, x: f64, y: f64) -> bool {
        (self.x0..=self.x1).contains(&x) && (self.y0..=self.y1).contains(&y)
    }
}

/// The share (0..1) of `of`'s projected area that nearer patches of `by` cover, each patch
/// weighted by its area (sampled on a grid). An entity out of the image is hidden by nothing: 0.
pub(crate) fn hidden_share<'a>(of: &Sight, by: impl Iterator<Item = &'a Sight>) -> f64 {
    let by: Vec<&Sight> = by.filter(|s| s.meets(of)).collect();
    if by.is_empty() {
        return 0.0;
    }
    let (mut total, mut hidden) = (0.0, 0.0);
    let mut near: Vec<&Patch> = Vec::new();
    for p in &of.patches {
        let area = (p.x1 - p.x0) * (p.y1 - p.y0);
        total += area;
        near.clear();
        near.extend(
            by.iter()
                .flat_map(|s| &s.patches)
                .filter(|q| q.hides && q.depth < p.depth && q.x0 < p.x1 && p.x0 < q.x1 && q.y0 < p.y1 && p.y0 < q.y1),
        );
        if near.is_empty() {
            continue;
        }
        if near.iter().any(|q| q.x0 <= p.x0 && p.x1 <= q.x1 && q.y0 <= p.y0 && p.y1 <= q.y1) {
            hidden += area;
            continue;
        }
        let mut covered = 0;
        for i in 0..GRID {
            let x = p.x0 + (i as f64 + 0.5) * (p.x1 - p.x0) / GRID as f64;
            for j in 0..GRID {
                let y = p.y0 + (j as f64 + 0.5) * (p.y1 - p.y0) / GRID as f64;
                if near.iter().any(|q| q.contains(x, y)) {
                    covered += 1;
                }
            }
        }
        hidden += area * f64::from(covered) / (GRID * GRID) as f64;
    }
    if total > 0.0 { hidden / total } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(size: f64, material: &str) -> ShapePart {
        ShapePart {
            prim: Primitive::Box,
            size: [size; 3],
            at: [0.0, 0.0, size / 2.0],
            color: [0.5, 0.5, 0.5, 1.0],
            yaw_deg: 0.0,
            roll_deg: 0.0,
            pitch_deg: 0.0,
            material: material.into(),
            when: None,
            shadow: true,
        }
    }

    fn camera() -> Camera {
        Camera { at: [0.0, 0.0, 1.4], look_at: [30.0, 0.0, 1.0], fov_deg: 70.0, width: 640, height: 360 }
    }

    #[test]
    fn the_look_at_point_projects_to_the_centre_and_left_is_left() {
        let v = View::new(&camera());
        let (xy, depth) = v.project([30.0, 0.0, 1.0]).unwrap();
        assert!((xy[0] - 320.0).abs() < 1e-9 && (xy[1] - 180.0).abs() < 1e-9, "{xy:?}");
        assert!((depth - (30.0f64.powi(2) + 0.16).sqrt()).abs() < 1e-9);
        let (left, _) = v.project([30.0, 5.0, 1.0]).unwrap();
        assert!(left[0] < 320.0);
        assert!(v.project([-1.0, 0.0, 1.0]).is_none(), "behind the camera");
    }

    #[test]
    fn a_wall_hides_what_stands_behind_it_and_glass_does_not() {
        let v = View::new(&camera());
        let small = v.sight(&[cube(1.0, "matte")], 0.0, [30.0, 0.0, 0.0]);
        let wall = v.sight(&[cube(3.0, "matte")], 0.0, [15.0, 0.0, 0.0]);
        assert!(hidden_share(&small, [&wall].into_iter()) > 0.99);
        // The near one is not hidden by the far one.
        assert_eq!(hidden_share(&wall, [&small].into_iter()), 0.0);
        // Off to the side, nothing is hidden.
        let aside = v.sight(&[cube(1.0, "matte")], 0.0, [30.0, 8.0, 0.0]);
        assert_eq!(hidden_share(&aside, [&wall].into_iter()), 0.0);
        let glass = v.sight(&[cube(3.0, "glass")], 0.0, [15.0, 0.0, 0.0]);
        assert_eq!(hidden_share(&small, [&glass].into_iter()), 0.0);
        // Half behind the wall: about half hidden.
        let half = v.sight(&[cube(1.0, "matte")], 0.0, [30.0, 3.4, 0.0]);
        let share = hidden_share(&half, [&wall].into_iter());
        assert!(share > 0.2 && share < 0.8, "{share}");
    }
}
