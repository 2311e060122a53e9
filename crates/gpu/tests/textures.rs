//! Textures sampled as a reference sampler on the CPU samples them: a quad facing the camera,
//! its texture repeated three times across it, drawn at a forced level L = 0..3 of the chain the
//! build stored, against bilinear filtering of that level written here from the glTF and Vulkan
//! definitions (texel centres at half-integers, wrap per axis, filtering in linear light); and
//! again with nearest filtering under mirrored and clamped wrapping. The quad's normal points at
//! the light, so that its shading is 1 and a pixel is the texel's colour alone.

use glam::{DVec3, Vec3};
use osw_gpu::draw::{Load, Pass};
use osw_gpu::renderer::{RenderOptions, Renderer};
use osw_scene::mesh::{Mesh, Object};
use osw_scene::source::InMemory;
use osw_scene::texture::{Filter, Image, Sampler, Texcoord, Texture, Textures, Wrap};
use osw_scene::{BuildOptions, Camera, SceneFile};
use std::path::Path;

const W: u32 = 256;
const H: u32 = 192;
const FOVY: f64 = 50.0;
const EYE: f64 = 4.0;
/// The quad's half sides: it covers most of the image.
const HALF: [f32; 2] = [2.0, 1.5];
/// The light of shaders/draw.wgsl.
const LIGHT: Vec3 = Vec3::new(0.4, 0.8, 0.3);

/// A 64x64 texture of smooth colour and sharp detail both.
fn image() -> Image {
    let texel = |x: u32, y: u32| {
        let h = (x.wrapping_mul(374_761_393) ^ y.wrapping_mul(668_265_263)).wrapping_mul(2_246_822_519) >> 24;
        [(x * 4) as u8, (y * 4) as u8, h as u8, 255]
    };
    Image { name: "test".into(), width: 64, height: 64, texels: (0..64).flat_map(|y| (0..64).map(move |x| texel(x, y))).collect() }
}

/// The quad at z = 0 facing the eye on +z, its texture coordinates `uv0` at the top left and
/// `uv1` at the bottom right, its normal at the light.
fn quad(uv0: [f32; 2], uv1: [f32; 2]) -> Mesh {
    let [a, b] = HALF;
    let corners = [[-a, b], [a, b], [a, -b], [-a, -b]];
    let uv = [uv0, [uv1[0], uv0[1]], uv1, [uv0[0], uv1[1]]];
    let n = osw_scene::normal::encode(LIGHT.normalize());
    Mesh {
        positions: corners.iter().map(|c| [c[0], c[1], 0.0]).collect(),
        indices: vec![0, 2, 1, 0, 3, 2],
        colors: vec![[255; 4]; 4],
        normals: vec![n; 4],
        texcoords: uv.iter().map(|&uv| Texcoord { uv, texture: 0 }).collect(),
        ..Mesh::default()
    }
}

fn build(dir: &Path, name: &str, mesh: Mesh, sampler: Sampler) -> SceneFile {
    let path = dir.join(format!("{name}.osw"));
    let textures = Textures { images: vec![image()], textures: vec![Texture { image: 0, sampler, cutoff: None }] };
    let mut source = InMemory::textured(vec![Object::new("quad", mesh)], textures);
    osw_scene::build(&mut source, name, Vec::new(), &BuildOptions::default(), &path, std::time::Instant::now(), &()).unwrap();
    SceneFile::open(&path).unwrap()
}

/// The frame with every texture at `level`, RGBA8 rows.
fn frame(scene: &SceneFile, level: f32) -> Vec<u8> {
    let gpu = osw_gpu::Gpu::new(None).expect("a Vulkan adapter (lavapipe: mesa-vulkan-drivers)");
    let options = RenderOptions { texture_level: Some(level), ..RenderOptions::default() };
    let mut r = Renderer::new(gpu, scene, W, H, options).unwrap();
    let view = r.view(&Camera::look_at(DVec3::new(0.0, 0.0, EYE), DVec3::ZERO, FOVY), 0.0);
    let lods: Vec<u32> = (0..scene.bvh_count()).map(|i| scene.node(i)).filter(|n| n.child_count == 0).map(|n| n.first_lod).collect();
    r.begin_frame();
    r.draw(scene, &view, &lods, Pass::Color, Load::Clear).unwrap();
    r.read_color().unwrap()
}

/// Where pixel (x, y)'s centre falls on the quad, in texture coordinates; None off the quad or
/// within a pixel of its edge.
fn uv_at(x: u32, y: u32, uv0: [f32; 2], uv1: [f32; 2]) -> Option<[f64; 2]> {
    let t = (FOVY.to_radians() / 2.0).tan() * EYE;
    let wx = ((x as f64 + 0.5) / W as f64 * 2.0 - 1.0) * t * W as f64 / H as f64;
    let wy = (1.0 - (y as f64 + 0.5) / H as f64 * 2.0) * t;
    let px = 2.0 * t / H as f64;
    let (a, b) = (HALF[0] as f64, HALF[1] as f64);
    if wx.abs() > a - px || wy.abs() > b - px {
        return None;
    }
    let (s, r) = ((wx + a) / (2.0 * a), (b - wy) / (2.0 * b));
    Some([uv0[0] as f64 + s * (uv1[0] - uv0[0]) as f64, uv0[1] as f64 + r * (uv1[1] - uv0[1]) as f64])
}

/// The reference sampler: level `texels` (`w` x `h`, RGBA8 sRGB) at `uv`, wrapped per axis and
/// filtered nearest or bilinear in linear light, as sRGB bytes.
fn reference(texels: &[u8], w: u32, h: u32, uv: [f64; 2], wrap: [Wrap; 2], filter: Filter) -> [f64; 3] {
    let fold = |i: i64, n: i64, mode: Wrap| match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let m = i.rem_euclid(2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
    };
    let at = |i: i64, j: i64| {
        let (x, y) = (fold(i, w as i64, wrap[0]), fold(j, h as i64, wrap[1]));
        let p = ((y * w as i64 + x) * 4) as usize;
        [0, 1, 2].map(|k| srgb_to_linear(texels[p + k] as f64 / 255.0))
    };
    let (u, v) = (uv[0] * w as f64, uv[1] * h as f64);
    let linear = match filter {
        Filter::Nearest => at(u.floor() as i64, v.floor() as i64),
        Filter::Linear => {
            let (u, v) = (u - 0.5, v - 0.5);
            let (i, j, fu, fv) = (u.floor() as i64, v.floor() as i64, u - u.floor(), v - v.floor());
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
            [0, 1, 2].map(|k| (a[k] * (1.0 - fu) + b[k] * fu) * (1.0 - fv) + (c[k] * (1.0 - fu) + d[k] * fu) * fv)
        }
    };
    linear.map(|c| linear_to_srgb(c) * 255.0)
}

fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

fn linear_to_srgb(c: f64) -> f64 {
    if c <= 0.0031308 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// The share of the quad's pixels within 2/255 of the reference at `level`, and their count.
fn agreement(scene: &SceneFile, level: u32, uv0: [f32; 2], uv1: [f32; 2], sampler: Sampler) -> (f64, usize) {
    let rgba = frame(scene, level as f32);
    let m = scene.images()[0];
    let (w, h, at) = m.level(level);
    let chain = scene.texels(0).unwrap();
    let texels = &chain[at as usize..(at + w as u64 * h as u64 * 4) as usize];
    let (mut close, mut all) = (0, 0);
    for y in 0..H {
        for x in 0..W {
            let Some(uv) = uv_at(x, y, uv0, uv1) else { continue };
            let want = reference(texels, w, h, uv, sampler.wrap, sampler.min);
            let p = ((y * W + x) * 4) as usize;
            all += 1;
            close += usize::from((0..3).all(|k| (rgba[p + k] as f64 - want[k]).abs() <= 2.0));
        }
    }
    (close as f64 / all as f64, all)
}

#[test]
fn a_quad_samples_each_level_as_the_reference_sampler_does() {
    let d = tempfile::tempdir().unwrap();
    let (uv0, uv1) = ([0.0, 0.0], [3.0, 3.0]);
    let sampler = Sampler::default();
    let scene = build(d.path(), "bilinear", quad(uv0, uv1), sampler);
    assert_eq!(scene.images()[0].levels, 7);
    for level in 0..4 {
        let (share, pixels) = agreement(&scene, level, uv0, uv1, sampler);
        eprintln!("bilinear level {level}: {:.3}% of {pixels} pixels within 2/255", share * 100.0);
        assert!(pixels > 20_000, "{pixels}");
        assert!(share >= 0.99, "level {level}: {:.2}% of {pixels} pixels within 2/255", share * 100.0);
    }
}

#[test]
fn nearest_texels_mirror_and_clamp_as_the_reference_sampler_does() {
    let d = tempfile::tempdir().unwrap();
    // Coordinates past both edges: mirrored across u, clamped along v.
    let (uv0, uv1) = ([-1.5, -0.5], [2.5, 1.5]);
    let sampler = Sampler { wrap: [Wrap::Mirror, Wrap::Clamp], mag: Filter::Nearest, min: Filter::Nearest, mip: Some(Filter::Nearest) };
    let scene = build(d.path(), "nearest", quad(uv0, uv1), sampler);
    for level in [0, 2] {
        let (share, pixels) = agreement(&scene, level, uv0, uv1, sampler);
        eprintln!("nearest level {level}: {:.3}% of {pixels} pixels within 2/255", share * 100.0);
        assert!(share >= 0.99, "level {level}: {:.2}% of {pixels} pixels within 2/255", share * 100.0);
    }
    // The same frame under the wrong wrap disagrees: the test can fail.
    let repeat = Sampler { wrap: [Wrap::Repeat; 2], ..sampler };
    let (share, _) = agreement(&scene, 0, uv0, uv1, repeat);
    assert!(share < 0.8, "{share}");
}
