//! `lamina view SCENE`: the real-time GPU view in a window (winit 0.30).
//!
//! Controls: left-drag or A/D/W/S orbits the camera around the scene camera's target;
//! mouse wheel or +/- zooms; right-drag or the arrow keys move the sun (azimuth and
//! elevation, also below the horizon and across leaf planes: the shading blends smoothly
//! from front- to back-lit, so nothing pops); Space starts/stops the sun orbiting; L turns
//! level of detail (`--lod`) on and off; O turns occlusion culling on and off; R resets;
//! Esc or Q quits. The overlay shows the frame time per pass and whether level of detail
//! and occlusion culling are on.
//!
//! `--frames N --screenshot out.png` renders N frames, saves the last one (overlay
//! included) and exits: how tests and scripts use it (e.g. under `xvfb-run -a`).

use anyhow::{Context, Result, anyhow, bail};
use glam::Vec3;
use lamina_gpu::wgpu;
use lamina_gpu::{ContextOptions, FrameView, GpuContext, RenderSettings, Renderer};
use lamina_scene::{Camera, Film, Scene};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// `lamina view`.
#[derive(clap::Args, Debug)]
pub struct ViewArgs {
    /// A scene file (TOML), or a built-in: `demo:front`, `demo:back`, `demo:bush` (the demo's
    /// panels), `tree:N` (a generated tree of N leaves).
    pub scene: String,
    /// Window width in pixels.
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub width: u32,
    /// Window height in pixels.
    #[arg(long, default_value_t = 720, value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub height: u32,
    /// Exit after this many frames.
    #[arg(long)]
    pub frames: Option<u64>,
    /// On exit, save the last frame (tone-mapped, with the overlay) as PNG.
    #[arg(long, value_name = "PNG")]
    pub screenshot: Option<PathBuf>,
    /// Replace a --screenshot file lamina did not write.
    #[arg(long, requires = "screenshot")]
    pub force: bool,
    /// Orbit the sun around the plant at this many degrees per second from the start.
    #[arg(long, default_value_t = 0.0)]
    pub sun_speed: f32,
    /// Side of the sun's shadow and transmittance maps (texels).
    #[arg(long, default_value_t = 2048, value_parser = clap::value_parser!(u32).range(64..=16384))]
    pub shadow_map: u32,
    /// Level of detail for foliage: a plant whose leaves look smaller than this many
    /// pixels drops a random share of them and enlarges the rest, keeping its leaf area
    /// (stochastic simplification, no popping); 0 draws every leaf. The window's default
    /// (4) favours frame rate; `render --gpu` images default to 1.
    #[arg(long, value_name = "PIXELS", default_value_t = 4.0, allow_negative_numbers = true, value_parser = crate::gpu_cmd::parse_lod)]
    pub lod: f32,
}

/// Loads a scene file or makes a built-in one (see [`ViewArgs::scene`]).
pub fn load_view_scene(spec: &str, size: (u32, u32)) -> Result<Scene> {
    if let Some(which) = spec.strip_prefix("demo:") {
        let leaf = crate::demo::demo_leaf("beech", 1)?;
        let s = size.1;
        return Ok(match which {
            "front" => lamina_scene::builtin::leaf_front_lit(&leaf, (s, s), 1),
            "back" => lamina_scene::builtin::leaf_back_lit(&leaf, (s, s), 1),
            "bush" => lamina_scene::builtin::bush_scene(&leaf, (s, s), 1),
            _ => bail!(
                "unknown built-in scene 'demo:{which}' (use demo:front, demo:back or demo:bush)"
            ),
        });
    }
    if let Some(n) = spec.strip_prefix("tree:") {
        let n: u32 = n
            .parse()
            .map_err(|_| anyhow!("'tree:{n}': the leaf count must be a whole number"))?;
        return Ok(lamina_bench::frame_tree_scene(n, size)?);
    }
    let (scene, bands) = lamina_scene::load_scene_with_output(std::path::Path::new(spec))?;
    if bands.is_some() || scene.film.spectral == lamina_scene::SpectralMode::Visible {
        eprintln!(
            "note: '{spec}' asks for a spectral render ([film] bands or spectral = \"visible\"); \
             the real-time view is RGB (lamina render makes the spectral image)"
        );
    }
    Ok(scene)
}

/// Camera orbiting a target, `+y` up.
#[derive(Clone, Copy, Debug)]
struct Orbit {
    target: Vec3,
    dist: f32,
    yaw: f32,
    pitch: f32,
    fov_deg: f32,
}

impl Orbit {
    fn from_camera(c: &Camera) -> Self {
        let o = c.position - c.look_at;
        let dist = o.length().max(1e-3);
        Orbit {
            target: c.look_at,
            dist,
            yaw: o.x.atan2(o.z),
            pitch: (o.y / dist).clamp(-1.0, 1.0).asin(),
            fov_deg: c.fov_deg,
        }
    }

    fn camera(&self) -> Camera {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let position = self.target + self.dist * Vec3::new(cp * sy, sp, cp * cy);
        Camera {
            position,
            look_at: self.target,
            up: Vec3::Y,
            fov_deg: self.fov_deg,
            aperture_radius: 0.0,
            focus_distance: self.dist,
        }
    }
}

/// Sun position as azimuth and elevation (radians); `dir` points toward the sun.
#[derive(Clone, Copy, Debug)]
struct Sun {
    azimuth: f32,
    elevation: f32,
}

impl Sun {
    fn from_dir(d: Vec3) -> Self {
        let d = d.normalize_or(Vec3::Y);
        Sun {
            azimuth: d.x.atan2(d.z),
            elevation: d.y.clamp(-1.0, 1.0).asin(),
        }
    }

    fn dir(&self) -> Vec3 {
        let (sa, ca) = self.azimuth.sin_cos();
        let (se, ce) = self.elevation.sin_cos();
        Vec3::new(ce * sa, se, ce * ca)
    }
}

struct State {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// The sRGB format the frames are rendered through.
    view_format: wgpu::TextureFormat,
    renderer: Renderer,
    film: Film,
    home: (Orbit, Option<Sun>),
    orbit: Orbit,
    sun: Option<Sun>,
    sun_speed: f32,
    left: bool,
    right: bool,
    cursor: Option<(f64, f64)>,
    last: Instant,
    /// Wall-clock time between frames (ms), smoothed.
    frame_ms: f64,
    /// The latest GPU time per pass, where the adapter has timestamp queries.
    gpu: Option<lamina_gpu::renderer::PassTimes>,
    frames: u64,
    triangles: u64,
}

struct Viewer {
    args: ViewArgs,
    scene: Option<Scene>,
    state: Option<State>,
    error: Option<anyhow::Error>,
}

impl State {
    fn frame_view(&self) -> FrameView {
        FrameView {
            camera: self.orbit.camera(),
            sun_dir: self.sun.map(|s| s.dir()),
            width: self.config.width,
            height: self.config.height,
        }
    }

    fn overlay(&self) -> Vec<u8> {
        let sun = self.sun.map_or(String::new(), |s| {
            format!(
                "  SUN AZ {:.0} EL {:.0}",
                s.azimuth.to_degrees().rem_euclid(360.0),
                s.elevation.to_degrees()
            )
        });
        // GPU time per pass where the adapter has timestamp queries; wall-clock time
        // between frames otherwise, labelled so.
        let time = match self.gpu {
            Some(t) => format!(
                "GPU {:.1} MS ({}SHADOW {:.1} MAIN {:.1} POST {:.1})  {:.1} FPS",
                t.total_ms(),
                t.cull_ms.map_or(String::new(), |c| format!("CULL {c:.1} ")),
                t.shadows_ms,
                t.main_ms,
                t.post_ms.unwrap_or(0.0),
                1000.0 / self.frame_ms.max(1e-3)
            ),
            None => format!(
                "WALL {:.1} MS ({:.1} FPS)",
                self.frame_ms,
                1000.0 / self.frame_ms.max(1e-3)
            ),
        };
        let lod = match self.renderer.lod_pixels() {
            0.0 => "LOD OFF".to_string(),
            px => format!("LOD {px} PX"),
        };
        let occl = if self.renderer.occlusion_culling() {
            "OCCL ON"
        } else {
            "OCCL OFF"
        };
        let text = format!(
            "{time}{sun}  {:.2}M TRIS  {lod}  {occl}",
            self.triangles as f64 / 1e6
        );
        lamina_gpu::overlay::render_text(&text)
    }

    fn redraw(&mut self) -> Result<()> {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        if self.frames > 0 {
            // Smoothed over about ten frames.
            let ms = dt * 1000.0;
            self.frame_ms = if self.frames == 1 {
                ms
            } else {
                0.9 * self.frame_ms + 0.1 * ms
            };
        }
        if let Some(s) = &mut self.sun {
            s.azimuth += (self.sun_speed as f64).to_radians() as f32 * dt as f32;
        }
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface
                    .configure(&self.renderer.context().device, &self.config);
                return Ok(());
            }
            _ => return Ok(()),
        };
        let target = frame.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.view_format),
            ..Default::default()
        });
        let view = self.frame_view();
        let overlay = self.overlay();
        let ctx = self.renderer.context().clone();
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        self.renderer.encode_scene(&mut encoder, &view);
        self.renderer.encode_post(
            &mut encoder,
            &target,
            self.view_format,
            &self.film,
            Some(&overlay),
        )?;
        self.renderer.finish_frame(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        self.renderer.frame_submitted();
        if let Some(t) = self.renderer.gpu_times() {
            self.gpu = Some(t);
        }
        self.window.pre_present_notify();
        ctx.queue.present(frame);
        self.frames += 1;
        Ok(())
    }
}

impl Viewer {
    fn init(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let scene = self.scene.take().context("the scene was already used")?;
        let attrs = Window::default_attributes()
            .with_title(format!("lamina view: {}", self.args.scene))
            .with_inner_size(PhysicalSize::new(self.args.width, self.args.height));
        let window = Arc::new(el.create_window(attrs).context("opening the window")?);
        let instance = lamina_gpu::context::new_instance(None);
        let surface = instance
            .create_surface(window.clone())
            .context("creating the window's GPU surface")?;
        let ctx = GpuContext::with_instance(instance, Some(&surface), &ContextOptions::default())?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&ctx.adapter, size.width.max(1), size.height.max(1))
            .context("the GPU adapter cannot present to this window")?;
        let caps = surface.get_capabilities(&ctx.adapter);
        // The tone-map pass writes linear values into an sRGB view, whose store applies the
        // sRGB curve (as the PNG writer does).
        if let Some(f) = caps.formats.iter().find(|f| f.is_srgb()) {
            config.format = *f;
        }
        let view_format = config.format.add_srgb_suffix();
        if view_format != config.format {
            config.view_formats = vec![view_format];
        }
        config.present_mode = wgpu::PresentMode::AutoNoVsync;
        surface.configure(&ctx.device, &config);
        let renderer = Renderer::new(
            &ctx,
            &scene,
            RenderSettings {
                shadow_map_size: self.args.shadow_map,
                supersample: 1,
                lod_pixels: self.args.lod,
                ..Default::default()
            },
        )?;
        for w in renderer.warnings() {
            eprintln!("warning: {w}");
        }
        eprintln!(
            "lamina view: {} ({} triangles) on {}",
            self.args.scene,
            renderer.triangles(),
            ctx.adapter_name()
        );
        let (camera, film, sun) = renderer.scene_view();
        let orbit = Orbit::from_camera(&camera);
        let sun = sun.map(Sun::from_dir);
        let triangles = renderer.triangles();
        self.state = Some(State {
            window,
            surface,
            config,
            view_format,
            renderer,
            film,
            home: (orbit, sun),
            orbit,
            sun,
            sun_speed: self.args.sun_speed,
            left: false,
            right: false,
            cursor: None,
            last: Instant::now(),
            frame_ms: 0.0,
            gpu: None,
            frames: 0,
            triangles,
        });
        Ok(())
    }

    fn fail(&mut self, el: &ActiveEventLoop, e: anyhow::Error) {
        self.error = Some(e);
        el.exit();
    }

    fn finish(&mut self) -> Result<()> {
        let (Some(path), Some(s)) = (&self.args.screenshot, &mut self.state) else {
            return Ok(());
        };
        let view = s.frame_view();
        let overlay = s.overlay();
        let rgba = s
            .renderer
            .render_screenshot(&view, &s.film, Some(&overlay))?;
        let img =
            image::RgbaImage::from_raw(view.width, view.height, rgba).context("screenshot size")?;
        crate::output_file::claim(path, self.args.force, &[]).context("--screenshot")?;
        lamina_io::save_image(path, &img)
            .with_context(|| format!("writing the screenshot '{}'", path.display()))?;
        let gpu = s.gpu.map_or(String::new(), |t| {
            format!(
                "; GPU {:.2} ms: {}shadows {:.2}, main {:.2}, post {:.2}",
                t.total_ms(),
                t.cull_ms
                    .map_or(String::new(), |c| format!("culling and LOD {c:.2}, ")),
                t.shadows_ms,
                t.main_ms,
                t.post_ms.unwrap_or(0.0)
            )
        });
        eprintln!(
            "wrote {} after {} frames ({:.1} ms per frame, wall clock{gpu})",
            path.display(),
            s.frames,
            s.frame_ms
        );
        Ok(())
    }
}

impl ApplicationHandler for Viewer {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.state.is_none()
            && self.error.is_none()
            && let Err(e) = self.init(el)
        {
            self.fail(el, e);
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let max_frames = self.args.frames;
        let Some(s) = &mut self.state else {
            return;
        };
        let step = 5f32.to_radians();
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(size) if size.width > 0 && size.height > 0 => {
                s.config.width = size.width;
                s.config.height = size.height;
                s.surface.configure(&s.renderer.context().device, &s.config);
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = s.redraw() {
                    self.fail(el, e);
                    return;
                }
                if max_frames.is_some_and(|n| s.frames >= n) {
                    el.exit();
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => s.left = down,
                    MouseButton::Right => s.right = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let Some((x, y)) = s.cursor {
                    let (dx, dy) = ((position.x - x) as f32, (position.y - y) as f32);
                    if s.left {
                        s.orbit.yaw -= dx * 0.005;
                        s.orbit.pitch = (s.orbit.pitch + dy * 0.005).clamp(-1.5, 1.5);
                    }
                    if let (true, Some(sun)) = (s.right, &mut s.sun) {
                        sun.azimuth += dx * 0.005;
                        sun.elevation = (sun.elevation - dy * 0.005).clamp(-1.55, 1.55);
                    }
                }
                s.cursor = Some((position.x, position.y));
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let d = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                s.orbit.dist *= 0.9f32.powf(d);
            }
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                match event.logical_key.as_ref() {
                    Key::Named(NamedKey::Escape) | Key::Character("q") => el.exit(),
                    Key::Named(NamedKey::ArrowLeft) => {
                        s.sun.iter_mut().for_each(|x| x.azimuth -= step)
                    }
                    Key::Named(NamedKey::ArrowRight) => {
                        s.sun.iter_mut().for_each(|x| x.azimuth += step)
                    }
                    Key::Named(NamedKey::ArrowUp) => s
                        .sun
                        .iter_mut()
                        .for_each(|x| x.elevation = (x.elevation + step).min(1.55)),
                    Key::Named(NamedKey::ArrowDown) => s
                        .sun
                        .iter_mut()
                        .for_each(|x| x.elevation = (x.elevation - step).max(-1.55)),
                    Key::Named(NamedKey::Space) => {
                        s.sun_speed = if s.sun_speed == 0.0 { 30.0 } else { 0.0 }
                    }
                    Key::Character("a") => s.orbit.yaw -= step,
                    Key::Character("d") => s.orbit.yaw += step,
                    Key::Character("w") => s.orbit.pitch = (s.orbit.pitch + step).min(1.5),
                    Key::Character("s") => s.orbit.pitch = (s.orbit.pitch - step).max(-1.5),
                    Key::Character("+") | Key::Character("=") => s.orbit.dist *= 0.9,
                    Key::Character("-") => s.orbit.dist /= 0.9,
                    Key::Character("r") => (s.orbit, s.sun) = s.home,
                    Key::Character("l") => {
                        // Level of detail on (the --lod setting, or 1 px) and off.
                        let on = if self.args.lod > 0.0 {
                            self.args.lod
                        } else {
                            1.0
                        };
                        let next = if s.renderer.lod_pixels() > 0.0 {
                            0.0
                        } else {
                            on
                        };
                        s.renderer.set_lod_pixels(next);
                    }
                    Key::Character("o") => {
                        let on = s.renderer.occlusion_culling();
                        s.renderer.set_occlusion_culling(!on);
                    }
                    _ => {}
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, el: &ActiveEventLoop) {
        if lamina_io::interrupt::interrupted() {
            el.exit();
            return;
        }
        if let Some(s) = &self.state {
            s.window.request_redraw();
        }
    }
}

pub fn run(args: ViewArgs) -> Result<()> {
    if let Some(p) = &args.screenshot {
        lamina_io::image_out::format_for(p).context("--screenshot")?;
        crate::output_file::claim(p, args.force, &[]).context("--screenshot")?;
    }
    let scene = load_view_scene(&args.scene, (args.width, args.height))?;
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow!(
            "cannot open a window ({e}); is a display available? Without one, run it under \
             `xvfb-run -a lamina view ...`, or use `lamina render --gpu` for images"
        )
    })?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut viewer = Viewer {
        args,
        scene: Some(scene),
        state: None,
        error: None,
    };
    // With the window open, Ctrl-C closes it (at the next frame) instead of killing the
    // process mid-frame; a second Ctrl-C still quits at once.
    lamina_io::interrupt::set_mode(lamina_io::interrupt::Mode::Stop);
    event_loop
        .run_app(&mut viewer)
        .context("the window's event loop failed")?;
    if lamina_io::interrupt::interrupted() {
        return Err(
            crate::interrupted::Interrupted("window closed, no screenshot written".into()).into(),
        );
    }
    if let Some(e) = viewer.error.take() {
        return Err(e);
    }
    viewer.finish()
}
