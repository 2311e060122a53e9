//! The statistics overlay: lines of text drawn over a frame's pixels on the CPU (the frame is
//! read back for the window anyway), white on a darkened panel in the top-left corner.

use ab_glyph::{Font, FontVec, PxScale, ScaleFont, point};

/// DejaVu Sans Mono comes with Debian's fonts-dejavu-core (scripts/setup.sh installs it).
const FONTS: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf",
    "/usr/share/fonts/dejavu/DejaVuSansMono.ttf",
    "/usr/share/fonts/TTF/DejaVuSansMono.ttf",
];

pub struct Overlay {
    font: FontVec,
    scale: PxScale,
}

impl Overlay {
    /// Text about 1/50 of the image height, at least 11 pixels.
    pub fn load(height: u32) -> Result<Overlay, String> {
        let path = FONTS
            .iter()
            .find(|p| std::path::Path::new(p).exists())
            .ok_or("no DejaVuSansMono.ttf found for the overlay: apt-get install fonts-dejavu-core")?;
        let bytes = std::fs::read(path).map_err(|e| format!("{path}: {e}"))?;
        let font = FontVec::try_from_vec(bytes).map_err(|_| format!("{path}: not a font"))?;
        Ok(Overlay { font, scale: PxScale::from((height as f32 / 50.0).max(11.0)) })
    }

    /// Draws `lines` over `rgba` (tightly packed RGBA8 rows of `width` pixels).
    pub fn draw(&self, rgba: &mut [u8], width: u32, lines: &[String]) {
        let f = self.font.as_scaled(self.scale);
        let (line_h, pad) = (f.height() + f.line_gap(), (f.height() * 0.4).ceil());
        let text_w = |l: &str| l.chars().map(|c| f.h_advance(f.glyph_id(c))).sum::<f32>();
        let panel_w = lines.iter().map(|l| text_w(l)).fold(0.0, f32::max) + 2.0 * pad;
        let panel_h = line_h * lines.len() as f32 + 2.0 * pad;
        let height = (rgba.len() / 4 / width as usize) as u32;
        let (pw, ph) = ((panel_w as u32).min(width), (panel_h as u32).min(height));
        for y in 0..ph {
            for x in 0..pw {
                let i = 4 * (y * width + x) as usize;
                for c in &mut rgba[i..i + 3] {
                    *c = (*c as u32 * 3 / 10) as u8;
                }
            }
        }
        for (k, line) in lines.iter().enumerate() {
            let mut x = pad;
            let baseline = pad + f.ascent() + k as f32 * line_h;
            for c in line.chars() {
                let id = f.glyph_id(c);
                if let Some(g) = self.font.outline_glyph(id.with_scale_and_position(self.scale, point(x, baseline))) {
                    let b = g.px_bounds();
                    g.draw(|gx, gy, cover| {
                        let (px, py) = (b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64);
                        if px >= 0 && py >= 0 && (px as u32) < pw && (py as u32) < ph {
                            let i = 4 * (py as usize * width as usize + px as usize);
                            for c in &mut rgba[i..i + 3] {
                                *c = (*c as f32 + (255.0 - *c as f32) * cover.clamp(0.0, 1.0)) as u8;
                            }
                        }
                    });
                }
                x += f.h_advance(id);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_lights_pixels_inside_the_panel_only() {
        let Ok(o) = Overlay::load(200) else {
            panic!("the overlay font is missing: apt-get install fonts-dejavu-core");
        };
        let (w, h) = (200u32, 100u32);
        let mut px = vec![128u8; (w * h * 4) as usize];
        o.draw(&mut px, w, &["PVS 12".to_string()]);
        let at = |x: u32, y: u32| px[4 * (y * w + x) as usize];
        let bright = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).filter(|&(x, y)| at(x, y) > 200).count();
        assert!(bright > 20, "glyphs drawn: {bright} bright pixels");
        assert_eq!(at(w - 1, h - 1), 128, "outside the panel untouched");
        assert!(at(1, 1) < 128, "panel darkened");
    }
}
