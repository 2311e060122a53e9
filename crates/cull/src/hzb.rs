//! The software Z pyramid of the `hzb` baseline (Peng 2014 sec. 5.3 eq. 4): the
//! occluders' depth is read back, reduced on the CPU to a pyramid of farthest depths, and
//! boxes are tested on the CPU against the 2x2 texels of the level where the box's screen
//! rectangle spans at most two texels. Reversed Z: farther is smaller, so each texel keeps the
//! minimum of the four below it, and a box is hidden when its nearest depth (its maximum) is
//! below the farthest occluder depth over its rectangle.
//!
//! The same pyramid and test, read a few levels finer, down to the pixels under a box where
//! its texels let it through and there by the box's own depth ([`Pyramid::reaches`],
//! [`visible_box`]), are the first test of `prev`'s and the switch's default HC (`--hc
//! hybrid`): every round of its traversal then costs no GPU round trip.

use crate::frustum::Containment;
use crate::tester::{Visibility, VisibilityTester};
use crate::view::View;
use glam::{DMat4, DVec3, DVec4};
use osw_scene::{Aabb, NodeId, NodeRecord};

/// Size of the active occluder set: Peng 2014 fixes it so that the cost per frame does not
/// change at run time; 128 full-detail leaves of at most 4096 triangles cost at most ~0.5M
/// triangles of depth-only drawing.
pub const ACTIVE_OCCLUDERS: usize = 128;

/// The active occluder set of Peng 2014 sec. 5.2: leaves in the frustum weighted by eq. 3,
/// weight = V |N . E| / D^3 (V the box volume, N the normal of the box's largest face, E the
/// view direction, D the distance from the eye to the box), the `count` heaviest at full detail
/// (their level 0). The compactness pre-selection (eq. 2) is left out: every leaf is a
/// candidate.
pub fn select_occluders(nodes: &[NodeRecord], bvh_count: u32, view: &View, count: usize) -> Vec<NodeId> {
    let e = view.orientation * DVec3::NEG_Z;
    let mut weighted: Vec<(f64, NodeId)> = (0..bvh_count)
        .map(|id| &nodes[id as usize])
        .filter(|n| n.child_count == 0 && view.frustum.classify(&n.aabb()) != Containment::Outside)
        .map(|n| {
            let b = n.aabb();
            let x = b.extent().as_dvec3();
            // The largest face is normal to the smallest extent.
            let normal = match x.min_position() {
                0 => DVec3::X,
                1 => DVec3::Y,
                _ => DVec3::Z,
            };
            let d = osw_scene::error_metric::distance_to_box(view.eye, &b).max(view.near);
            (x.x * x.y * x.z * normal.dot(e).abs() / (d * d * d), n.first_lod)
        })
        .collect();
    weighted.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut out: Vec<NodeId> = weighted.into_iter().take(count).map(|w| w.1).collect();
    out.sort_unstable();
    out
}

/// The next level of a `w` x `h` image: each texel the farthest (minimum) of the 2x2 below it,
/// an odd last row or column read twice. Row by row, so that the compiler sees plain slices
/// (HC builds a pyramid of a million texels at least once a frame: 2.5-3% of the switch's CPU
/// as an iterator clamping every read, 1.1% so).
fn reduce(w: usize, h: usize, d: &[f32], next: &mut Vec<f32>) {
    next.clear();
    next.reserve(w.div_ceil(2) * h.div_ceil(2));
    for y in (0..h).step_by(2) {
        let (r0, r1) = (&d[y * w..][..w], &d[(y + 1).min(h - 1) * w..][..w]);
        next.extend(r0.chunks_exact(2).zip(r1.chunks_exact(2)).map(|(a, b)| a[0].min(a[1]).min(b[0].min(b[1]))));
        if w % 2 == 1 {
            next.push(r0[w - 1].min(r1[w - 1]));
        }
    }
}

/// Farthest-depth pyramid; level 0 is the depth buffer (row 0 at the top).
#[derive(Default)]
pub struct Pyramid {
    levels: Vec<(u32, u32, Vec<f32>)>,
}

impl Pyramid {
    /// Builds the pyramid from a `width` x `height` reversed-Z depth image.
    pub fn new(width: u32, height: u32, depth: Vec<f32>) -> Pyramid {
        let mut pyramid = Pyramid::default();
        let Ok(()) = pyramid.rebuild(width, height, |d| {
            *d = depth;
            Ok::<(), std::convert::Infallible>(())
        });
        pyramid
    }

    /// Builds the pyramid again, in this one's storage, from the `width` x `height` reversed-Z
    /// depth image that `fill` writes into level 0 (given empty). A fresh allocation of a
    /// screen's pyramid is faulted in page by page, a cost every frame would pay again
    /// (docs/measurements/2026-12-07-constants.md, "Pyramid::rebuild").
    pub fn rebuild<E>(&mut self, width: u32, height: u32, fill: impl FnOnce(&mut Vec<f32>) -> Result<(), E>) -> Result<(), E> {
        let mut storage = std::mem::take(&mut self.levels).into_iter().map(|(_, _, d)| d);
        let mut depth = storage.next().unwrap_or_default();
        depth.clear();
        fill(&mut depth)?;
        assert_eq!(depth.len(), (width * height) as usize, "depth image size");
        self.levels.push((width, height, depth));
        while let Some(&(w, h, ref d)) = self.levels.last().filter(|(w, h, _)| *w > 1 || *h > 1) {
            let mut next = storage.next().unwrap_or_default();
            reduce(w as usize, h as usize, d, &mut next);
            self.levels.push((w.div_ceil(2), h.div_ceil(2), next));
        }
        Ok(())
    }

    /// The level where the level-0 pixel rectangle [x0, x1] x [y0, y1] spans at most
    /// 2^(1 + finer) texels a side (finer = 0: Peng 2014's 2x2).
    fn level_of(&self, x0: u32, y0: u32, x1: u32, y1: u32, finer: u32) -> usize {
        let span = (x1 - x0).max(y1 - y0) + 1;
        let level = (u32::BITS - (span.max(1) - 1).leading_zeros()).saturating_sub(finer) as usize;
        level.min(self.levels.len() - 1)
    }

    /// Whether the farthest depth over the level-0 pixel rectangle [x0, x1] x [y0, y1]
    /// (inclusive), read at the level where the rectangle spans at most 2^(1 + finer) texels a
    /// side (finer = 0: Peng 2014's 2x2), lies at or behind `nearest`: conservative, the texels
    /// cover the rectangle. It stops at the first such texel, so a visible box reads only until
    /// it finds one, a hidden one every texel.
    pub fn lets_through(&self, (x0, y0, x1, y1): (u32, u32, u32, u32), nearest: f32, finer: u32) -> bool {
        let s = self.level_of(x0, y0, x1, y1, finer);
        let (w, h, d) = &self.levels[s];
        let (tx0, ty0, tx1, ty1) = (x0 >> s, y0 >> s, (x1 >> s).min(w - 1), (y1 >> s).min(h - 1));
        // Rounding margin: f32 depth against an f64 corner depth.
        (ty0..=ty1).any(|y| d[(y * w + tx0) as usize..=(y * w + tx1) as usize].iter().any(|&t| nearest >= t - 1e-7))
    }
}

impl Pyramid {
    /// Whether some pixel of the rectangle `rect` = [x0, x1] x [y0, y1] (inclusive, inside the image)
    /// lies at or behind a box there: `nearest` the box's nearest depth, and `within` its
    /// nearest depth over the pixel centres of a block of pixels (inclusive), None where it
    /// covers none of them. The pyramid is read from the level of [`Pyramid::lets_through`]
    /// down, only under texels that let the box through, to the pixels themselves. What
    /// `lets_through` answers for the texels that cover the rectangle, this answers for the
    /// box: a box behind a near occluder with gaps passes a coarse texel through a gap beside
    /// it, and its rectangle through a gap beside its silhouette. After `budget` texels read it
    /// answers true (conservative).
    pub fn reaches(
        &self,
        rect: (u32, u32, u32, u32),
        nearest: f32,
        within: &impl Fn((u32, u32, u32, u32)) -> Option<f32>,
        finer: u32,
        budget: u32,
    ) -> bool {
        let level = self.level_of(rect.0, rect.1, rect.2, rect.3, finer);
        let mut left = budget;
        self.reaches_below(level, rect, (0, 0, u32::MAX, u32::MAX), nearest, within, &mut left)
    }

    /// [`Pyramid::reaches`] at `level`, over the texels of `rect` (level-0 pixels) within
    /// `texels` (of this level).
    fn reaches_below(
        &self,
        level: usize,
        rect: (u32, u32, u32, u32),
        texels: (u32, u32, u32, u32),
        nearest: f32,
        within: &impl Fn((u32, u32, u32, u32)) -> Option<f32>,
        left: &mut u32,
    ) -> bool {
        let (w, h, d) = &self.levels[level];
        let (x0, y0, x1, y1) = rect;
        let tx0 = (x0 >> level).max(texels.0);
        let ty0 = (y0 >> level).max(texels.1);
        let tx1 = (x1 >> level).min(w - 1).min(texels.2);
        let ty1 = (y1 >> level).min(h - 1).min(texels.3);
        for y in ty0..=ty1 {
            for x in tx0..=tx1 {
                if *left == 0 {
                    return true;
                }
                *left -= 1;
                // Rounding margin: f32 depth against an f64 depth.
                let farthest = d[(y * w + x) as usize] - 1e-7;
                if nearest < farthest {
                    continue;
                }
                let block =
                    ((x << level).max(x0), (y << level).max(y0), (((x + 1) << level) - 1).min(x1), (((y + 1) << level) - 1).min(y1));
                // The box's own nearest depth over this texel's pixels: behind its farthest, hidden here.
                let Some(part) = within(block).filter(|&z| z >= farthest) else { continue };
                if level == 0 || self.reaches_below(level - 1, rect, (2 * x, 2 * y, 2 * x + 1, 2 * y + 1), part, within, left) {
                    return true;
                }
            }
        }
        false
    }
}

/// The rays through a view's pixel centres, camera-relative (the eye at the origin): pixel (x,
/// y)'s meets the near plane at `corner + x step_x + y step_y`, and the point t times as far
/// along it has reversed-Z depth 1 / t ([`View::view_proj`]: depth = near / distance along the
/// view axis).
#[derive(Clone, Copy, Debug)]
pub struct PixelRays {
    corner: DVec3,
    step_x: DVec3,
    step_y: DVec3,
}

impl PixelRays {
    pub fn new(view: &View) -> PixelRays {
        let f = 1.0 / (view.fovy_rad * 0.5).tan();
        let (w, h) = (view.width as f64, view.height as f64);
        let q = view.orientation;
        // Near-plane offsets per unit of normalised device x and y.
        let (right, up) = (q * DVec3::X * (view.near * w / h / f), q * DVec3::Y * (view.near / f));
        // Pixel centre (x + 0.5, y + 0.5): ndc x = (2x + 1) / w - 1, ndc y = 1 - (2y + 1) / h.
        let corner = q * DVec3::NEG_Z * view.near + right * (1.0 / w - 1.0) + up * (1.0 - 1.0 / h);
        PixelRays { corner, step_x: right * (2.0 / w), step_y: up * (-2.0 / h) }
    }

    /// Reversed-Z depth where the ray through pixel (x, y)'s centre enters the camera-relative
    /// box `lo..hi` (1 where the box reaches the near plane there), or None where it misses
    /// the box: what the GPU's exact test draws of the box at that pixel.
    pub fn depth_into(&self, x: u32, y: u32, lo: DVec3, hi: DVec3) -> Option<f64> {
        let d = self.corner + x as f64 * self.step_x + y as f64 * self.step_y;
        let (mut enter, mut exit) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if d[a] == 0.0 {
                if lo[a] > 0.0 || hi[a] < 0.0 {
                    return None;
                }
                continue;
            }
            let (t0, t1) = (lo[a] / d[a], hi[a] / d[a]);
            enter = enter.max(t0.min(t1));
            exit = exit.min(t0.max(t1));
        }
        (enter <= exit && exit > 0.0).then(|| 1.0 / enter.max(1.0))
    }
}

/// Levels below Peng 2014's 2x2-texel choice that the pyramid box tests read, on the GPU
/// (`BoxTest::Pyramid`, as the shader's `finer`) and in the hybrid HC's traversal on the CPU:
/// a box spans at most 16 texels a side. Behind a near occluder with gaps, 2x2 coarse texels
/// almost always see a gap.
pub const PYRAMID_FINER: u32 = 3;

/// How a box is read against a [`Pyramid`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Read {
    /// Levels below Peng 2014's 2x2-texel choice to read (see [`Pyramid::lets_through`]).
    pub finer: u32,
    /// Texels to read below that level, to the pixels ([`Pyramid::reaches`]); 0: that
    /// level's texels alone, as Peng 2014.
    pub budget: u32,
    /// Whether, on the way down, each texel is read against the box's own nearest depth over
    /// it ([`OnImage::nearest_in`]) rather than the nearest over the box's rectangle: a large
    /// box seen at a slant, or beside the eye, is hidden where its rectangle is not, at a
    /// clipping of the box per texel read.
    pub by_block: bool,
}

impl Read {
    /// `finer` levels below Peng 2014's texels, no further.
    pub const fn at(finer: u32) -> Read {
        Read { finer, budget: 0, by_block: false }
    }
}

/// Tests boxes against a [`Pyramid`] on the CPU.
pub struct HzbTester<'a> {
    pub nodes: &'a [NodeRecord],
    pub pyramid: &'a Pyramid,
    pub read: Read,
}

impl VisibilityTester for HzbTester<'_> {
    type Error = std::convert::Infallible;

    fn test(&mut self, view: &View, ids: &[NodeId], out: &mut Vec<Visibility>) -> Result<(), Self::Error> {
        let vp = view.view_proj().as_dmat4();
        for &id in ids {
            out.push(Visibility { visible: self.visible(&vp, view, id), pixels: None });
        }
        Ok(())
    }
}

/// Where a box lands on screen: its pixel rectangle (unclipped) and nearest reversed-Z depth.
pub enum Footprint {
    /// A corner is behind the eye: the traversal sends such boxes only when they straddle it.
    Behind,
    Rect {
        x0: f64,
        y0: f64,
        x1: f64,
        y1: f64,
        nearest: f64,
    },
}

impl Footprint {
    /// The box of node `id` as [`View::test_box`] grows it, through `vp` (the view's
    /// camera-relative view-projection in f64).
    pub fn of(nodes: &[NodeRecord], vp: &DMat4, view: &View, id: NodeId) -> Footprint {
        Footprint::of_box(vp, view, &nodes[id as usize].aabb())
    }

    /// As [`Footprint::of`], for any scene-local box.
    pub fn of_box(vp: &DMat4, view: &View, b: &Aabb) -> Footprint {
        let (lo, hi) = view.test_box(b);
        match clip_corners(vp, lo, hi) {
            Some(corners) => Footprint::of_points(view, &corners),
            None => Footprint::Behind,
        }
    }

    /// The rectangle and nearest depth of clip-space points in front of the eye.
    fn of_points(view: &View, points: &[DVec4]) -> Footprint {
        let (w, h) = (view.width as f64, view.height as f64);
        let (mut x0, mut y0, mut x1, mut y1, mut nearest) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY, 0.0f64);
        for clip in points {
            let (nx, ny, nz) = (clip.x / clip.w, clip.y / clip.w, clip.z / clip.w);
            x0 = x0.min((nx + 1.0) * 0.5 * w);
            x1 = x1.max((nx + 1.0) * 0.5 * w);
            y0 = y0.min((1.0 - ny) * 0.5 * h);
            y1 = y1.max((1.0 - ny) * 0.5 * h);
            nearest = nearest.max(nz);
        }
        Footprint::Rect { x0, y0, x1, y1, nearest }
    }

    /// Pixels across the larger side (infinite behind the eye).
    pub fn span_px(&self) -> f64 {
        match *self {
            Footprint::Behind => f64::INFINITY,
            Footprint::Rect { x0, y0, x1, y1, .. } => (x1 - x0).max(y1 - y0),
        }
    }
}

/// The clip-space corners of the camera-relative box `lo..hi` (corner c takes the maximum on
/// axis k where bit k of c is set), or None when one is behind the eye.
fn clip_corners(vp: &DMat4, lo: DVec3, hi: DVec3) -> Option<[DVec4; 8]> {
    let corners = std::array::from_fn(|c| {
        let p = DVec3::select(glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0), hi, lo);
        *vp * p.extend(1.0)
    });
    corners.iter().all(|c: &DVec4| c.w > 0.0).then_some(corners)
}

/// A box's six faces as corner indices (see [`clip_corners`]), each in order around it.
const BOX_FACES: [[usize; 4]; 6] = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]];

/// A box as the image shows it: its grown corners in clip space, the nearest depth of its part
/// on the image, or on any block of pixels. What lies off the image or outside a block draws
/// nothing there, and a large box beside the eye has its nearest corner off the image: its
/// part on the image is farther, and behind a wall its whole box is not. A box seen along a
/// slant is nearer at one end than at the other: each block's part has its own depth.
pub struct OnImage<'a> {
    view: &'a View,
    corners: [DVec4; 8],
    grown: (DVec3, DVec3),
    rays: PixelRays,
}

impl<'a> OnImage<'a> {
    /// None when a corner of the grown box is behind the eye.
    pub fn new(vp: &DMat4, view: &'a View, b: &Aabb) -> Option<OnImage<'a>> {
        let grown = view.test_box(b);
        let corners = clip_corners(vp, grown.0, grown.1)?;
        Some(OnImage { view, corners, grown, rays: PixelRays::new(view) })
    }

    /// The box's rectangle and nearest depth, of its faces clipped to the frustum's sides
    /// where the rectangle crosses the image's edge.
    pub fn footprint(&self) -> Footprint {
        let whole = Footprint::of_points(self.view, &self.corners);
        let (w, h) = (self.view.width as f64, self.view.height as f64);
        match whole {
            Footprint::Rect { x0, y0, x1, y1, .. } if x0 < 0.0 || y0 < 0.0 || x1 > w || y1 > h => {
                let on_image = self.clipped(-1.0, 1.0, -1.0, 1.0);
                let (x0, y0, x1, y1) = on_image.rect;
                match on_image.points {
                    // Nothing of it on the image: a rectangle off it.
                    0 => Footprint::Rect { x0: -2.0, y0: -2.0, x1: -1.0, y1: -1.0, nearest: 0.0 },
                    _ => Footprint::Rect { x0, y0, x1, y1, nearest: on_image.nearest },
                }
            }
            whole => whole,
        }
    }

    /// The box's nearest depth over the centres of the pixels [x0, x1] x [y0, y1] (inclusive):
    /// along the ray of a single pixel, else the nearest corner of its faces clipped to the
    /// frustum through the block's outer pixel centres (the nearest point of a convex body is
    /// a corner). None where it covers none of them.
    pub fn nearest_in(&self, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> Option<f64> {
        if (x0, y0) == (x1, y1) {
            return self.rays.depth_into(x0, y0, self.grown.0, self.grown.1);
        }
        let (w, h) = (self.view.width as f64, self.view.height as f64);
        // Widened a little, so that a block one pixel wide keeps a width.
        let ndc_x = |x: u32, e: f64| (2.0 * (x as f64 + 0.5 + e)) / w - 1.0;
        let ndc_y = |y: u32, e: f64| 1.0 - (2.0 * (y as f64 + 0.5 + e)) / h;
        let part = self.clipped(ndc_x(x0, -1e-3), ndc_x(x1, 1e-3), ndc_y(y1, 1e-3), ndc_y(y0, -1e-3));
        (part.points > 0).then_some(part.nearest)
    }

    /// The box's faces clipped to the frustum of normalised device x in [ax, bx], y in [ay, by].
    fn clipped(&self, ax: f64, bx: f64, ay: f64, by: f64) -> Clipped {
        let planes = [
            DVec4::new(1.0, 0.0, 0.0, -ax),
            DVec4::new(-1.0, 0.0, 0.0, bx),
            DVec4::new(0.0, 1.0, 0.0, -ay),
            DVec4::new(0.0, -1.0, 0.0, by),
        ];
        let mut out = Clipped::new(self.view);
        for face in BOX_FACES {
            out.clip_face(face.map(|c| self.corners[c]), &planes);
        }
        out
    }
}

/// What is left of a box's faces clipped to four planes (Sutherland and Hodgman: a quad cut by
/// four planes keeps at most 8 corners): the rectangle and nearest depth of those corners.
struct Clipped {
    width: f64,
    height: f64,
    points: u32,
    rect: (f64, f64, f64, f64),
    nearest: f64,
}

impl Clipped {
    fn new(view: &View) -> Clipped {
        let rect = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        Clipped { width: view.width as f64, height: view.height as f64, points: 0, rect, nearest: 0.0 }
    }

    /// Takes in what of `face` lies on the positive side of every plane (p . (x, y, z, w) >= 0).
    fn clip_face(&mut self, face: [DVec4; 4], planes: &[DVec4; 4]) {
        let (mut a, mut b) = ([DVec4::ZERO; 8], [DVec4::ZERO; 8]);
        a[..4].copy_from_slice(&face);
        let (mut poly, mut next, mut n) = (&mut a, &mut b, 4);
        for plane in planes {
            let mut m = 0;
            for i in 0..n {
                let (p, q) = (poly[i], poly[(i + 1) % n]);
                let (dp, dq) = (plane.dot(p), plane.dot(q));
                if dp >= 0.0 {
                    next[m] = p;
                    m += 1;
                }
                if (dp >= 0.0) != (dq >= 0.0) && m < 8 {
                    next[m] = p + (q - p) * (dp / (dp - dq));
                    m += 1;
                }
            }
            (poly, next, n) = (next, poly, m);
        }
        for c in &poly[..n] {
            let (nx, ny) = (c.x / c.w, c.y / c.w);
            let (x, y) = ((nx + 1.0) * 0.5 * self.width, (1.0 - ny) * 0.5 * self.height);
            self.rect = (self.rect.0.min(x), self.rect.1.min(y), self.rect.2.max(x), self.rect.3.max(y));
            self.nearest = self.nearest.max(c.z / c.w);
        }
        self.points += n as u32;
    }
}

impl HzbTester<'_> {
    fn visible(&self, vp: &DMat4, view: &View, id: NodeId) -> bool {
        visible_box(self.pyramid, vp, view, &self.nodes[id as usize].aabb(), self.read)
    }
}

/// Whether any of box `b` may be nearer than the farthest depth under its rectangle (see
/// [`Read`] for how it is read): false only when all of it is hidden. `vp`: the view's
/// camera-relative view-projection in f64.
/// With a `budget`, its rectangle on the image ([`OnImage::footprint`]), and the texels that
/// let it through are read down to the pixels under it, and there by the box's own depth at
/// each pixel centre its silhouette covers ([`Pyramid::reaches`], [`PixelRays`]): as the GPU's
/// exact test draws the box. Most boxes the rectangle let through are small and far, seen
/// beside an occluder's edge.
pub fn visible_box(pyramid: &Pyramid, vp: &DMat4, view: &View, b: &Aabb, read: Read) -> bool {
    let (w, h) = (view.width as f64, view.height as f64);
    let pixels = |x0: f64, y0: f64, x1: f64, y1: f64| {
        let clamp = |v: f64, m: f64| v.clamp(0.0, m - 1.0) as u32;
        (x1 >= 0.0 && y1 >= 0.0 && x0 < w && y0 < h)
            .then(|| (clamp(x0.floor(), w), clamp(y0.floor(), h), clamp(x1.floor(), w), clamp(y1.floor(), h)))
    };
    if read.budget == 0 {
        // Peng 2014's test, as the GPU pyramid's shader makes it: the whole box's rectangle.
        let Footprint::Rect { x0, y0, x1, y1, nearest } = Footprint::of_box(vp, view, b) else { return true };
        return pixels(x0, y0, x1, y1).is_some_and(|rect| pyramid.lets_through(rect, nearest as f32, read.finer));
    }
    let Some(on_image) = OnImage::new(vp, view, b) else { return true };
    let Footprint::Rect { x0, y0, x1, y1, nearest } = on_image.footprint() else { return true };
    let Some(rect) = pixels(x0, y0, x1, y1) else { return false };
    let within = |block: (u32, u32, u32, u32)| match read.by_block || (block.0, block.1) == (block.2, block.3) {
        true => on_image.nearest_in(block).map(|z| z as f32),
        false => Some(nearest as f32),
    };
    pyramid.reaches(rect, nearest as f32, &within, read.finer, read.budget)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pyramid_keeps_the_farthest_depth() {
        // 3x2 image; level 1 is 2x1: min over the 2x2 blocks (clamped at the edge).
        let p = Pyramid::new(3, 2, vec![0.9, 0.5, 0.7, 0.8, 0.6, 0.4]);
        assert_eq!(p.levels[1], (2, 1, vec![0.5, 0.4]));
        assert_eq!(p.levels[2], (1, 1, vec![0.4]));
        // The farthest depth over a rectangle at the level read: a box as near as it passes,
        // one nearer does not.
        let farthest = |rect, finer, far: f32| p.lets_through(rect, far, finer) && !p.lets_through(rect, far - 0.01, finer);
        assert!(farthest((0, 0, 0, 0), 0, 0.9));
        assert!(farthest((0, 0, 1, 1), 0, 0.5));
        assert!(farthest((0, 0, 2, 1), 0, 0.4));
        // One level finer: the 2x2 rectangle is read at level 0, texel by texel.
        assert!(farthest((0, 0, 1, 0), 1, 0.5));
        assert!(farthest((0, 0, 0, 1), 1, 0.8));
    }

    /// A linear congruential generator: samples reproducible by seed.
    struct Lcg(u32);

    impl Lcg {
        fn next(&mut self) -> u32 {
            self.0 = self.0.wrapping_mul(1664525).wrapping_add(1013904223);
            self.0 >> 8
        }

        /// In [0, 1).
        fn unit(&mut self) -> f64 {
            self.next() as f64 / (1 << 24) as f64
        }

        /// In [0, m).
        fn below(&mut self, m: u32) -> u32 {
            self.next() % m
        }
    }

    /// A `w` x `h` depth image of random depths, reproducible by `seed`.
    fn noise(w: u32, h: u32, seed: u32) -> Vec<f32> {
        let mut rng = Lcg(seed);
        (0..w * h).map(|_| rng.unit() as f32).collect()
    }

    #[test]
    fn reaching_the_pixels_answers_for_the_rectangle_itself() {
        // Against the pixels read one by one: with budget to spare, `reaches` is exact; with
        // little, it may only add visible answers; `lets_through` at the start level never hides
        // a rectangle that `reaches` finds.
        let (w, h) = (61u32, 45u32);
        let p = Pyramid::new(w, h, noise(w, h, 11).iter().map(|d| 0.5 + 0.5 * d).collect());
        let depth = &p.levels[0].2;
        let mut rng = Lcg(5);
        let (mut hidden, mut shown) = (0, 0);
        for _ in 0..2000 {
            let (x0, y0) = (rng.below(w), rng.below(h));
            let (x1, y1) = ((x0 + rng.below(24)).min(w - 1), (y0 + rng.below(24)).min(h - 1));
            let nearest = 0.48 + 0.06 * rng.below(1000) as f32 / 1000.0;
            let brute = (y0..=y1).any(|y| (x0..=x1).any(|x| nearest >= depth[(y * w + x) as usize] - 1e-7));
            for finer in [0, 3] {
                let rect = |_| Some(nearest);
                assert_eq!(p.reaches((x0, y0, x1, y1), nearest, &rect, finer, u32::MAX), brute, "({x0},{y0})-({x1},{y1}) at {nearest}");
                assert!(!brute || p.reaches((x0, y0, x1, y1), nearest, &rect, finer, 3), "a small budget hid a visible rectangle");
                assert!(!brute || p.lets_through((x0, y0, x1, y1), nearest, finer));
            }
            (hidden, shown) = (hidden + u32::from(!brute), shown + u32::from(brute));
        }
        assert!(hidden > 100 && shown > 100, "too one-sided to tell: {hidden} hidden, {shown} shown");
    }

    #[test]
    fn a_box_read_to_the_pixels_is_visible_wherever_a_pixel_of_it_is() {
        // The reference: each box's faces rasterised at pixel centres against the depth there.
        // A test that hides a box with a visible pixel fails; reading to the pixels hides
        // more than the rectangle alone, and block by block no fewer.
        use osw_scene::Camera;
        let (w, h) = (96u32, 64u32);
        let view = View::new(&Camera::look_at(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, 60.0), DVec3::ZERO, w, h, 0.01);
        let vp = view.view_proj().as_dmat4();
        // Occluders: a wall of random depth in front of the boxes, with gaps.
        let depth: Vec<f32> = noise(w, h, 3).iter().map(|d| if *d < 0.15 { 0.0 } else { 0.9 + 0.1 * d }).collect();
        let p = Pyramid::new(w, h, depth.clone());
        let (mut culled_rect, mut culled_pixels, mut culled_blocks, mut visible) = (0, 0, 0, 0);
        let mut rng = Lcg(9);
        let mut unit = || rng.unit() as f32;
        for _ in 0..500 {
            let c = glam::Vec3::new(8.0 * unit() - 4.0, 6.0 * unit() - 3.0, -6.0 * unit());
            let e = glam::Vec3::new(3.0 * unit(), 0.3 * unit(), 3.0 * unit()) + 0.05;
            let b = Aabb { min: c - e, max: c + e };
            let raw = (b.min.as_dvec3() - view.eye, b.max.as_dvec3() - view.eye);
            let seen = (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .any(|(x, y)| drawn_box_at(&view, raw, x, y).0.is_some_and(|z| z >= depth[(y * w + x) as usize] as f64));
            let rect = visible_box(&p, &vp, &view, &b, Read::at(0));
            let read = |by_block| Read { finer: 3, budget: 1 << 16, by_block };
            let (pixels, blocks) = (visible_box(&p, &vp, &view, &b, read(false)), visible_box(&p, &vp, &view, &b, read(true)));
            assert!(!seen || pixels, "box {b:?} has a visible pixel but was hidden");
            assert!(!seen || blocks, "box {b:?} has a visible pixel but was hidden block by block");
            assert!(!pixels || rect, "the pixels let through a box its rectangle hid");
            assert_eq!(pixels, blocks, "box {b:?}: with budget to spare, block by block only reads fewer texels");
            (culled_rect, culled_pixels, culled_blocks, visible) = (
                culled_rect + u32::from(!rect),
                culled_pixels + u32::from(!pixels),
                culled_blocks + u32::from(!blocks),
                visible + u32::from(seen),
            );
        }
        assert!(
            visible > 50 && culled_pixels > culled_rect && culled_blocks == culled_pixels,
            "{visible} visible; culled {culled_rect} by the rectangle, {culled_pixels} to the pixels, {culled_blocks} block by block"
        );
    }

    /// Box `lo..hi` (camera-relative) drawn at pixel (x, y)'s centre as a rasteriser draws its
    /// 12 triangles through `view`: the nearest reversed-Z depth among the faces covering the
    /// centre (interpolated linearly on screen, where it is affine), and the centre's distance
    /// in pixels to the nearest triangle edge.
    fn drawn_box_at(view: &View, (lo, hi): (DVec3, DVec3), x: u32, y: u32) -> (Option<f64>, f64) {
        let vp = view.view_proj().as_dmat4();
        let (w, h) = (view.width as f64, view.height as f64);
        let corner = |i: usize| {
            let p = DVec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
            let q = vp * p.extend(1.0);
            DVec3::new((q.x / q.w + 1.0) * 0.5 * w, (1.0 - q.y / q.w) * 0.5 * h, q.z / q.w)
        };
        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
        let (mut depth, mut edge) = (None::<f64>, f64::INFINITY);
        for f in BOX_FACES {
            for [a, b, c] in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]].map(|t| t.map(corner)) {
                let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
                if area.abs() < 1e-12 {
                    continue;
                }
                let sides = [(b, c), (c, a), (a, b)];
                let l = sides.map(|(u, v)| ((v.x - u.x) * (py - u.y) - (v.y - u.y) * (px - u.x)) / area);
                for (v, (u, t)) in l.iter().zip(sides) {
                    edge = edge.min((v * area).abs() / (t.truncate() - u.truncate()).length());
                }
                if l.iter().all(|&v| v >= 0.0) {
                    let z = l[0] * a.z + l[1] * b.z + l[2] * c.z;
                    depth = Some(depth.map_or(z, |d| d.max(z)));
                }
            }
        }
        (depth, edge)
    }

    #[test]
    fn pixel_rays_enter_a_box_where_its_faces_are_drawn() {
        // Coverage agrees with the rasterised faces away from their edges, and depth wherever
        // both cover the centre (the view-projection is f32, the rays f64).
        use osw_scene::Camera;
        let camera = Camera::look_at(DVec3::new(3.0, 2.0, 9.0), DVec3::new(0.5, -0.5, 0.0), 55.0);
        let view = View::new(&camera, DVec3::ZERO, 80, 50, 0.05);
        let rays = PixelRays::new(&view);
        let mut rng = Lcg(3);
        let mut covered = 0;
        for _ in 0..40 {
            let c = DVec3::new(6.0 * rng.unit() - 3.0, 4.0 * rng.unit() - 2.0, 4.0 * rng.unit() - 4.0);
            let e = DVec3::new(2.0 * rng.unit(), 2.0 * rng.unit(), 2.0 * rng.unit()) + 0.05;
            let b = (c - e - view.eye, c + e - view.eye);
            for (y, x) in (0..view.height).flat_map(|y| (0..view.width).map(move |x| (y, x))) {
                let ((drawn, edge), got) = (drawn_box_at(&view, b, x, y), rays.depth_into(x, y, b.0, b.1));
                if edge > 1e-3 {
                    assert_eq!(got.is_some(), drawn.is_some(), "pixel ({x}, {y}) of box {b:?}");
                }
                if let (Some(g), Some(d)) = (got, drawn) {
                    assert!((g - d).abs() <= 1e-6 * d, "pixel ({x}, {y}): depth {g} against {d}");
                    covered += 1;
                }
            }
        }
        assert!(covered > 2000, "{covered} pixels covered");
    }

    #[test]
    fn a_box_across_the_image_edge_is_measured_on_the_image() {
        // Every pixel centre the box's faces cover lies in its rectangle on the image, no
        // nearer than its nearest depth there; boxes that reach far off the image get a
        // smaller rectangle and a farther nearest depth than their whole.
        use osw_scene::Camera;
        let camera = Camera::look_at(DVec3::new(0.0, 1.0, 6.0), DVec3::new(0.0, 0.0, 0.0), 60.0);
        let view = View::new(&camera, DVec3::ZERO, 64, 48, 0.05);
        let vp = view.view_proj().as_dmat4();
        let mut rng = Lcg(17);
        let (mut tighter, mut covered) = (0, 0);
        for _ in 0..200 {
            let c = DVec3::new(16.0 * rng.unit() - 8.0, 12.0 * rng.unit() - 6.0, -8.0 * rng.unit() + 1.0);
            let e = DVec3::new(4.0 * rng.unit(), 4.0 * rng.unit(), 4.0 * rng.unit()) + 0.05;
            let b = Aabb { min: (c - e).as_vec3(), max: (c + e).as_vec3() };
            let (Footprint::Rect { x0, y0, x1, y1, nearest }, Footprint::Rect { nearest: whole, .. }) =
                (OnImage::new(&vp, &view, &b).map_or(Footprint::Behind, |o| o.footprint()), Footprint::of_box(&vp, &view, &b))
            else {
                continue;
            };
            for (y, x) in (0..view.height).flat_map(|y| (0..view.width).map(move |x| (y, x))) {
                let Some(z) = drawn_box_at(&view, view.test_box(&b), x, y).0 else { continue };
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let margin = 1e-9;
                assert!(px >= x0 - margin && px <= x1 + margin && py >= y0 - margin && py <= y1 + margin, "({x}, {y}) outside {b:?}");
                assert!(z <= nearest * (1.0 + 1e-6), "({x}, {y}) at {z}, nearer than {nearest}");
                covered += 1;
            }
            tighter += u32::from(nearest < whole * 0.9);
        }
        assert!(covered > 10_000 && tighter > 20, "{covered} pixels covered, {tighter} boxes nearer off the image");
    }

    #[test]
    fn a_block_of_pixels_sees_the_nearest_part_of_the_box_within_it() {
        // Against the faces rasterised pixel by pixel: a block's nearest depth is no nearer than
        // nothing and no farther than any covered centre in it; a block holding no covered
        // centre (away from the edges) reaches nothing; slanted boxes give blocks farther than
        // the whole box's nearest.
        use osw_scene::Camera;
        let camera = Camera::look_at(DVec3::new(1.0, 2.0, 7.0), DVec3::new(0.0, 0.0, -1.0), 60.0);
        let view = View::new(&camera, DVec3::ZERO, 48, 40, 0.05);
        let vp = view.view_proj().as_dmat4();
        let mut rng = Lcg(29);
        let (mut farther, mut blocks) = (0, 0);
        for _ in 0..60 {
            let c = glam::Vec3::new(rng.below(120) as f32 / 10.0 - 6.0, rng.below(80) as f32 / 10.0 - 4.0, -(rng.below(80) as f32) / 10.0);
            let e = glam::Vec3::new(rng.below(40) as f32 / 10.0, rng.below(40) as f32 / 10.0, rng.below(60) as f32 / 10.0) + 0.05;
            let b = Aabb { min: c - e, max: c + e };
            let Some(on_image) = OnImage::new(&vp, &view, &b) else { continue };
            let Footprint::Rect { nearest, .. } = on_image.footprint() else { continue };
            let drawn: Vec<(Option<f64>, f64)> = (0..view.height)
                .flat_map(|y| (0..view.width).map(move |x| (x, y)))
                .map(|(x, y)| drawn_box_at(&view, view.test_box(&b), x, y))
                .collect();
            for _ in 0..40 {
                let (x0, y0) = (rng.below(view.width), rng.below(view.height));
                let (x1, y1) = ((x0 + rng.below(12)).min(view.width - 1), (y0 + rng.below(12)).min(view.height - 1));
                let cells = (y0..=y1).flat_map(|y| (x0..=x1).map(move |x| (y * view.width + x) as usize));
                let (deepest, sure) = cells.fold((None::<f64>, true), |(d, sure), i| {
                    let (z, edge) = drawn[i];
                    (z.map_or(d, |z| Some(d.map_or(z, |d: f64| d.max(z)))), sure && edge > 1e-3)
                });
                let got = on_image.nearest_in((x0, y0, x1, y1));
                if let Some(z) = deepest {
                    assert!(got.is_some_and(|g| g >= z * (1.0 - 1e-6)), "block ({x0},{y0})-({x1},{y1}) of {b:?}: {got:?} against {z}");
                    farther += u32::from(got.is_some_and(|g| g < nearest * 0.95));
                } else if sure {
                    assert!(got.is_none_or(|g| g <= nearest), "block ({x0},{y0})-({x1},{y1}) of {b:?}: {got:?}, nearer than the box");
                }
                blocks += u32::from(deepest.is_some());
            }
        }
        assert!(blocks > 300 && farther > 30, "{blocks} blocks covered, {farther} farther than their box");
    }

    #[test]
    fn every_level_holds_the_farthest_of_its_block() {
        // Odd sizes both ways: each texel of level l is the minimum over the level-0 pixels of
        // its 2^l x 2^l block, clipped to the image, counted pixel by pixel.
        let (w, h) = (37u32, 23u32);
        let depth = noise(w, h, 7);
        // Built new, and again in the storage of a larger pyramid of another shape.
        let mut reused = Pyramid::new(64, 9, vec![0.0; 64 * 9]);
        let Ok(()) = reused.rebuild(w, h, |d| {
            d.extend_from_slice(&depth);
            Ok::<(), std::convert::Infallible>(())
        });
        for p in [Pyramid::new(w, h, depth.clone()), reused] {
            assert_eq!(p.levels.last().map(|l| (l.0, l.1)), Some((1, 1)));
            holds_the_farthest_of_each_block(&p, w, h, &depth);
        }
    }

    fn holds_the_farthest_of_each_block(p: &Pyramid, w: u32, h: u32, depth: &[f32]) {
        for (l, (lw, lh, d)) in p.levels.iter().enumerate() {
            for (y, x) in (0..*lh).flat_map(|y| (0..*lw).map(move |x| (y, x))) {
                let block = |v: u32, n: u32| (v << l)..((v + 1) << l).min(n);
                let want =
                    block(y, h).flat_map(|py| block(x, w).map(move |px| depth[(py * w + px) as usize])).fold(f32::INFINITY, f32::min);
                assert_eq!(d[(y * lw + x) as usize], want, "level {l}, texel ({x}, {y})");
            }
        }
    }
}
