//! An image's mip chain as the scene file stores it. Level 0 is the image at the powers of two
//! at or above its sides (at most [`MAX_SIDE`]), so that every level halves both sides, down to
//! 1x1 (each side at least 1). Levels are filtered in linear light, colour weighted by alpha
//! (a cut-out's transparent texels, whatever colour they hold, do not bleed into its edges).
//!
//! A cut-out's alpha is scaled per level so that the share of texels at or above its cutoff
//! stays level 0's: averaging alone thins a fence's wires to nothing a few levels down
//! (Castaño, "Computing Alpha Mipmaps", 2010).

use crate::texture::{Image, srgb_to_linear_table, srgb8};

/// Largest level 0 stored, texels a side: the largest 2D texture wgpu's default limits allow.
pub const MAX_SIDE: u32 = 8192;

/// One level: `width` x `height` RGBA8 texels, sRGB colour, straight alpha, rows top first.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[u8; 4]>,
}

/// Level 0's size for an image of `width` x `height`.
pub fn base_size(width: u32, height: u32) -> (u32, u32) {
    (width.next_power_of_two().min(MAX_SIDE), height.next_power_of_two().min(MAX_SIDE))
}

/// Levels of a `width` x `height` level 0 (powers of two).
pub fn level_count(width: u32, height: u32) -> u32 {
    width.max(height).ilog2() + 1
}

/// Bytes of the whole chain of a `width` x `height` level 0.
pub fn chain_bytes(width: u32, height: u32) -> u64 {
    (0..level_count(width, height)).map(|k| (width >> k).max(1) as u64 * (height >> k).max(1) as u64 * 4).sum()
}

/// The chain of `image`; `cutoff`: the alpha of a cut-out's holes (see the module's notes).
pub fn chain(image: &Image, cutoff: Option<f32>) -> Vec<Level> {
    let (w, h) = base_size(image.width, image.height);
    let top = Linear::of(image);
    let top = if (w, h) == (image.width, image.height) { top } else { top.resampled(w, h) };
    let coverage = cutoff.map(|c| (c, top.coverage(c)));
    let mut levels = vec![top];
    while levels.last().is_some_and(|l| l.width > 1 || l.height > 1) {
        let mut next = levels.last().expect("a level").halved();
        if let Some((cutoff, want)) = coverage {
            next.keep_coverage(cutoff, want);
        }
        levels.push(next);
    }
    levels.iter().map(Linear::encoded).collect()
}

/// A level in linear light: RGB premultiplied by alpha.
struct Linear {
    width: u32,
    height: u32,
    texels: Vec<[f32; 4]>,
}

impl Linear {
    fn of(image: &Image) -> Linear {
        let lin = srgb_to_linear_table();
        let texels = image
            .texels
            .iter()
            .map(|t| {
                let a = t[3] as f32 / 255.0;
                [lin[t[0] as usize] * a, lin[t[1] as usize] * a, lin[t[2] as usize] * a, a]
            })
            .collect();
        Linear { width: image.width, height: image.height, texels }
    }

    fn at(&self, x: u32, y: u32) -> [f32; 4] {
        self.texels[(y * self.width + x) as usize]
    }

    /// Bilinear at texel centres, edges clamped: a side's power of two is at or above the
    /// image's, so this stretches it (or, past [`MAX_SIDE`], shrinks it).
    fn resampled(&self, width: u32, height: u32) -> Linear {
        let axis = |to: u32, from: u32, i: u32| {
            let s = ((i as f32 + 0.5) * from as f32 / to as f32 - 0.5).clamp(0.0, (from - 1) as f32);
            let lo = s.floor() as u32;
            (lo, (lo + 1).min(from - 1), s - lo as f32)
        };
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            let (y0, y1, fy) = axis(height, self.height, y);
            for x in 0..width {
                let (x0, x1, fx) = axis(width, self.width, x);
                let (a, b, c, d) = (self.at(x0, y0), self.at(x1, y0), self.at(x0, y1), self.at(x1, y1));
                texels.push(std::array::from_fn(|k| (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy));
            }
        }
        Linear { width, height, texels }
    }

    /// The next level: the mean of each 2x2 (2x1 or 1x2 where a side is 1 already).
    fn halved(&self) -> Linear {
        let (width, height) = ((self.width / 2).max(1), (self.height / 2).max(1));
        let (sx, sy) = (self.width / width, self.height / height);
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                let mut sum = [0f32; 4];
                for (dx, dy) in (0..sy).flat_map(|dy| (0..sx).map(move |dx| (dx, dy))) {
                    let t = self.at(x * sx + dx, y * sy + dy);
                    (0..4).for_each(|k| sum[k] += t[k]);
                }
                texels.push(sum.map(|v| v / (sx * sy) as f32));
            }
        }
        Linear { width, height, texels }
    }

    /// The share of texels whose alpha is at or above `cutoff`.
    fn coverage(&self, cutoff: f32) -> f32 {
        self.texels.iter().filter(|t| t[3] >= cutoff).count() as f32 / self.texels.len() as f32
    }

    /// Scales alpha (and the premultiplied colour with it) so that [`Linear::coverage`] comes
    /// closest to `want`: a bisection on the scale, coverage growing with it.
    fn keep_coverage(&mut self, cutoff: f32, want: f32) {
        let covered = |s: f32| self.texels.iter().filter(|t| (t[3] * s).min(1.0) >= cutoff).count() as f32 / self.texels.len() as f32;
        let (mut lo, mut hi) = (0.0f32, 4.0f32);
        for _ in 0..16 {
            let mid = 0.5 * (lo + hi);
            if covered(mid) < want { lo = mid } else { hi = mid }
        }
        let s = if (covered(lo) - want).abs() < (covered(hi) - want).abs() { lo } else { hi };
        for t in &mut self.texels {
            let a = (t[3] * s).min(1.0);
            let k = if t[3] > 0.0 { a / t[3] } else { 0.0 };
            *t = [t[0] * k, t[1] * k, t[2] * k, a];
        }
    }

    fn encoded(&self) -> Level {
        let texels = self
            .texels
            .iter()
            .map(|t| {
                let c = |v: f32| if t[3] > 0.0 { srgb8(v / t[3]) } else { 0 };
                [c(t[0]), c(t[1]), c(t[2]), (t[3].clamp(0.0, 1.0) * 255.0).round() as u8]
            })
            .collect();
        Level { width: self.width, height: self.height, texels }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: u32, height: u32, f: impl Fn(u32, u32) -> [u8; 4]) -> Image {
        let texels = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        Image { name: "test".into(), width, height, texels }
    }

    #[test]
    fn a_chain_halves_to_one_texel_in_linear_light() {
        // A checker of black and white: every coarser level is linear 0.5 grey, sRGB 188.
        let img = image(8, 4, |x, y| if (x + y) % 2 == 0 { [0, 0, 0, 255] } else { [255, 255, 255, 255] });
        let chain = chain(&img, None);
        let sizes: Vec<(u32, u32)> = chain.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(8, 4), (4, 2), (2, 1), (1, 1)]);
        assert_eq!(chain.iter().map(|l| l.texels.len() as u64 * 4).sum::<u64>(), chain_bytes(8, 4));
        assert_eq!(level_count(8, 4), 4);
        assert!(chain[1..].iter().all(|l| l.texels.iter().all(|t| *t == [188, 188, 188, 255])), "{:?}", chain[1]);
    }

    #[test]
    fn sides_grow_to_powers_of_two() {
        let img = image(3, 5, |x, _| [x as u8 * 100, 0, 0, 255]);
        let chain = chain(&img, None);
        assert_eq!((chain[0].width, chain[0].height), (4, 8));
        // Stretched, not tiled: the left column stays the image's left column.
        assert_eq!(chain[0].texels[0], [0, 0, 0, 255]);
        assert_eq!(chain[0].texels[3], [200, 0, 0, 255]);
    }

    #[test]
    fn transparent_texels_do_not_bleed_their_colour() {
        // Green where opaque, magenta where transparent: the mean is green, half covered.
        let img = image(2, 1, |x, _| if x == 0 { [0, 255, 0, 255] } else { [255, 0, 255, 0] });
        let chain = chain(&img, None);
        assert_eq!(chain[1].texels[0], [0, 255, 0, 128]);
    }

    #[test]
    fn a_cut_out_keeps_its_coverage_down_the_chain() {
        // Foliage: three texels in ten opaque, scattered. Averaged, alpha gathers around 0.3
        // and a few levels down nearly every texel is a hole at cutoff 0.5.
        let hash = |x: u32, y: u32| (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)).wrapping_mul(2_654_435_761) >> 22;
        let img = image(32, 32, |x, y| if hash(x, y) % 10 < 3 { [40, 120, 40, 255] } else { [0, 0, 0, 0] });
        let covered = |l: &Level| l.texels.iter().filter(|t| t[3] >= 128).count() as f32 / l.texels.len() as f32;
        let plain = chain(&img, None);
        let kept = chain(&img, Some(0.5));
        let want = covered(&kept[0]);
        assert!((0.2..0.4).contains(&want), "{want}");
        assert!(covered(&plain[2]) < want / 2.0, "plain level 2: {}", covered(&plain[2]));
        for l in &kept[..4] {
            assert!((covered(l) - want).abs() < 0.1, "level {}x{}: {} against {want}", l.width, l.height, covered(l));
        }
    }
}
