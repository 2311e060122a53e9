//! The window's side of the display: what the person asks for (walking, colours by state, a
//! frozen culling camera, tau, recording the path, screenshots, the overlay) and what the
//! window shows of each frame.

use crate::controls::{Action, Controls};
use crate::overlay::Overlay;
use crate::window::{Input, KEYS, Window};
use osw_cull::View;
use osw_cull::states::classify;
use osw_gpu::Renderer;
use osw_gpu::draw::{Load, Pass};
use osw_render::results::DisplayFrame;
use osw_scene::{Camera, SceneFile};
use std::io::Write as _;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// Colours by state (the occlusion switch's colour plate): visible, occlusion-culled, frustum-culled.
const VISIBLE: [u8; 3] = [70, 200, 80];
const OCCLUDED: [u8; 3] = [220, 60, 50];
const OUTSIDE: [u8; 3] = [70, 110, 230];

struct Recording {
    from: u64,
    cameras: Vec<Camera>,
    taus: Vec<f64>,
}

pub struct Ui {
    pub window: Window,
    /// Some when the person walks (`--interactive`); in path playback the path moves.
    pub controls: Option<Controls>,
    overlay: Option<Overlay>,
    show_overlay: bool,
    state_colours: bool,
    /// The culling camera while frozen: the cluster culls for it, the window shows the walk.
    frozen: Option<Camera>,
    recording: Option<Recording>,
    recordings: u32,
    screenshot: bool,
    quit: bool,
    last_move: Instant,
    /// Frames a second, smoothed.
    fps: f64,
    out: PathBuf,
    /// The scene, for the views the window draws itself.
    scene: Arc<SceneFile>,
}

/// Says what the display did on stdout (`osw run` passes it on); a closed stdout is no error.
fn say(what: String) {
    let _ = writeln!(std::io::stdout(), "{what}");
}

impl Ui {
    pub fn new(window: Window, controls: Option<Controls>, height: u32, out: PathBuf, scene: Arc<SceneFile>) -> Ui {
        let overlay = Overlay::load(height).map_err(|e| tracing::warn!("no overlay: {e}")).ok();
        Ui {
            window,
            controls,
            overlay,
            show_overlay: true,
            state_colours: false,
            frozen: None,
            recording: None,
            recordings: 0,
            screenshot: false,
            quit: false,
            last_move: Instant::now(),
            fps: 0.0,
            out,
            scene,
        }
    }

    /// Takes in what the person did since the last call.
    pub fn pump(&mut self) {
        for input in self.window.pump() {
            let action = match (input, self.controls.as_mut()) {
                (Input::Key(k, down), Some(c)) => c.key(k, down),
                (Input::Key(crate::controls::Key::Do(a), true), None) => Some(a),
                (Input::Drag(dx, dy), Some(c)) => {
                    c.drag(dx, dy);
                    None
                }
                (Input::ReleaseAll, Some(c)) => {
                    c.release_all();
                    None
                }
                _ => None,
            };
            match action {
                Some(Action::Colours) => self.state_colours = !self.state_colours,
                Some(Action::Freeze) => {
                    self.frozen = match (self.frozen, &self.controls) {
                        (None, Some(c)) => Some(c.camera()),
                        _ => None,
                    }
                }
                Some(Action::Record) => self.record(),
                Some(Action::Screenshot) => self.screenshot = true,
                Some(Action::Overlay) => self.show_overlay = !self.show_overlay,
                Some(Action::Quit) => self.quit = true,
                None => {}
            }
        }
        self.quit |= self.window.closed();
    }

    /// The camera and tau to send for the next frame while walking, or `None` once the
    /// person quit (or in path playback, where the path has the cameras).
    pub fn next_camera(&mut self) -> Option<(Camera, f64)> {
        self.pump();
        let c = self.controls.as_mut().filter(|_| !self.quit)?;
        c.advance(self.last_move.elapsed().as_secs_f64());
        self.last_move = Instant::now();
        Some((self.frozen.unwrap_or_else(|| c.camera()), c.tau))
    }

    /// Path playback: the person closed the window or pressed Escape.
    pub fn quit(&self) -> bool {
        self.quit
    }

    fn record(&mut self) {
        match self.recording.take() {
            None => self.recording = Some(Recording { from: u64::MAX, cameras: Vec::new(), taus: Vec::new() }),
            Some(r) => self.save(r),
        }
    }

    fn save(&mut self, r: Recording) {
        if r.cameras.is_empty() {
            return;
        }
        let path = self.out.join("paths").join(format!("recorded-{:03}.csv", self.recordings));
        self.recordings += 1;
        let written = std::fs::create_dir_all(self.out.join("paths")).map_err(|e| e.to_string());
        match written.and_then(|_| osw_scene::path::write(&path, &r.cameras).map_err(|e| e.to_string())) {
            Ok(()) => say(format!("recorded {} frames {}..={}", path.display(), r.from, r.from + r.cameras.len() as u64 - 1)),
            Err(e) => tracing::error!("recording not saved: {e}"),
        }
        if r.taus.iter().any(|&t| t != r.taus[0]) {
            tracing::warn!("tau changed while recording: the path keeps cameras only; it replays at one tau");
        }
    }

    /// Stops a recording still running (the walk is over).
    pub fn finish(&mut self) {
        if let Some(r) = self.recording.take() {
            self.save(r);
        }
    }

    /// The camera the window looks through: the walker's while the culling camera is frozen.
    fn viewer(&self, camera: &Camera) -> Camera {
        match (self.frozen, &self.controls) {
            (Some(_), Some(c)) => c.camera(),
            _ => *camera,
        }
    }

    /// Whether the window draws frame `camera` again (colours by state, or a frozen culling
    /// camera) rather than show the frame as RVG drew it.
    pub fn redraws(&self, camera: &Camera) -> bool {
        self.state_colours || self.viewer(camera) != *camera
    }

    /// Renders what the window shows of frame `row.frame`, sent with `camera` at `tau` and
    /// already drawn into the renderer's colour target as the frame is written (`frame`: its
    /// pixels if the caller read them back). Drawn again when the window's view differs:
    /// colours by state, or a frozen culling camera.
    pub fn show(
        &mut self,
        r: &mut Renderer,
        frame: Option<Vec<u8>>,
        visible: &[u32],
        camera: &Camera,
        tau: f64,
        row: &DisplayFrame,
    ) -> anyhow::Result<()> {
        if let Some(rec) = self.recording.as_mut() {
            rec.from = rec.from.min(row.frame);
            rec.cameras.push(*camera);
            rec.taus.push(tau);
        }
        let (viewer, redraw) = (self.viewer(camera), self.redraws(camera));
        if self.state_colours {
            // The culling camera's cut, seen from the viewer.
            let culling = r.view(camera, tau);
            let view = View { lod: culling.lod, ..r.view(&viewer, tau) };
            let scene = &self.scene;
            let mut front = Vec::new();
            osw_cull::frustum_cull(scene.nodes(), &view, tau, &mut front);
            let s = classify(scene.nodes(), &front, visible, &culling.frustum);
            r.draw(scene, &view, &s.visible, Pass::Tinted(VISIBLE), Load::Clear)?;
            r.draw(scene, &view, &s.occlusion_culled, Pass::Tinted(OCCLUDED), Load::Keep)?;
            r.draw(scene, &view, &s.frustum_culled, Pass::Tinted(OUTSIDE), Load::Keep)?;
        } else if viewer != *camera {
            let view = View { lod: r.view(camera, tau).lod, ..r.view(&viewer, tau) };
            r.draw(&self.scene, &view, visible, Pass::Color, Load::Clear)?;
        }
        // The frame as RVG drew it, read back once by the caller, unless it was drawn again.
        let mut rgba = match frame {
            Some(f) if !redraw => f,
            _ => r.read_color()?,
        };
        let width = r.width();
        if row.frame_ms > 0.0 {
            let now = 1e3 / row.frame_ms;
            self.fps = if self.fps == 0.0 { now } else { 0.9 * self.fps + 0.1 * now };
        }
        if let (true, Some(o)) = (self.show_overlay, &self.overlay) {
            o.draw(&mut rgba, width, &self.lines(row, tau));
        }
        self.window.present(r.gpu(), &rgba, width)?;
        if std::mem::take(&mut self.screenshot) {
            let path = self.out.join("screenshots").join(format!("{:05}.png", row.frame));
            std::fs::create_dir_all(self.out.join("screenshots"))?;
            osw_render::output::write_png(&path, width, r.height(), &rgba)?;
            say(format!("screenshot {}", path.display()));
        }
        Ok(())
    }

    /// The overlay's text.
    fn lines(&self, row: &DisplayFrame, tau: f64) -> Vec<String> {
        let node = crate::links::NAMES.get(row.hc_node as usize).unwrap_or(&"?");
        let mut l = vec![
            format!(
                "frame {}  {:.1} fps  latency {:.0} ms, {:.2} frames",
                row.frame,
                self.fps,
                row.latency_ms,
                row.latency_ms * self.fps / 1e3
            ),
            format!("HC node {node}{}", if row.degraded == 1 { "  DEGRADED: one node runs both roles" } else { "" }),
            format!("PVS {} nodes  {} triangles  {} B/frame  tau {tau} px", row.pvs_nodes, row.triangles_drawn, row.bytes),
            format!(
                "HC {:.1} ms (traversal {:.1}, second look {:.1}, retest {:.1}{})  RVG {:.1} ms",
                row.hc_ms,
                row.hc_traversal_ms,
                row.hc_second_look_ms,
                row.hc_retest_ms,
                if row.cull_skipped == 1 { ", culling skipped" } else { "" },
                row.rvg_ms
            ),
        ];
        let mut state =
            vec![if self.state_colours { "colours: green visible, red occluded, blue outside" } else { "colours: by object" }.to_string()];
        if let Some(c) = &self.controls {
            state.push(format!("speed {:.3}/s", c.speed));
        }
        if self.frozen.is_some() {
            state.push("culling camera FROZEN".into());
        }
        if let Some(r) = &self.recording {
            state.push(format!("REC {}", r.cameras.len()));
        }
        l.push(state.join("  "));
        l.extend(KEYS.map(String::from));
        l
    }
}
