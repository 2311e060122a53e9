//! The software Z pyramid of the `hzb` baseline (Peng 2014 sec. 5.3 eq. 4): the
//! occluders' depth is read back, reduced on the CPU to a pyramid of farthest depths, and
//! boxes are tested on the CPU against the 2x2 texels of the level where the box's screen
//! rectangle spans at most two texels. Reversed Z: farther is smaller, so each texel keeps the
//! minimum of the four below it, and a box is hidden when its nearest depth (its maximum) is
//! below the farthest occluder depth over its rectangle.
//!
//! The same pyramid and test, read a few levels finer, down to the pixels under a box where
//! its texels let it through ([`Pyramid::reaches`]), and on the halves of a box that passes
//! ([`visible_parts`]), are the first test of `prev`'s and the switch's default HC (`--hc
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
    /// depth image that `fill` writes into level 0 (given empty). A 1024x1024 pyramid is 5.6 MB,
    /// which a fresh allocation faults in page by page: measured, page faults took about 8% of
    /// a frame's CPU on the 10B instanced plant's walk when every pyramid was new.
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
    /// lies at or behind depth `nearest`: the pyramid read from the level of
    /// [`Pyramid::lets_through`] down, only under texels that let `nearest` through, to the pixels
    /// themselves. What `lets_through` answers for the texels that cover the rectangle, this
    /// answers for the rectangle: a box behind a near occluder with gaps passes a coarse texel
    /// through a gap beside it. After `budget` texels read it answers true (conservative).
    pub fn reaches(&self, rect: (u32, u32, u32, u32), nearest: f32, finer: u32, budget: u32) -> bool {
        let level = self.level_of(rect.0, rect.1, rect.2, rect.3, finer);
        let mut left = budget;
        self.reaches_below(level, rect, (0, 0, u32::MAX, u32::MAX), nearest, &mut left)
    }

    /// [`Pyramid::reaches`] at `level`, over the texels of `rect` (level-0 pixels) within
    /// `within` (texels of this level).
    fn reaches_below(&self, level: usize, rect: (u32, u32, u32, u32), within: (u32, u32, u32, u32), nearest: f32, left: &mut u32) -> bool {
        let (w, h, d) = &self.levels[level];
        let (x0, y0, x1, y1) = rect;
        let tx0 = (x0 >> level).max(within.0);
        let ty0 = (y0 >> level).max(within.1);
        let tx1 = (x1 >> level).min(w - 1).min(within.2);
        let ty1 = (y1 >> level).min(h - 1).min(within.3);
        for y in ty0..=ty1 {
            for x in tx0..=tx1 {
                if *left == 0 {
                    return true;
                }
                *left -= 1;
                // Rounding margin: f32 depth against an f64 corner depth.
                if nearest < d[(y * w + x) as usize] - 1e-7 {
                    continue;
                }
                if level == 0 || self.reaches_below(level - 1, rect, (2 * x, 2 * y, 2 * x + 1, 2 * y + 1), nearest, left) {
                    return true;
                }
            }
        }
        false
    }
}

/// Levels below Peng 2014's 2x2-texel choice that the pyramid box tests read, on the GPU
/// (`BoxTest::Pyramid`, as the shader's `finer`) and in the hybrid HC's traversal on the CPU:
/// a box spans at most 16 texels a side. Behind a near occluder with gaps, 2x2 coarse texels
/// almost always see a gap.
pub const PYRAMID_FINER: u32 = 3;

/// Tests boxes against a [`Pyramid`] on the CPU.
pub struct HzbTester<'a> {
    pub nodes: &'a [NodeRecord],
    pub pyramid: &'a Pyramid,
    /// Levels below Peng 2014's 2x2-texel choice to read (see [`Pyramid::lets_through`]).
    pub finer: u32,
    /// Texels to read below that level, to the pixels ([`Pyramid::reaches`]); 0: that
    /// level's texels alone, as Peng 2014.
    pub budget: u32,
    /// Times a box that passes is halved along its longest side and its halves tested
    /// ([`visible_parts`]); 0: the box alone.
    pub splits: u32,
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
        let (w, h) = (view.width as f64, view.height as f64);
        let (mut x0, mut y0, mut x1, mut y1, mut nearest) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY, 0.0f64);
        for c in 0..8 {
            let p = DVec3::new(
                if c & 1 != 0 { hi.x } else { lo.x },
                if c & 2 != 0 { hi.y } else { lo.y },
                if c & 4 != 0 { hi.z } else { lo.z },
            );
            let clip = *vp * DVec4::new(p.x, p.y, p.z, 1.0);
            if clip.w <= 0.0 {
                return Footprint::Behind;
            }
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

impl HzbTester<'_> {
    fn visible(&self, vp: &DMat4, view: &View, id: NodeId) -> bool {
        visible_parts(self.pyramid, vp, view, &self.nodes[id as usize].aabb(), (self.finer, self.budget), self.splits)
    }
}

/// Whether any of box `b` may be nearer than the farthest depth under its screen rectangle
/// (read `finer` levels below Peng 2014's 2x2 texels): false only when all of it is hidden.
/// `vp`: the view's camera-relative view-projection in f64.
/// With a `budget`, the texels that let it through are read down to the pixels under its
/// rectangle ([`Pyramid::reaches`]).
pub fn visible_box(pyramid: &Pyramid, vp: &DMat4, view: &View, b: &Aabb, finer: u32, budget: u32) -> bool {
    let Footprint::Rect { x0, y0, x1, y1, nearest } = Footprint::of_box(vp, view, b) else { return true };
    let (w, h) = (view.width as f64, view.height as f64);
    if x1 < 0.0 || y1 < 0.0 || x0 >= w || y0 >= h {
        return false;
    }
    let clamp = |v: f64, m: f64| v.clamp(0.0, m - 1.0) as u32;
    let (x0, y0, x1, y1) = (clamp(x0.floor(), w), clamp(y0.floor(), h), clamp(x1.floor(), w), clamp(y1.floor(), h));
    if budget > 0 {
        return pyramid.reaches((x0, y0, x1, y1), nearest as f32, finer, budget);
    }
    pyramid.lets_through((x0, y0, x1, y1), nearest as f32, finer)
}

/// [`visible_box`] (`read`: its `finer` and `budget`), and where the box passes, its halves
/// along its longest side, `splits` times over: visible when a part is. A footprint takes the
/// box's nearest depth over all of its rectangle, so a long box seen at a slant (a pipe
/// along a wall) passes behind an occluder that hides every part of it; each half has a
/// smaller rectangle and a farther nearest depth. The halves cover the box: conservative.
pub fn visible_parts(pyramid: &Pyramid, vp: &DMat4, view: &View, b: &Aabb, read: (u32, u32), splits: u32) -> bool {
    if !visible_box(pyramid, vp, view, b, read.0, read.1) {
        return false;
    }
    if splits == 0 {
        return true;
    }
    let axis = b.extent().max_position();
    let mid = 0.5 * (b.min[axis] + b.max[axis]);
    let (mut lo, mut hi) = (*b, *b);
    lo.max[axis] = mid;
    hi.min[axis] = mid;
    visible_parts(pyramid, vp, view, &lo, read, splits - 1) || visible_parts(pyramid, vp, view, &hi, read, splits - 1)
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

    /// A `w` x `h` depth image of random depths, reproducible by `seed`.
    fn noise(w: u32, h: u32, seed: u32) -> Vec<f32> {
        let mut rng = seed;
        (0..w * h)
            .map(|_| {
                rng = rng.wrapping_mul(1664525).wrapping_add(1013904223);
                (rng >> 8) as f32 / (1 << 24) as f32
            })
            .collect()
    }

    #[test]
    fn reaching_the_pixels_answers_for_the_rectangle_itself() {
        // Against the pixels read one by one: with budget to spare, `reaches` is exact; with
        // little, it may only add visible answers; `lets_through` at the start level never hides
        // a rectangle that `reaches` finds.
        let (w, h) = (61u32, 45u32);
        let p = Pyramid::new(w, h, noise(w, h, 11).iter().map(|d| 0.5 + 0.5 * d).collect());
        let depth = &p.levels[0].2;
        let mut rng = 5u32;
        let mut next = |m: u32| {
            rng = rng.wrapping_mul(22695477).wrapping_add(1);
            (rng >> 8) % m
        };
        let (mut hidden, mut shown) = (0, 0);
        for _ in 0..2000 {
            let (x0, y0) = (next(w), next(h));
            let (x1, y1) = ((x0 + next(24)).min(w - 1), (y0 + next(24)).min(h - 1));
            let nearest = 0.48 + 0.06 * next(1000) as f32 / 1000.0;
            let brute = (y0..=y1).any(|y| (x0..=x1).any(|x| nearest >= depth[(y * w + x) as usize] - 1e-7));
            for finer in [0, 3] {
                assert_eq!(p.reaches((x0, y0, x1, y1), nearest, finer, u32::MAX), brute, "({x0},{y0})-({x1},{y1}) at {nearest}");
                assert!(!brute || p.reaches((x0, y0, x1, y1), nearest, finer, 3), "a small budget hid a visible rectangle");
                assert!(!brute || p.lets_through((x0, y0, x1, y1), nearest, finer));
            }
            (hidden, shown) = (hidden + u32::from(!brute), shown + u32::from(brute));
        }
        assert!(hidden > 100 && shown > 100, "too one-sided to tell: {hidden} hidden, {shown} shown");
    }

    #[test]
    fn a_box_split_into_parts_is_visible_wherever_a_point_of_it_is() {
        // The reference: points on a grid through each box, projected, against the depth at
        // their pixel. A part test that hides a box with a visible point fails.
        use osw_scene::Camera;
        let (w, h) = (96u32, 64u32);
        let view = View::new(&Camera::look_at(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, 60.0), DVec3::ZERO, w, h, 0.01);
        let vp = view.view_proj().as_dmat4();
        // Occluders: a wall of random depth in front of the boxes, with gaps.
        let depth: Vec<f32> = noise(w, h, 3).iter().map(|d| if *d < 0.15 { 0.0 } else { 0.9 + 0.1 * d }).collect();
        let p = Pyramid::new(w, h, depth.clone());
        let (mut culled_whole, mut culled_parts, mut visible) = (0, 0, 0);
        let mut rng = 9u32;
        let mut unit = || {
            rng = rng.wrapping_mul(1664525).wrapping_add(1013904223);
            (rng >> 8) as f32 / (1 << 24) as f32
        };
        for _ in 0..500 {
            let c = glam::Vec3::new(8.0 * unit() - 4.0, 6.0 * unit() - 3.0, -6.0 * unit());
            let e = glam::Vec3::new(3.0 * unit(), 0.3 * unit(), 3.0 * unit()) + 0.05;
            let b = Aabb { min: c - e, max: c + e };
            let seen = (0..=16).flat_map(|i| (0..=16).flat_map(move |j| (0..=16).map(move |k| (i, j, k)))).any(|(i, j, k)| {
                let t = glam::Vec3::new(i as f32, j as f32, k as f32) / 16.0;
                let q = (b.min + (b.max - b.min) * t).as_dvec3() - view.eye;
                let clip = vp * q.extend(1.0);
                let (x, y) = ((clip.x / clip.w + 1.0) * 0.5 * w as f64, (1.0 - clip.y / clip.w) * 0.5 * h as f64);
                clip.w > 0.0
                    && (0.0..w as f64).contains(&x)
                    && (0.0..h as f64).contains(&y)
                    && clip.z / clip.w >= depth[(y as u32 * w + x as u32) as usize] as f64
            });
            let whole = visible_box(&p, &vp, &view, &b, 0, 0);
            let parts = visible_parts(&p, &vp, &view, &b, (3, 64), 4);
            assert!(!seen || parts, "box {b:?} has a visible point but its parts were hidden");
            assert!(!parts || whole, "a part passed where the whole box did not");
            (culled_whole, culled_parts, visible) =
                (culled_whole + u32::from(!whole), culled_parts + u32::from(!parts), visible + u32::from(seen));
        }
        assert!(visible > 50 && culled_parts > culled_whole, "{visible} visible; culled {culled_whole} whole, {culled_parts} in parts");
    }

    #[test]
    fn every_level_holds_the_farthest_of_its_block() {
        // Odd sizes both ways: each texel of level l is the minimum over the level-0 pixels of
        // its 2^l x 2^l block, clipped to the image, counted pixel by pixel.
        let (w, h) = (37u32, 23u32);
        let mut rng = 7u32;
        let depth: Vec<f32> = (0..w * h)
            .map(|_| {
                rng = rng.wrapping_mul(1664525).wrapping_add(1013904223);
                (rng >> 8) as f32 / (1 << 24) as f32
            })
            .collect();
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
