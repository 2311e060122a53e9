//! Triangle tests inside the clusters a pass draws, as niagara's meshlet shader makes them per
//! triangle, here on the CPU while the pass gathers its indices (lavapipe sets up every
//! triangle it is given on the CPU too; measured, the tests cost a small part of what the
//! triangles they drop did: docs/measurements/2026-12-02-clusters.md):
//!
//! - back faces: a triangle of a closed part wound outwards that faces away from an eye
//!   outside the part is hidden by the part's front faces (the cone test's rule, per triangle);
//! - small triangles: a triangle that holds no pixel centre of the image makes no fragment
//!   (the rasteriser samples pixel centres), whether it is tiny, a sliver between centres or
//!   off the image.
//!
//! Both are conservative with margins for the GPU's f32 arithmetic and sub-pixel snapping.

use crate::view::View;
use glam::{DMat3, DVec2, DVec3};

/// A view made ready to test many triangles.
#[derive(Clone, Debug)]
pub struct TriangleView {
    eye: DVec3,
    /// Scene-local to view space (rotation only; the eye at the origin looking down -z).
    rotation: DMat3,
    focal_px: f64,
    width: f64,
    height: f64,
    near: f64,
    /// Absolute f32 rounding of camera-relative positions (the eye's and a vertex's ulps).
    eye_ulps: f64,
}

/// Pixels a vertex may move by when the rasteriser snaps it (lavapipe keeps 8 bits below the
/// pixel; one bit of that is rounding), with room for its f32 transform.
const SNAP_PX: f64 = 1.0 / 64.0;

/// Most pixel centres inside a triangle's screen bounds that are tested one by one. A sliver
/// between two centres is common and cheap to find; a triangle whose bounds hold more covers
/// one of them so often that testing them cost lavapipe more than the triangles it dropped
/// (16 centres: the isosurface's orbit in prev 5-8% slower, the plant's walk the same).
const EDGE_TEST_CENTRES: i32 = 2;

/// On one axis of `extent` pixels, the first and last k whose pixel centre k + 0.5 lies in
/// [lo, hi] (first > last when none). Clamped, then rounded by casts: `floor` and `ceil` are
/// calls on baseline x86-64.
fn centres(lo: f64, hi: f64, extent: f64) -> (i32, i32) {
    let (a, b) = ((lo - 0.5).clamp(-1.0, extent), (hi - 0.5).clamp(-1.0, extent));
    let (ta, tb) = (a as i32, b as i32);
    ((ta + i32::from((ta as f64) < a)).max(0), (tb - i32::from((tb as f64) > b)).min(extent as i32 - 1))
}

/// A screen triangle's edges, made once for the pixel centres tested against it, grown by
/// what moves each vertex by up to `margin` in x and y.
struct Edges {
    from: [DVec2; 3],
    along: [DVec2; 3],
    length: [f64; 3],
    inv_length2: [f64; 3],
    /// The sign of the triangle's area: inside lies left of each edge for +1.
    sign: f64,
    /// How far such a move shifts an end of an edge.
    shift: f64,
}

impl Edges {
    /// None when the triangle is so thin that the moves could turn it over: it counts as
    /// covering every centre.
    fn new(s: [DVec2; 3], margin: f64) -> Option<Edges> {
        let along = [s[1] - s[0], s[2] - s[1], s[0] - s[2]];
        let length = along.map(DVec2::length);
        let area2 = along[0].perp_dot(-along[2]);
        let shift = margin * std::f64::consts::SQRT_2;
        if area2.abs() <= 2.0 * shift * length.iter().sum::<f64>() {
            return None;
        }
        Some(Edges { from: s, along, length, inv_length2: length.map(|l| 1.0 / (l * l)), sign: area2.signum(), shift })
    }

    /// True when pixel centre `p` lies outside the triangle whatever the moves: outside one
    /// edge by more than they can shift the edge at `p`.
    fn outside(&self, p: DVec2) -> bool {
        (0..3).any(|k| {
            let d = p - self.from[k];
            let inside = self.along[k].perp_dot(d) * self.sign;
            // Each end moves by up to `shift`; along the edge's line that shifts it at `p` by
            // up to (|1 - t| + |t|) times as much, t being p's place along the edge.
            inside < 0.0 && {
                let t = d.dot(self.along[k]) * self.inv_length2[k];
                inside < -self.shift * ((1.0 - t).abs() + t.abs()) * self.length[k]
            }
        })
    }
}

impl TriangleView {
    pub fn new(view: &View) -> TriangleView {
        TriangleView {
            eye: view.eye,
            rotation: DMat3::from_quat(view.orientation.inverse()),
            focal_px: view.focal_px,
            width: view.width as f64,
            height: view.height as f64,
            near: view.near,
            eye_ulps: view.eye.abs().max_element() * 2.4e-7,
        }
    }

    /// True when every vertex lies at least `near` in front of the eye and the triangle,
    /// grown by the GPU's rounding, holds no pixel centre of the image: none inside its screen
    /// bounds, or, where those hold a few, none inside its three edges.
    pub fn covers_no_pixel(&self, tri: [[f32; 3]; 3]) -> bool {
        let mut s = [DVec2::ZERO; 3];
        let mut nearest = 0.0f64;
        let mut size = 0.0f64;
        for (k, p) in tri.into_iter().enumerate() {
            let p = DVec3::from(p.map(f64::from));
            size = size.max(p.abs().max_element());
            let v = self.rotation * (p - self.eye);
            let depth = -v.z;
            if depth.is_nan() || depth < self.near {
                return false;
            }
            let px = self.focal_px / depth;
            nearest = nearest.max(px);
            s[k] = DVec2::new(self.width * 0.5 + v.x * px, self.height * 0.5 - v.y * px);
        }
        // How far a vertex may sit from where f64 puts it: f32 rounding of a camera-relative
        // position (vertex and eye ulps, the transform's relative error) in pixels at the
        // nearest vertex's depth (`nearest`: its pixels per unit), and the rasteriser's snapping.
        let margin = SNAP_PX + (nearest * (self.eye_ulps + size * 2.4e-7) + self.focal_px * 1e-6) * 4.0;
        let (lo, hi) = (s[0].min(s[1]).min(s[2]) - margin, s[0].max(s[1]).max(s[2]) + margin);
        let (x0, x1) = centres(lo.x, hi.x, self.width);
        let (y0, y1) = centres(lo.y, hi.y, self.height);
        if x0 > x1 || y0 > y1 {
            return true;
        }
        if (x1 - x0 + 1) * (y1 - y0 + 1) > EDGE_TEST_CENTRES {
            return false;
        }
        let Some(edges) = Edges::new(s, margin) else { return false };
        (y0..=y1).all(|y| (x0..=x1).all(|x| edges.outside(DVec2::new(x as f64 + 0.5, y as f64 + 0.5))))
    }

    /// True when the eye lies behind the plane of the triangle (counter-clockwise seen from
    /// its front), by a margin that f32 rounding of the eye and the vertices cannot cross.
    pub fn faces_away(&self, tri: [[f32; 3]; 3]) -> bool {
        let [a, b, c] = tri.map(|p| DVec3::from(p.map(f64::from)));
        let n = (b - a).cross(c - a);
        let to_eye = self.eye - a;
        let behind = n.dot(to_eye);
        // Squared, past the sign: behind < -|n| margin.
        behind < 0.0 && {
            let margin = to_eye.length() * 1e-4 + self.eye_ulps * 4.0 + a.abs().max_element() * 1e-6;
            behind * behind > n.length_squared() * margin * margin
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use osw_scene::Camera;

    fn view(eye: DVec3, target: DVec3, w: u32, h: u32) -> View {
        View::new(&Camera::look_at(eye, target, 60.0), DVec3::ZERO, w, h, 0.01)
    }

    /// The pixel centres a triangle covers, by the edge functions at every centre of the image
    /// (the rasteriser's rule without its snapping), counted in f64 from the view's matrix.
    fn covered(v: &View, tri: [[f32; 3]; 3]) -> usize {
        let m = v.view_proj().as_dmat4();
        let s: Vec<glam::DVec2> = tri
            .iter()
            .map(|p| {
                let c = m * (DVec3::from(p.map(f64::from)) - v.eye).extend(1.0);
                glam::DVec2::new((c.x / c.w + 1.0) * 0.5 * v.width as f64, (1.0 - c.y / c.w) * 0.5 * v.height as f64)
            })
            .collect();
        let edge = |a: glam::DVec2, b: glam::DVec2, p: glam::DVec2| (b - a).perp_dot(p - a);
        let mut n = 0;
        for y in 0..v.height {
            for x in 0..v.width {
                let p = glam::DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                let e = [edge(s[0], s[1], p), edge(s[1], s[2], p), edge(s[2], s[0], p)];
                n += usize::from(e.iter().all(|&e| e >= 0.0) || e.iter().all(|&e| e <= 0.0));
            }
        }
        n
    }

    #[test]
    fn a_triangle_said_to_cover_no_pixel_covers_none() {
        // Triangles of many sizes scattered before a 64x48 view, some far, some off screen;
        // each one said to cover no pixel centre is checked at every centre.
        let v = view(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, 64, 48);
        let t = TriangleView::new(&v);
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut culled, mut kept) = (0, 0);
        for _ in 0..4000 {
            let c = DVec3::new(next() * 16.0 - 8.0, next() * 12.0 - 6.0, -next() * 30.0);
            let size = 0.002 * 10f64.powf(next() * 4.0);
            let p = |_| (c + DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * size).as_vec3().to_array();
            let tri: [[f32; 3]; 3] = std::array::from_fn(p);
            if t.covers_no_pixel(tri) {
                assert_eq!(covered(&v, tri), 0, "{tri:?} covers a pixel centre");
                culled += 1;
            } else {
                kept += 1;
            }
        }
        assert!(culled > 500 && kept > 500, "both kinds are drawn: {culled} culled, {kept} kept");
    }

    #[test]
    fn a_triangle_across_the_near_plane_or_on_a_pixel_centre_is_kept() {
        let v = view(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), 64, 64);
        let t = TriangleView::new(&v);
        assert!(!t.covers_no_pixel([[0.0, 0.0, 1.0], [0.001, 0.0, -1.0], [0.0, 0.001, -1.0]]), "behind the eye");
        // A sliver on the centre of pixel (32, 32): the view axis meets the image at a pixel
        // corner, so that centre lies half a pixel right of and below it.
        let px = 1.0 / v.focal_px as f32;
        let z = -1.0;
        let tri = [[0.5 * px - 1e-6, -0.5 * px, z], [0.5 * px + 1e-6, -0.5 * px, z], [0.5 * px, -0.5 * px + 1e-4, z]];
        assert!(!t.covers_no_pixel(tri), "a triangle touching a pixel centre is kept");
        let away = tri.map(|p| [p[0] + 0.3 * px, p[1] + 0.3 * px, p[2]]);
        assert!(t.covers_no_pixel(away), "the same sliver between pixel centres is culled");
        // A triangle whose bounds hold that centre, the centre outside its long edge (x + y =
        // 0.3 px from it, offsets in pixels to the right and down): culled by its edges; moved so
        // that the edge runs through the centre, kept.
        let screen = |dx: f32, dy: f32| [(0.5 + dx) * px, -(0.5 + dy) * px, z];
        let corner = [(-0.6, 0.9), (0.9, 0.9), (0.9, -0.6)];
        assert!(t.covers_no_pixel(corner.map(|(x, y)| screen(x, y))), "outside an edge, inside the bounds");
        assert!(!t.covers_no_pixel(corner.map(|(x, y)| screen(x - 0.15, y - 0.15))), "on the edge");
    }

    #[test]
    fn centres_round_as_floor_and_ceil_do() {
        for k in -400..=2400 {
            let lo = k as f64 * 0.37 - 100.0;
            for hi in [lo, lo + 0.5, lo + 1.0, lo + 3.3] {
                let want = (((lo - 0.5).ceil().max(0.0)) as i32, ((hi - 0.5).floor().min(63.0)) as i32);
                let got = centres(lo, hi, 64.0);
                assert!(got == want || (got.0 > got.1 && want.0 > want.1), "[{lo}, {hi}]: {got:?} against {want:?}");
            }
        }
    }

    #[test]
    fn faces_away_only_behind_the_plane() {
        let v = view(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, 64, 64);
        let t = TriangleView::new(&v);
        let front = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let back = [front[0], front[2], front[1]];
        assert!(!t.faces_away(front));
        assert!(t.faces_away(back));
        // Edge on: the eye in the triangle's plane is never behind it.
        let edge_on = [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(!t.faces_away(edge_on) && !t.faces_away([edge_on[0], edge_on[2], edge_on[1]]));
    }
}
