//! The renderer: uploads a [`Scene`] once, then draws frames. Per frame, a compute pass and
//! three render passes (plus the optional tone-map pass for windows and screenshots):
//!
//! 0. **Culling and level of detail** (`culling.rs`, `lod.rs`): each instance's share of
//!    leaves kept, the camera's frustum-culled draw list and the light views' full one,
//!    and the indirect draws of every mesh.
//! 1. **Light view, layer 1** (`fs_shadow_first`): the sun's orthographic view of every
//!    alpha-tested surface: depth `d1` of the nearest and its diffuse transmittance `c1`.
//! 2. **Light view, layer 2** (`fs_shadow_peel`): depth peeling: the nearest surface behind
//!    layer 1, `d2` and `c2`. Together a two-layer translucent shadow map: sunlight reaches
//!    a point unattenuated, through one leaf (`c1`), or through two (`c1 c2`), each leaf's
//!    share scaled by the form factor `a² / (a² + d²)` of its card (radius `a`) seen from
//!    `d` behind it, since a leaf passes light on diffusely.
//! 3. **Camera** (`fs_main`): every mesh and instance in view with the alpha test, shaded
//!    with the baked leaf model ([`crate::bake`]), the sun through the transmittance map,
//!    the other lights through their maps baked at load, and the SH sky ([`crate::sky`])
//!    scaled by the sky visibility baked at load. Output: linear radiance in an RGBA16F target.
//!    With occlusion culling (frame sequences, [`RenderSettings::occlusion_culling`]) the
//!    pass comes in two parts: the instances the last frame saw; then, after a max-depth
//!    pyramid of that depth (`hiz.rs`) and a second culling dispatch against it, the
//!    instances in view it does not hide that were not drawn yet.
//!
//! Quad lights are shaded by their exact irradiance (one-sided unless `two_sided`), sphere
//! lights as point lights (exact outside them), see [`lights`]. The first
//! [`MAX_SHADOWED_LIGHTS`] lights besides the first sun are shadowed through two-layer
//! translucent maps baked at load (`local_shadows.rs`): a tiled orthographic map for a
//! further sun, a cube for a point, sphere or quad light (hard shadows for point lights,
//! soft ones for spheres and quads). Lights past those cast no shadows; they are named in
//! [`Renderer::warnings`], as are the lights past the first sun and 32 others, which are
//! left out. Determinism: the same scene and view give the same image on
//! the same device and driver (the soft-shadow taps rotate with the pixel, not at random;
//! the draw lists keep instance order within each LOD bucket).
//!
//! The rooms, in the order [`Renderer::new`] fills them:
//! * `materials`: baked materials uploaded as group 1 of every pass;
//! * `geometry`: vertex, index and instance buffers; the draw calls; with `lod` (leaves in
//!   rank order at load) and `culling` (the per-frame compute pass and its draw lists);
//! * `pipelines`: the scene shader's five pipelines and their group-0 layouts;
//! * `sun`: the sun's two-layer maps, redrawn every frame;
//! * `sky_visibility`: the sky's two-layer maps per direction, baked once;
//! * `local_shadows`: the two-layer maps of the lights besides the first sun, baked once;
//! * `camera`: the globals buffer, the camera pass and its HDR/depth targets, with `hiz`
//!   (the depth pyramid for occlusion culling, made with the targets);
//! * `post`: tone map and overlay;
//! * `lights`: scene lights and sky as the per-frame uniforms, and the light warnings;
//! * `timing`: GPU time per pass (timestamp queries);
//! * `bounds`, `projection`: bounding spheres and matrices; `layout`: formats and binding
//!   shorthand; `readback`, `half`: reading frames back.

mod bounds;
mod camera;
mod culling;
mod geometry;
mod half;
mod hiz;
mod layout;
mod lights;
mod local_shadows;
mod lod;
mod materials;
mod pipelines;
mod post;
mod projection;
mod readback;
mod sky_visibility;
mod sun;
mod timing;

pub use lights::MAX_SHADOWED_LIGHTS;
pub use post::OVERLAY_SIZE;
pub use projection::{camera_matrix, sphere_directions};
pub use sky_visibility::MAX_SKY_DIRS;
pub use timing::PassTimes;

use crate::context::GpuContext;
use crate::error::GpuError;
use bounds::SceneBounds;
use camera::CameraPass;
use culling::{CullView, Phase};
use geometry::DrawList;
use geometry::Geometry;
use glam::Vec3;
use hiz::HiZPipelines;
use lamina_image::Image;
use lamina_scene::{Camera, Film, Light, Scene};
use lights::{Globals, Lighting};
use local_shadows::LocalShadows;
use materials::Materials;
use pipelines::ScenePipelines;
use post::PostProcess;
use sky_visibility::SkyVisibility;
use sun::SunShadow;
use timing::{Pass, Timer};

/// The scene shader (light-view and camera passes), without the level-of-detail
/// functions it uses ([`scene_wgsl`] is the whole source).
pub const SCENE_WGSL: &str = include_str!("../shaders/scene.wgsl");

/// The scene shader as compiled: `lod.wgsl` with its constants, then [`SCENE_WGSL`].
pub fn scene_wgsl() -> String {
    format!("{}\n{SCENE_WGSL}", lod::wgsl_prelude())
}

/// The culling shader as compiled: `lod.wgsl` with its constants, then `cull.wgsl`.
pub fn cull_wgsl() -> String {
    format!("{}\n{}", lod::wgsl_prelude(), culling::CULL_WGSL)
}
/// The tone-map and overlay shader.
pub const POST_WGSL: &str = include_str!("../shaders/post.wgsl");

/// Quality settings.
#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    /// Side of the sun's shadow and transmittance maps, in texels.
    pub shadow_map_size: u32,
    /// Supersampling factor per axis for [`Renderer::render_image`] (box-filtered down).
    pub supersample: u32,
    /// Directions (0-16) of the sky-visibility maps baked at load time: how much of the
    /// sky each surface sees, and through how many leaves. 0 leaves sky light unshadowed.
    pub sky_directions: u32,
    /// Side of each sky-visibility map, in texels.
    pub sky_map_size: u32,
    /// Level of detail for foliage (`renderer/lod.rs`): the projected area of one leaf, in pixels
    /// of the image (before supersampling), below which a plant's leaves thin out (the
    /// survivors grow so that its leaf area is kept). 0 draws every leaf.
    pub lod_pixels: f32,
    /// Side, in texels, of the shadow maps baked at load for the lights besides the first
    /// sun: each cube face of a point, sphere or quad light (36 MiB per light at 512: six
    /// faces, two layers of depth and transmittance), each tile of a further sun's map (as
    /// many tiles as make it as sharp as the first sun's, at most 4x4: 96 MiB at 512 and a
    /// 2048 sun). 0 turns their shadows off (each such light is then named in a warning).
    pub local_shadow_size: u32,
    /// Two-phase occlusion culling of instances in frame sequences ([`Renderer::encode_scene`]:
    /// the viewer, benchmarks): what the last frame found hidden behind nearer surfaces is
    /// not drawn unless this frame's depth shows it. Single images
    /// ([`Renderer::render_image`]) draw every instance in view either way.
    pub occlusion_culling: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            shadow_map_size: 2048,
            supersample: 2,
            sky_directions: 16,
            sky_map_size: 512,
            lod_pixels: 1.0,
            local_shadow_size: 512,
            occlusion_culling: true,
        }
    }
}

/// What changes from frame to frame: the camera, the sun and the image size.
#[derive(Clone, Copy, Debug)]
pub struct FrameView {
    /// The camera (horizontal field of view, as in the scene file).
    pub camera: Camera,
    /// Direction toward the shadowed sun; `None` keeps the scene's first sun.
    pub sun_dir: Option<Vec3>,
    /// Target width in pixels.
    pub width: u32,
    /// Target height in pixels.
    pub height: u32,
}

/// A scene on the GPU, ready to draw frames.
pub struct Renderer {
    ctx: GpuContext,
    settings: RenderSettings,
    materials: Materials,
    geometry: Geometry,
    pipelines: ScenePipelines,
    sun: SunShadow,
    sky_visibility: SkyVisibility,
    local_shadows: LocalShadows,
    camera: CameraPass,
    /// The depth pyramid's pipelines, where the device culls.
    hiz_pipelines: Option<HiZPipelines>,
    post: PostProcess,
    lighting: Lighting,
    bounds: SceneBounds,
    /// The scene's own camera and film (what [`Renderer::render_image`] renders).
    scene_camera: Camera,
    scene_film: Film,
    warnings: Vec<String>,
    /// GPU time per pass, where the device has timestamp queries.
    timer: Option<Timer>,
    /// The offscreen tone-map target of [`Renderer::render_and_wait`] (size, view).
    post_target: Option<((u32, u32), wgpu::TextureView)>,
}

impl Renderer {
    /// Uploads `scene` (bakes its materials, see [`crate::bake`]), builds the pipelines
    /// and bakes the sky-visibility maps.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        settings: RenderSettings,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let scene_module = ctx.compile_wgsl("scene.wgsl", &scene_wgsl())?;
        let post_module = ctx.compile_wgsl("post.wgsl", POST_WGSL)?;
        let (materials, warnings) = Materials::upload(ctx, scene)?;
        let geometry = Geometry::upload(ctx, scene)?;
        let pipelines =
            ScenePipelines::new(ctx, &scene_module, &materials.layout, &geometry.layout)?;
        let globals = camera::globals_buffer(device);
        let shadow_size = settings.shadow_map_size.clamp(16, ctx.max_texture_dim);
        let sun = SunShadow::new(device, shadow_size, &pipelines, &globals);
        let sky_visibility = SkyVisibility::new(
            device,
            settings.sky_map_size.clamp(16, ctx.max_texture_dim),
            settings.sky_directions.clamp(1, MAX_SKY_DIRS as u32),
        );
        let map_size = settings.local_shadow_size.min(ctx.max_texture_dim);
        let shadowed = if map_size == 0 {
            0
        } else {
            MAX_SHADOWED_LIGHTS
        };
        let max_layers = ctx.device.limits().max_texture_array_layers;
        // Further suns' maps as sharp as the first sun's: tiles of the local maps' size.
        let sun_tiles = shadow_size.div_ceil(map_size.max(1)).clamp(1, 4);
        let lighting = Lighting::of(scene, shadowed, max_layers, sun_tiles);
        let local_shadows = LocalShadows::new(device, map_size, lighting.shadow_layers());
        let camera = CameraPass::new(
            device,
            &pipelines,
            globals,
            (&sun, &sky_visibility, &local_shadows),
        );
        let mut warnings = warnings;
        warnings.extend(lighting.warnings.iter().cloned());
        if geometry.culling.is_none() && geometry.lod_elements > 0 {
            warnings.push(format!(
                "this GPU ({}) has no indirect draws with a first instance: every leaf is \
                 drawn, without level of detail or culling",
                ctx.adapter_name()
            ));
        }
        let hiz_pipelines = match geometry.culling {
            Some(_) => Some(HiZPipelines::new(ctx)?),
            None => None,
        };
        let renderer = Renderer {
            ctx: ctx.clone(),
            settings,
            materials,
            geometry,
            pipelines,
            sun,
            sky_visibility,
            local_shadows,
            camera,
            hiz_pipelines,
            post: PostProcess::new(device, post_module),
            lighting,
            bounds: SceneBounds::of(scene),
            scene_camera: scene.camera,
            scene_film: scene.film,
            warnings,
            timer: Timer::new(device, &ctx.queue),
            post_target: None,
        };
        renderer.bake_sky_visibility()?;
        renderer.bake_local_shadows()?;
        Ok(renderer)
    }

    /// Renders the shadow maps of the lights besides the first sun (once: lights and
    /// geometry are static).
    fn bake_local_shadows(&self) -> Result<(), GpuError> {
        let maps = self.lighting.shadow_maps();
        if maps.is_empty() {
            return Ok(());
        }
        let base = self.globals(&FrameView {
            camera: self.scene_camera,
            sun_dir: None,
            width: 1,
            height: 1,
        });
        self.local_shadows.bake(
            &self.ctx,
            &maps,
            &self.bounds,
            base,
            self.settings.lod_pixels,
            (&self.pipelines, &self.geometry, &self.materials.groups),
        )
    }

    /// GPU memory of the shadow maps baked at load (lights besides the first sun), bytes.
    pub fn local_shadow_bytes(&self) -> u64 {
        self.local_shadows.bytes()
    }

    /// Renders the sky-visibility maps (once: geometry and sky are static) for
    /// [`RenderSettings::sky_directions`] directions.
    fn bake_sky_visibility(&self) -> Result<(), GpuError> {
        // Every instance (the maps serve every later view), leaves thinned out at the maps'
        // own resolution (they are orthographic views of the whole scene).
        if let Some(c) = &self.geometry.culling {
            let (_, r) = self.bounds.casters;
            let texels = self.sky_visibility.map_size() as f32;
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            c.encode(
                &self.ctx.queue,
                &mut encoder,
                &CullView {
                    view_proj: glam::Mat4::IDENTITY,
                    position: Vec3::ZERO,
                    focal_px: 1.0,
                    lod_pixels: self.settings.lod_pixels,
                    frustum: false,
                    ortho_px_per_m: Some(texels / (2.0 * r.max(1e-6))),
                    phase: Phase::All,
                },
                None,
                None,
            );
            self.ctx.queue.submit([encoder.finish()]);
        }
        let base = self.globals(&FrameView {
            camera: self.scene_camera,
            sun_dir: None,
            width: 1,
            height: 1,
        });
        self.sky_visibility.bake(
            &self.ctx,
            self.settings.sky_directions as usize,
            self.bounds.casters,
            base,
            (&self.pipelines, &self.geometry, &self.materials.groups),
        )
    }

    /// Messages about what the GPU path does differently from the offline renderer
    /// (downscaled maps, lights without shadows or left out), each naming the map or light;
    /// empty when all went as asked.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Triangles drawn per camera pass (instances counted).
    pub fn triangles(&self) -> u64 {
        self.geometry.triangles
    }

    /// Leaves (instances counted) that level of detail may thin out.
    pub fn lod_leaves(&self) -> u64 {
        self.geometry.lod_elements
    }

    /// Triangles the last frame drew in the camera pass and in each light-view pass after
    /// culling and level of detail (read back, waiting for the GPU: for tests and
    /// benchmarks); `None` where the device draws everything ([`Renderer::triangles`]).
    pub fn drawn_triangles(&self) -> Result<Option<[u64; 2]>, GpuError> {
        match &self.geometry.culling {
            Some(c) => c.drawn_triangles(&self.ctx).map(Some),
            None => Ok(None),
        }
    }

    /// GPU memory of the scene's geometry (vertex, index and instance buffers), bytes.
    pub fn geometry_bytes(&self) -> u64 {
        self.geometry.bytes()
    }

    /// Scene bounding sphere (centre, radius in m).
    pub fn bounds(&self) -> (Vec3, f32) {
        self.bounds.all
    }

    /// The scene's camera, film and first sun direction (toward the sun), for viewers.
    pub fn scene_view(&self) -> (Camera, Film, Option<Vec3>) {
        let sun = self.lighting.lights.iter().find_map(|l| match l {
            Light::Sun { direction, .. } => Some(*direction),
            _ => None,
        });
        (self.scene_camera, self.scene_film, sun)
    }

    /// The GPU context.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    fn globals(&self, view: &FrameView) -> Globals {
        self.lighting
            .globals(view, &self.bounds, self.sun.size, self.local_shadows.size)
    }

    /// Records a frame's scene passes for `view` into `encoder`, rendering into the
    /// internal HDR target (resized to the view). One of a sequence of frames: with
    /// [`RenderSettings::occlusion_culling`] it skips what the last frame found hidden
    /// (and draws, in the same frame, whatever this frame's depth does not hide).
    pub fn encode_scene(&mut self, encoder: &mut wgpu::CommandEncoder, view: &FrameView) {
        let occlusion = self.settings.occlusion_culling;
        self.encode_scene_lod(encoder, view, self.settings.lod_pixels, occlusion);
    }

    /// [`Renderer::encode_scene`] with leaves thinned out below `lod_pixels` pixels of
    /// `view`'s target, with two-phase occlusion culling when `occlusion` (and the device
    /// culls at all).
    fn encode_scene_lod(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        view: &FrameView,
        lod_pixels: f32,
        occlusion: bool,
    ) {
        let hiz = self
            .hiz_pipelines
            .as_ref()
            .zip(self.geometry.culling.as_ref().map(|c| &c.hiz_layout));
        self.camera
            .ensure_targets(&self.ctx.device, view.width, view.height, hiz);
        let occlusion = occlusion && hiz.is_some();
        let globals = self.globals(view);
        self.ctx
            .queue
            .write_buffer(&self.camera.globals, 0, bytemuck::bytes_of(&globals));
        let has_sun = globals.sun_dir[3] > 0.5;
        let mut timer = self.timer.as_mut();
        if let Some(t) = timer.as_deref_mut() {
            t.begin_frame();
        }
        let tan = (view.camera.fov_deg.to_radians() * 0.5).tan().max(1e-6);
        let cull_view = CullView {
            view_proj: glam::Mat4::from_cols_array_2d(&globals.view_proj),
            position: view.camera.position,
            focal_px: view.width as f32 / (2.0 * tan),
            lod_pixels,
            frustum: true,
            ortho_px_per_m: None,
            phase: if occlusion { Phase::Seen } else { Phase::All },
        };
        if let Some(c) = &self.geometry.culling {
            let writes = timer.as_deref_mut().and_then(|t| t.compute_writes());
            c.encode(&self.ctx.queue, encoder, &cull_view, None, writes);
        }
        let (pipelines, geometry) = (&self.pipelines, &self.geometry);
        let materials = &self.materials.groups;
        self.sun.encode(
            encoder,
            pipelines,
            geometry,
            materials,
            has_sun,
            timer.as_deref_mut(),
        );
        let background = self.lighting.background;
        let first = if occlusion {
            Pass::MainFirst
        } else {
            Pass::Main
        };
        let writes = timer.as_deref_mut().and_then(|t| t.writes(first));
        let camera = &self.camera;
        let scene = (pipelines, geometry, materials.as_slice());
        camera.encode(encoder, background, scene, DrawList::Camera, writes);
        if !occlusion {
            return;
        }
        // The late part: the pyramid of what was drawn, then the instances it does not
        // hide that were not drawn yet.
        let (Some(hp), Some(c), Some(t)) =
            (&self.hiz_pipelines, &geometry.culling, &camera.targets)
        else {
            return;
        };
        let Some(pyramid) = &t.hiz else {
            return;
        };
        pyramid.encode(encoder, hp);
        let late = CullView {
            phase: Phase::Late {
                width: t.width,
                height: t.height,
                levels: pyramid.level_count(),
            },
            ..cull_view
        };
        c.encode(
            &self.ctx.queue,
            encoder,
            &late,
            Some(&pyramid.cull_group),
            None,
        );
        let writes = timer.and_then(|t| t.writes(Pass::MainLate));
        camera.encode(encoder, background, scene, DrawList::Late, writes);
    }

    /// Sets [`RenderSettings::lod_pixels`] for the frames drawn from now on (0: every leaf).
    /// The sky-visibility maps keep the setting they were baked with at load (their
    /// leaves thinned out at the maps' own resolution, which keeps their coverage).
    pub fn set_lod_pixels(&mut self, lod_pixels: f32) {
        self.settings.lod_pixels = lod_pixels.max(0.0);
    }

    /// Turns [`RenderSettings::occlusion_culling`] on or off for the frames drawn from now
    /// on.
    pub fn set_occlusion_culling(&mut self, on: bool) {
        self.settings.occlusion_culling = on;
    }

    /// Whether frames skip instances hidden in the last one: the setting, where the device
    /// can (it needs the culling pass, [`Renderer::drawn_triangles`] is `None` without).
    pub fn occlusion_culling(&self) -> bool {
        self.settings.occlusion_culling && self.hiz_pipelines.is_some()
    }

    /// The current [`RenderSettings::lod_pixels`].
    pub fn lod_pixels(&self) -> f32 {
        self.settings.lod_pixels
    }

    /// Whether this device times its passes (timestamp queries); without them
    /// [`Renderer::gpu_times`] is always `None` and callers show wall-clock time.
    pub fn has_gpu_timing(&self) -> bool {
        self.timer.is_some()
    }

    /// Records, after a frame's last pass ([`Renderer::encode_scene`] and, if any,
    /// [`Renderer::encode_post`]), the copy of its pass timestamps for
    /// [`Renderer::gpu_times`]. Call [`Renderer::frame_submitted`] after submitting the
    /// encoder.
    pub fn finish_frame(&mut self, encoder: &mut wgpu::CommandEncoder) {
        if let Some(t) = &mut self.timer {
            t.resolve(encoder);
        }
    }

    /// Tells the timer that the encoder of [`Renderer::finish_frame`] was submitted.
    pub fn frame_submitted(&mut self) {
        if let Some(t) = &mut self.timer {
            t.submitted();
        }
    }

    /// The GPU time per pass of the latest timed frame, without waiting for the GPU
    /// (frames drawn while a read is pending are not timed); `None` before the first or on
    /// a device without timestamp queries.
    pub fn gpu_times(&mut self) -> Option<PassTimes> {
        let device = &self.ctx.device;
        self.timer.as_mut().and_then(|t| t.poll(device))
    }

    /// Renders the scene's own camera at the film size (supersampled, see
    /// [`RenderSettings::supersample`]) and reads back linear radiance.
    pub fn render_image(&mut self) -> Result<Image, GpuError> {
        let film = self.scene_film;
        let view = FrameView {
            camera: self.scene_camera,
            sun_dir: None,
            width: film.width,
            height: film.height,
        };
        self.render_view_image(&view)
    }

    /// Renders `view` (supersampled) and reads back linear radiance at `view`'s size.
    pub fn render_view_image(&mut self, view: &FrameView) -> Result<Image, GpuError> {
        let ss = self.settings.supersample.max(1);
        let max = self.ctx.max_texture_dim;
        let (w, h) = (view.width * ss, view.height * ss);
        if w > max || h > max {
            return Err(GpuError::Scene(format!(
                "the image ({w}x{h} with {ss}x supersampling) is larger than the GPU's texture \
                 limit of {max}; lower the film size"
            )));
        }
        let big = FrameView {
            width: w,
            height: h,
            ..*view
        };
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        // LOD's leaf area is in pixels of the image: ss² pixels of the target. A single
        // image draws every instance in view (no history: the same view, the same image).
        let lod = self.settings.lod_pixels * (ss * ss) as f32;
        self.encode_scene_lod(&mut encoder, &big, lod, false);
        let hdr = &self
            .camera
            .targets
            .as_ref()
            .expect("made by encode_scene")
            .hdr;
        let raw = readback::read_texture(&self.ctx, encoder, hdr, w, h, 8)?;
        Ok(Image {
            width: view.width,
            height: view.height,
            pixels: readback::box_downsample(&raw, ss, view.width, view.height),
        })
    }

    /// Records the tone-map pass (exposure and operator of `film`, identical to the PNG
    /// output of the offline renderer) from the HDR target into `target` (an sRGB format
    /// so the store applies the sRGB curve), with `overlay` (R8, [`OVERLAY_SIZE`], 1 =
    /// text) in the top-left corner when given.
    pub fn encode_post(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        film: &Film,
        overlay: Option<&[u8]>,
    ) -> Result<(), GpuError> {
        self.post.ensure_pipeline(&self.ctx, format)?;
        let t = self
            .camera
            .targets
            .as_ref()
            .ok_or_else(|| GpuError::Validation {
                what: "tone mapping".into(),
                message: "no frame was rendered yet".into(),
            })?;
        self.post.write_inputs(&self.ctx, film, overlay);
        let writes = self.timer.as_mut().and_then(|t| t.writes(Pass::Post));
        self.post
            .encode(&self.ctx.device, encoder, &t.hdr_view, target, writes);
        Ok(())
    }

    /// Renders `view` at 1x, tone-maps it with `film` and the overlay, and returns sRGB
    /// RGBA8 rows (for window screenshots).
    pub fn render_screenshot(
        &mut self,
        view: &FrameView,
        film: &Film,
        overlay: Option<&[u8]>,
    ) -> Result<Vec<u8>, GpuError> {
        let format = wgpu::TextureFormat::Rgba8UnormSrgb;
        let tex = layout::texture_2d(
            &self.ctx.device,
            "screenshot",
            (view.width, view.height, 1),
            format,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_scene(&mut encoder, view);
        self.encode_post(
            &mut encoder,
            &tex.create_view(&Default::default()),
            format,
            film,
            overlay,
        )?;
        readback::read_texture(&self.ctx, encoder, &tex, view.width, view.height, 4)
    }

    /// Renders `view` without reading it back and waits for the GPU: one frame's work,
    /// for timing. With `post`, the frame also tone-maps into an offscreen sRGB target of
    /// the view's size (what a window's frame does). Returns the frame's GPU time per pass
    /// where the device has timestamp queries.
    pub fn render_and_wait(
        &mut self,
        view: &FrameView,
        post: Option<&Film>,
    ) -> Result<Option<PassTimes>, GpuError> {
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_scene(&mut encoder, view);
        if let Some(film) = post {
            let format = wgpu::TextureFormat::Rgba8UnormSrgb;
            let size = (view.width, view.height);
            let stale = self.post_target.as_ref().is_none_or(|(s, _)| *s != size);
            if stale {
                let tex = layout::texture_2d(
                    &self.ctx.device,
                    "offscreen frame",
                    (view.width, view.height, 1),
                    format,
                    wgpu::TextureUsages::RENDER_ATTACHMENT,
                );
                self.post_target = Some((size, tex.create_view(&Default::default())));
            }
            let (_, target) = self.post_target.take().expect("made above");
            let r = self.encode_post(&mut encoder, &target, format, film, None);
            self.post_target = Some((size, target));
            r?;
        }
        self.finish_frame(&mut encoder);
        self.ctx.queue.submit([encoder.finish()]);
        self.frame_submitted();
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let device = &self.ctx.device;
        Ok(self.timer.as_mut().and_then(|t| t.wait(device)))
    }
}
