//! The display's window (docs/window.md): a winit window on X11 with a wgpu surface on the renderer's
//! device. Frames are rendered offscreen as always (they are also written as PNGs), read back,
//! given the overlay and copied into the surface: on lavapipe every "GPU" copy is a CPU copy
//! anyway, and the window shows exactly the pixels a screenshot saves.
//!
//! The event loop is pumped by the frame loop (winit's pump_events), so the display keeps one
//! thread of control: between frames, and every few milliseconds while a frame is coming in.

use crate::controls::{Action, Key};
use anyhow::{Context, bail};
use osw_gpu::Gpu;
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::platform::pump_events::{EventLoopExtPumpEvents, PumpStatus};
use winit::window::WindowId;

/// What the person did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    Key(Key, bool),
    /// Mouse moved by (dx, dy) pixels with the left button held.
    Drag(f64, f64),
    /// The window lost the keyboard: every held key counts as released.
    ReleaseAll,
}

/// The keys, by position on the keyboard (the same on any layout).
fn key_for(code: KeyCode) -> Option<Key> {
    Some(match code {
        KeyCode::KeyW => Key::Forward,
        KeyCode::KeyS => Key::Back,
        KeyCode::KeyA => Key::Left,
        KeyCode::KeyD => Key::Right,
        KeyCode::KeyQ => Key::Down,
        KeyCode::KeyE => Key::Up,
        KeyCode::ArrowLeft => Key::TurnLeft,
        KeyCode::ArrowRight => Key::TurnRight,
        KeyCode::ArrowUp => Key::TurnUp,
        KeyCode::ArrowDown => Key::TurnDown,
        KeyCode::KeyX => Key::Faster,
        KeyCode::KeyZ => Key::Slower,
        KeyCode::BracketRight => Key::TauUp,
        KeyCode::BracketLeft => Key::TauDown,
        KeyCode::Tab => Key::Do(Action::Colours),
        KeyCode::KeyF => Key::Do(Action::Freeze),
        KeyCode::KeyR => Key::Do(Action::Record),
        KeyCode::KeyP => Key::Do(Action::Screenshot),
        KeyCode::KeyH => Key::Do(Action::Overlay),
        KeyCode::Escape => Key::Do(Action::Quit),
        _ => return None,
    })
}

/// The help lines of the overlay.
pub const KEYS: [&str; 2] =
    ["WASD QE move  drag/arrows look  Z X speed  [ ] tau", "Tab colours  F freeze  R record  P shot  H overlay  Esc quit"];

/// winit's side: makes the window once the loop runs, turns events into [`Input`]s.
struct App {
    attributes: winit::window::WindowAttributes,
    window: Option<Arc<winit::window::Window>>,
    error: Option<String>,
    inputs: Vec<Input>,
    closed: bool,
    left: bool,
    cursor: Option<(f64, f64)>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            match event_loop.create_window(self.attributes.clone()) {
                Ok(w) => self.window = Some(Arc::new(w)),
                Err(e) => self.error = Some(e.to_string()),
            }
        }
    }

    fn window_event(&mut self, _: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => self.closed = true,
            WindowEvent::KeyboardInput { event: KeyEvent { physical_key: PhysicalKey::Code(code), state, repeat: false, .. }, .. } => {
                if let Some(k) = key_for(code) {
                    self.inputs.push(Input::Key(k, state == ElementState::Pressed));
                }
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => self.left = state == ElementState::Pressed,
            WindowEvent::CursorMoved { position, .. } => {
                if let (true, Some((x, y))) = (self.left, self.cursor) {
                    self.inputs.push(Input::Drag(position.x - x, position.y - y));
                }
                self.cursor = Some((position.x, position.y));
            }
            WindowEvent::Focused(false) => {
                self.left = false;
                self.inputs.push(Input::ReleaseAll);
            }
            _ => {}
        }
    }
}

pub struct Window {
    event_loop: EventLoop<()>,
    app: App,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
}

impl Window {
    /// Opens a window of `width` x `height` pixels and the renderer's device on an instance
    /// that can draw into it.
    pub fn open(title: &str, width: u32, height: u32, adapter: Option<&str>) -> anyhow::Result<(Window, Gpu)> {
        let mut event_loop = EventLoop::new().map_err(|e| {
            anyhow::anyhow!(
                "cannot open a window: {e}. Is DISPLAY set? On a machine without a screen, run under Xvfb \
                 (apt-get install -y xvfb; xvfb-run -a -s '-screen 0 1280x1024x24' ...)"
            )
        })?;
        let gpu = Gpu::for_display(adapter, Box::new(event_loop.owned_display_handle()))?;
        let attributes = winit::window::Window::default_attributes()
            .with_title(title)
            .with_inner_size(PhysicalSize::new(width, height))
            .with_resizable(false);
        let mut app = App { attributes, window: None, error: None, inputs: Vec::new(), closed: false, left: false, cursor: None };
        let start = Instant::now();
        while app.window.is_none() {
            if let PumpStatus::Exit(code) = event_loop.pump_app_events(Some(Duration::from_millis(10)), &mut app) {
                bail!("the window system closed the event loop ({code}) before the window opened");
            }
            if let Some(e) = app.error.take() {
                bail!("cannot open a window: {e}");
            }
            if start.elapsed() > Duration::from_secs(10) {
                bail!("no window after 10 s: is the X server answering?");
            }
        }
        let window = Arc::clone(app.window.as_ref().expect("made above"));
        let surface = gpu.instance.create_surface(Arc::clone(&window)).context("making a surface for the window")?;
        let caps = surface.get_capabilities(&gpu.adapter);
        if !caps.usages.contains(wgpu::TextureUsages::COPY_DST) {
            bail!("{}: its surfaces cannot be copied into ({:?})", gpu.info.name, caps.usages);
        }
        // Unorm formats: the frame's bytes are shown as they are written to the PNGs.
        let format = [wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Bgra8Unorm]
            .into_iter()
            .find(|f| caps.formats.contains(f))
            .with_context(|| format!("{}: no 8-bit RGBA or BGRA surface format among {:?}", gpu.info.name, caps.formats))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::COPY_DST,
            format,
            color_space: Default::default(),
            width: size.width.max(1),
            height: size.height.max(1),
            // One frame queued at most: the latency the overlay shows includes it.
            desired_maximum_frame_latency: 1,
            // A walkthrough shows frames as they come: no waiting for a vertical blank.
            present_mode: wgpu::PresentMode::AutoNoVsync,
            alpha_mode: wgpu::CompositeAlphaMode::Auto,
            view_formats: vec![],
        };
        surface.configure(&gpu.device, &config);
        gpu.check()?;
        Ok((Window { event_loop, app, surface, config }, gpu))
    }

    /// Handles pending window events; returns what the person did since the last call.
    pub fn pump(&mut self) -> Vec<Input> {
        if let PumpStatus::Exit(_) = self.event_loop.pump_app_events(Some(Duration::ZERO), &mut self.app) {
            self.app.closed = true;
        }
        std::mem::take(&mut self.app.inputs)
    }

    /// The window was closed by the window system or the person.
    pub fn closed(&self) -> bool {
        self.app.closed
    }

    /// Shows `rgba` (tightly packed RGBA8 rows of `width` pixels, top row first).
    pub fn present(&mut self, gpu: &Gpu, rgba: &[u8], width: u32) -> anyhow::Result<()> {
        use wgpu::CurrentSurfaceTexture as C;
        let frame = match self.surface.get_current_texture() {
            C::Success(t) | C::Suboptimal(t) => t,
            C::Outdated | C::Lost => {
                self.surface.configure(&gpu.device, &self.config);
                return Ok(());
            }
            // Hidden, or not ready: this frame is not shown; the next one will be.
            _ => return Ok(()),
        };
        let bgra;
        let data = if self.config.format == wgpu::TextureFormat::Bgra8Unorm {
            bgra = rgba.chunks_exact(4).flat_map(|p| [p[2], p[1], p[0], p[3]]).collect::<Vec<u8>>();
            &bgra[..]
        } else {
            rgba
        };
        let height = (rgba.len() / 4 / width as usize) as u32;
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &frame.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            data,
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * width), rows_per_image: None },
            wgpu::Extent3d { width: width.min(self.config.width), height: height.min(self.config.height), depth_or_array_layers: 1 },
        );
        gpu.queue.submit([]);
        gpu.queue.present(frame);
        gpu.check()?;
        Ok(())
    }
}
