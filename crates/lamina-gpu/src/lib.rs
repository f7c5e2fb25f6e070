//! Real-time approximation of lamina's leaf model with wgpu (Vulkan; Mesa's lavapipe
//! renders it on machines without a GPU): `lamina render --gpu` for quick previews,
//! `lamina view` for an interactive window, and the frame-time benchmark.
//!
//! The same [`lamina_scene::Scene`] the offline renderer takes (meshes, leaf cards,
//! instanced prototypes, sun/point/area lights, constant or image sky) is rasterised with
//! the alpha test and shaded with an approximation of [`lamina_leaf::LeafBsdf`] whose
//! constants come from lamina-leaf itself; the result is the same linear-radiance
//! [`lamina_image::Image`] the offline renderer returns, so the two can be compared and
//! written alike.
//!
//! * [`bake`]: per material, the white-sky albedo maps (adaxial R, abaxial R, T, with the
//!   thickness and extinction maps applied by the CPU model) and angular lookup tables
//!   baked by evaluating the real CPU BSDF; GGX roughness per side, specular weight and the
//!   front/back blend width from [`lamina_leaf::LeafParams`]; glTF materials
//!   ([`lamina_leaf::PbrBsdf`]) likewise, with one GGX lobe of their mean roughness and a
//!   coloured metallic Fresnel.
//! * [`sky`]: the sky as spherical-harmonic irradiance.
//! * [`renderer`]: the upload and the passes (two-layer translucent shadow map from the
//!   sun every frame, sky-visibility maps baked once at load, camera pass, tone map),
//!   headless image readback and window frames.
//! * [`metrics`]: mean absolute error and SSIM for comparing with the offline renderer.
//! * [`overlay`]: a tiny bitmap font for the frame-time overlay (GPU time per pass from
//!   timestamp queries where the adapter has them: [`renderer::PassTimes`]).
//! * [`context`]: adapter/device creation and the error-scoped shader compile path.
//!
//! Known approximations: point, quad and sphere lights and every sun but the first are
//! unshadowed (quads shaded by their exact unshadowed irradiance, spheres as point lights,
//! at most 32 besides the first sun; [`Renderer::warnings`] names the lights concerned); the
//! sky is shadowed by
//! sky-visibility maps from [`RenderSettings::sky_directions`] directions (16 by default,
//! 0 turns it off), so its light is blocked or filtered only as seen along those
//! directions; light between leaves is limited to transmittance through up to two leaves
//! per direction (no leaf-to-leaf bounces); the leaf lobes' azimuthal shape is averaged
//! out; leaves' bump maps and glTF normal maps are applied with a tangent frame from
//! screen-space derivatives (a leaf's bump baked to the CPU model's shading normal,
//! entering only the shading cosines and the specular lobe, as in `LeafBsdf`); a glTF
//! material's roughness and metallic maps are averaged for its specular lobe.
//!
//! Where this crate sits among the others, and the invariants it keeps: ARCHITECTURE.md.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bake;
pub mod context;
pub mod error;
pub mod metrics;
pub mod overlay;
pub mod renderer;
pub mod sky;

pub use context::{ContextOptions, GpuContext, context_for_tests};
pub use error::GpuError;
pub use renderer::{FrameView, MAX_SHADOWED_LIGHTS, RenderSettings, Renderer};

/// Renders `scene` headless at its film size: the GPU counterpart of
/// `lamina_render::render`. Returns linear radiance and the upload warnings.
pub fn render_scene(
    ctx: &GpuContext,
    scene: &lamina_scene::Scene,
    settings: RenderSettings,
) -> Result<(lamina_image::Image, Vec<String>), GpuError> {
    let mut r = Renderer::new(ctx, scene, settings)?;
    let img = r.render_image()?;
    Ok((img, r.warnings().to_vec()))
}
/// The wgpu this crate is built with (for window surfaces in the CLI).
pub use wgpu;
