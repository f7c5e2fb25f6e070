// lamina-gpu scene shader: the light-view passes (alpha-tested depth and the two-layer
// transmittance map) and the camera pass (leaf shading).
//
// Conventions (as in lamina-leaf): colours are linear Rec.709 RGB; lengths in metres;
// `sun_dir` points from the scene TOWARD the sun; the adaxial (upper, front) side of a
// surface is the side its counter-clockwise winding faces, kept for mirroring instance
// transforms. Radiometry: the camera pass outputs radiance (W m^-2 sr^-1) into a linear
// RGBA16F target; exposure and tone map happen afterwards, identically to the offline
// renderer's PNG output.

const PI: f32 = 3.14159265;
const MAX_LIGHTS: u32 = 32u;

// One light besides the shadowed sun (Rust: `lights::GpuLight`). `pos.w == 0`:
// directional, `pos.xyz` toward the light, `color.rgb` = irradiance at normal incidence
// (W m^-2). `pos.w == 1`: point light at `pos.xyz`, `color.rgb` = radiant intensity
// (W sr^-1), `u.x` the radius of a sphere light (distances clamped to it). `pos.w == 2`
// (one-sided) or `3` (two-sided): a quad with corner `pos.xyz` and edges `u.xyz`, `v.xyz`,
// emitting toward `u x v`, `color.rgb` = radiance (W m^-2 sr^-1). `color.w`: the first
// array layer of its shadow maps in local_d / local_c (-1: none); `u.w`: a cube's range (m).
struct Light {
    pos: vec4<f32>,
    color: vec4<f32>,
    u: vec4<f32>,
    v: vec4<f32>,
}

// Per-frame constants (Rust: `gpu::Globals`).
struct Globals {
    // World -> clip of the camera (depth 0..1).
    view_proj: mat4x4<f32>,
    // World -> clip of the sun's orthographic shadow camera.
    light_view_proj: mat4x4<f32>,
    // Camera position (m), w unused.
    camera_pos: vec4<f32>,
    // Unit vector toward the shadowed sun; w = 1 when there is one.
    sun_dir: vec4<f32>,
    // The shadowed sun's irradiance at normal incidence (W m^-2, linear RGB).
    sun_irr: vec4<f32>,
    // x: shadow map side (texels); y: world size of one shadow texel (m);
    // z: depth range of the shadow camera (m); w: side of a local light's cube face (texels).
    shadow: vec4<f32>,
    // Only in a cube face's light-view pass: the light's centre (m, xyz) and the cube's
    // range (m, w); its depth is the distance from the centre over the range.
    cube: vec4<f32>,
    // The casters' bounding sphere (centre m, radius m) that the suns' maps frame.
    casters: vec4<f32>,
    // Sky irradiance as 9 SH coefficients (bands 0-2), E(n) = sum c_k Y_k(n), W m^-2.
    sky: array<vec4<f32>, 9>,
    lights: array<Light, 32>,
    // x: number of entries used in `lights`.
    counts: vec4<u32>,
}

// Per-material constants (Rust: `bake::MaterialUniform`): x/y GGX alpha adaxial/abaxial,
// z specular weight, w sin(blend width).
// shape.x: card radius a (m): light transmitted by this material reaches a receiver d
// behind it scaled by a^2 / (a^2 + d^2) (it leaves the leaf diffusely); shape.y: 1 when
// t_normal holds a normal map; shape.z: 1 for leaves, whose normal map is the bump map
// baked from lamina-leaf: it lives inside the leaf BSDF (the shading cosines and the
// specular lobe), while sides, the angular tables and the blend band stay geometric.
// metal: the glTF material's metallic lobe, rgb = mean metallic * base colour (F0 times
// weight), a = mean metallic; its Fresnel is rgb + (a - rgb) (1 - v.h)^5. Zero otherwise.
struct MaterialParams {
    spec: vec4<f32>,
    shape: vec4<f32>,
    metal: vec4<f32>,
}

@group(0) @binding(0) var<uniform> g: Globals;
// Light-view depth of the nearest alpha-tested occluder (layer 1) and of the next one
// behind it (layer 2), and their diffuse transmittance colours (rgb) and card radii (a).
@group(0) @binding(1) var shadow_d1: texture_depth_2d;
@group(0) @binding(2) var shadow_d2: texture_depth_2d;
@group(0) @binding(3) var shadow_c1: texture_2d<f32>;
@group(0) @binding(4) var shadow_c2: texture_2d<f32>;

// Sky visibility, baked once per scene: for each of `params.x` directions `dir[k]`
// (spread over the sphere), a two-layer depth/transmittance map like the sun's.
// params: x count, y map side (texels), z world size of a texel (m), w depth range (m).
struct SkyVis {
    view_proj: array<mat4x4<f32>, 16>,
    dir: array<vec4<f32>, 16>,
    params: vec4<f32>,
}
@group(0) @binding(5) var<uniform> skyvis: SkyVis;
@group(0) @binding(6) var sky_d1: texture_depth_2d_array;
@group(0) @binding(7) var sky_d2: texture_depth_2d_array;
@group(0) @binding(8) var sky_c1: texture_2d_array<f32>;
@group(0) @binding(9) var sky_c2: texture_2d_array<f32>;

// The two-layer maps of the lights besides the first sun (baked once, see
// local_shadows.rs), from a light's first layer `color.w`: for a point, sphere or quad
// light a cube, layer first + 2 * face + l holding layer l (0: nearest occluder, 1: the
// next behind it) of a face, depth = distance from the light's centre / range; for a sun
// its orthographic map cut into n x n tiles (n = `v.w`), layers first + 2 k + l holding
// tile k (row by row from the top left), depth as the first sun's. Colour: the
// transmittance with the card radius (a).
@group(0) @binding(10) var local_d: texture_depth_2d_array;
@group(0) @binding(11) var local_c: texture_2d_array<f32>;

// Material maps baked from lamina-leaf (see bake.rs): white-sky albedos, sRGB-encoded
// 8-bit, sampled as linear. front.a = alpha matte.
@group(1) @binding(0) var t_front: texture_2d<f32>;
@group(1) @binding(1) var t_back: texture_2d<f32>;
@group(1) @binding(2) var t_trans: texture_2d<f32>;
// Angular tables g_X(mu_o, mu_i) (1/sr) for layers 0 adaxial R, 1 abaxial R, 2 T;
// layer 3 row 0: Fresnel of the adaxial (r) and abaxial (g) epidermis vs cosine, and the
// specular lobe's directional albedo (b adaxial, a abaxial); row 1 (glTF materials): the
// GGX lobe's albedo with F = 1 (r) and with F = (1 - v.h)^5 (g).
@group(1) @binding(3) var t_lut: texture_2d_array<f32>;
@group(1) @binding(4) var s_map: sampler;
@group(1) @binding(5) var s_lut: sampler;
@group(1) @binding(6) var<uniform> mat: MaterialParams;
// Tangent-space normal map (linear, rgb = n * 0.5 + 0.5; +x along u, +y towards increasing
// lamina v; for leaves +y = normal x tangent, the CPU leaf frame), used when mat.shape.y is
// 1; a flat 1x1 map otherwise.
@group(1) @binding(7) var t_normal: texture_2d<f32>;

// Instance transforms, object -> world: three linear columns and the translation (w
// unused); one slot per instance, a world mesh's slot holding the identity.
struct Instance {
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    m3: vec4<f32>,
}
@group(2) @binding(0) var<storage, read> instances: array<Instance>;
// Per instance slot, written by the culling pass (cull.wgsl): x the fraction of its leaves
// kept, y its own scale (when its instances are the leaves).
@group(2) @binding(1) var<storage, read> inst_lod: array<vec2<f32>>;
// The draw lists: a draw's instance k is the slot draw_list[first_instance + k].
@group(2) @binding(2) var<storage, read> draw_list: array<u32>;

struct VIn {
    @builtin(instance_index) list_index: u32,
    @location(0) pos: vec3<f32>,
    // xyz: the unit normal (w = 0).
    @location(1) normal: vec4<f32>,
    @location(2) uv: vec2<f32>,
    // Level of detail (renderer/lod.rs): xyz the offset from this vertex to its leaf's
    // centre (object space, m), w the leaf's rank; rank -1: never scaled; -2: the whole
    // mesh scaled by its instance's own scale about the centre.
    @location(3) lod: vec4<f32>,
}

struct VOut {
    // Invariant: the camera's depth pre-pass and its shading pass compute the same depth
    // for the same vertex, bit for bit (the shading pass tests for equal depth).
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    // -1 when the instance transform mirrors (front faces then wind clockwise).
    @location(3) @interpolate(flat) mirror: f32,
}

fn transform(v: VIn, clip_from_world: mat4x4<f32>) -> VOut {
    var o: VOut;
    let slot = draw_list[v.list_index];
    let x = instances[slot];
    let m0 = x.m0.xyz;
    let m1 = x.m1.xyz;
    let m2 = x.m2.xyz;
    let m3 = x.m3.xyz;
    // Stochastic simplification: a kept leaf grows about its centre (lod.wgsl).
    let l = inst_lod[slot];
    var s = 1.0;
    if (v.lod.w >= 0.0) {
        s = sqrt(lod_area_factor(v.lod.w, l.x));
    } else if (v.lod.w < -1.5) {
        s = l.y;
    }
    // centre + (pos - centre) s, with the offset centre - pos (exactly pos when s = 1).
    let pos = v.pos + v.lod.xyz * (1.0 - s);
    let world = m0 * pos.x + m1 * pos.y + m2 * pos.z + m3;
    // Normals transform with the cofactor matrix (det * inverse transpose).
    let c0 = cross(m1, m2);
    let c1 = cross(m2, m0);
    let c2 = cross(m0, m1);
    let det = dot(m0, c0);
    o.mirror = select(1.0, -1.0, det < 0.0);
    o.normal = (c0 * v.normal.x + c1 * v.normal.y + c2 * v.normal.z) * o.mirror;
    o.world = world;
    o.uv = v.uv;
    o.clip = clip_from_world * vec4<f32>(world, 1.0);
    return o;
}

// Texture coordinates: lamina's v points up, texture rows go down.
fn map_uv(uv: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(uv.x, 1.0 - uv.y);
}

// ---------------------------------------------------------------------------------
// Light-view passes. Layer 1: nearest alpha-tested surface (depth) and its transmittance
// colour. Layer 2 (depth peeling): the nearest surface strictly behind layer 1. Light
// reaching a point behind one layer is scaled by c1, behind two by c1 * c2, each times the
// form factor of `passed` (a third leaf leaves almost nothing: a green leaf transmits
// 5-20 %).

@vertex
fn vs_shadow(v: VIn) -> VOut {
    return transform(v, g.light_view_proj);
}

// Diffuse transmittance (fraction of the incident flux passed through) of the occluder.
@fragment
fn fs_shadow_first(in: VOut) -> @location(0) vec4<f32> {
    let uv = map_uv(in.uv);
    if textureSample(t_front, s_map, uv).a < 0.5 {
        discard;
    }
    return vec4<f32>(textureSample(t_trans, s_map, uv).rgb, mat.shape.x);
}

@fragment
fn fs_shadow_peel(in: VOut) -> @location(0) vec4<f32> {
    let uv = map_uv(in.uv);
    let a = textureSample(t_front, s_map, uv).a;
    let t = textureSample(t_trans, s_map, uv).rgb;
    let d1 = textureLoad(shadow_d1, vec2<i32>(in.clip.xy), 0);
    if a < 0.5 || in.clip.z <= d1 + 1e-6 {
        discard;
    }
    return vec4<f32>(t, mat.shape.x);
}

// Cube faces of a local light: the same two layers, with depth the distance from the
// light's centre over the cube's range (linear, the same on every face).
struct CubeOut {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

fn cube_depth(p: vec3<f32>) -> f32 {
    return clamp(length(p - g.cube.xyz) / g.cube.w, 0.0, 1.0);
}

@fragment
fn fs_cube_first(in: VOut) -> CubeOut {
    let uv = map_uv(in.uv);
    if textureSample(t_front, s_map, uv).a < 0.5 {
        discard;
    }
    var o: CubeOut;
    o.color = vec4<f32>(textureSample(t_trans, s_map, uv).rgb, mat.shape.x);
    o.depth = cube_depth(in.world);
    return o;
}

@fragment
fn fs_cube_peel(in: VOut) -> CubeOut {
    let uv = map_uv(in.uv);
    let a = textureSample(t_front, s_map, uv).a;
    let t = textureSample(t_trans, s_map, uv).rgb;
    let d = cube_depth(in.world);
    let d1 = textureLoad(shadow_d1, vec2<i32>(in.clip.xy), 0);
    if a < 0.5 || d <= d1 + 1e-6 {
        discard;
    }
    var o: CubeOut;
    o.color = vec4<f32>(t, mat.shape.x);
    o.depth = d;
    return o;
}

// ---------------------------------------------------------------------------------
// Camera pass.

@vertex
fn vs_main(v: VIn) -> VOut {
    return transform(v, g.view_proj);
}

fn smooth01(x: f32) -> f32 {
    let t = clamp(x, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// Angular table lookup at (mu_o, mu_i) in layer `l` (linear filtering, clamped).
fn lut(l: i32, mu_o: f32, mu_i: f32) -> vec3<f32> {
    return textureSampleLevel(t_lut, s_lut, vec2<f32>(mu_o, mu_i), l, 0.0).rgb;
}

fn fresnel(c: f32, adaxial: bool) -> f32 {
    let f = textureSampleLevel(t_lut, s_lut, vec2<f32>(c, 0.5 / 32.0), 3, 0.0);
    return select(f.g, f.r, adaxial);
}

// Directional albedo of the specular lobe (weight 1) at viewing cosine `c`, per side.
fn specular_albedo(c: f32, adaxial: bool) -> f32 {
    let f = textureSampleLevel(t_lut, s_lut, vec2<f32>(c, 0.5 / 32.0), 3, 0.0);
    return select(f.a, f.b, adaxial);
}

// Directional albedo of the metallic lobe (`mat.metal`, weight included) at viewing
// cosine `c`: F0 E1 + (1 - F0) E5 per channel (Schlick's Fresnel integrated exactly).
fn metal_albedo(c: f32) -> vec3<f32> {
    let e = textureSampleLevel(t_lut, s_lut, vec2<f32>(c, 1.5 / 32.0), 3, 0.0);
    return mat.metal.rgb * e.r + (vec3<f32>(mat.metal.a) - mat.metal.rgb) * e.g;
}

fn ggx_lambda(c: f32, a: f32) -> f32 {
    let c2 = max(c * c, 1e-8);
    let tan2 = max(1.0 - c2, 0.0) / c2;
    return 0.5 * (sqrt(1.0 + a * a * tan2) - 1.0);
}

// The leaf's specular lobe f_spec cos (lamina_leaf::specular::eval, GGX with
// height-correlated Smith and the epidermis Fresnel), faded over the blend band next to
// the plane exactly as LeafBsdf does. `n` is the shading normal on the viewer's (= light's)
// side; `fade` the blend-band fade from the geometric cosines (LeafBsdf fades with those).
// For glTF materials (lamina_leaf::PbrBsdf) the dielectric lobe has weight 1 - metallic and
// the metallic lobe (`mat.metal`) adds the same GGX lobe with a coloured Schlick Fresnel.
fn specular(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, adaxial: bool, fade: f32) -> vec3<f32> {
    let w = mat.spec.z;
    if w <= 0.0 && mat.metal.a <= 0.0 {
        return vec3<f32>(0.0);
    }
    let a = select(mat.spec.y, mat.spec.x, adaxial);
    let mu_o = dot(n, v);
    let mu_i = dot(n, l);
    if mu_o <= 0.0 || mu_i <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = normalize(v + l);
    let c = max(dot(n, h), 0.0);
    let a2 = a * a;
    let t = c * c * (a2 - 1.0) + 1.0;
    let d = a2 / (PI * t * t);
    let g2 = 1.0 / (1.0 + ggx_lambda(mu_o, a) + ggx_lambda(mu_i, a));
    let vh = max(dot(v, h), 0.0);
    let f = w * fresnel(vh, adaxial);
    let m = 1.0 - vh;
    let m5 = m * m * m * m * m;
    let fm = mat.metal.rgb + (vec3<f32>(mat.metal.a) - mat.metal.rgb) * m5;
    return (vec3<f32>(f) + fm) * (fade * d * g2 / (4.0 * mu_o));
}

// Everything a light needs about the shaded texel.
struct Surface {
    // Unit shading normal on the viewer's side (normal-mapped or bump-mapped).
    n: vec3<f32>,
    // Unit normal that decides sides and the angular tables' cosines, on the viewer's
    // side: the unperturbed one for leaves (their bump lives inside the BSDF), `n` itself
    // for other materials (a normal map perturbs the whole frame, as on the CPU).
    ng: vec3<f32>,
    // Unit direction to the viewer.
    v: vec3<f32>,
    // Viewing cosine against `ng`.
    mu_o: f32,
    // True when the viewer sees the adaxial side.
    adaxial: bool,
    // Diffuse reflectance of the seen side, and diffuse transmittance (linear RGB).
    refl: vec3<f32>,
    trans: vec3<f32>,
}

// f(wo, wi) |cos theta_i| for light from unit direction `l`: the seen side's reflection
// lobe plus specular when the light is on the viewer's side (of `ng`), the transmission
// lobe when it is behind. The diffuse lobes take the table at the `ng` cosines times
// LeafBsdf's cosine: the shading cosine max(0, l . ±n) (`n` flipped to the light's side)
// blended to the `ng` cosine over the blend band, which vanishes at the plane; the
// specular fades over the band too, so a light crossing the plane changes nothing
// abruptly however the bump tilts `n`. Without a bump (n = ng) the cosine is |l . n|.
fn bsdf_cos(s: Surface, l: vec3<f32>) -> vec3<f32> {
    let c = dot(s.ng, l);
    let mu_i = abs(c);
    let n_l = select(-s.n, s.n, c >= 0.0);
    let cs = max(dot(l, n_l), 0.0);
    let cos_eff = mu_i + smooth01(mu_i / mat.spec.w) * (cs - mu_i);
    if c >= 0.0 {
        let layer = select(1, 0, s.adaxial);
        let fade = smooth01(s.mu_o / mat.spec.w) * smooth01(mu_i / mat.spec.w);
        return s.refl * lut(layer, s.mu_o, mu_i) * cos_eff
            + specular(s.n, s.v, l, s.adaxial, fade);
    }
    return s.trans * lut(2, s.mu_o, mu_i) * cos_eff;
}

fn sh_basis(d: vec3<f32>) -> array<f32, 9> {
    return array<f32, 9>(
        0.282095,
        0.488603 * d.y,
        0.488603 * d.z,
        0.488603 * d.x,
        1.092548 * d.x * d.y,
        1.092548 * d.y * d.z,
        0.315392 * (3.0 * d.z * d.z - 1.0),
        1.092548 * d.x * d.z,
        0.546274 * (d.x * d.x - d.y * d.y),
    );
}

// Sky irradiance (W m^-2) on a surface facing `n`.
fn sky_irradiance(n: vec3<f32>) -> vec3<f32> {
    let b = sh_basis(n);
    var e = vec3<f32>(0.0);
    for (var k = 0; k < 9; k++) {
        e += g.sky[k].xyz * b[k];
    }
    return max(e, vec3<f32>(0.0));
}

// Fraction of the sun's light (per RGB channel) reaching world point `p` with unit normal
// `n_l` on the sun's side: 1 in front of the nearest occluder, what `passed` leaves of c1
// behind one leaf, of c1 and c2 behind two; 3x3 percentage-closer filtered. The point is
// offset 1.5 shadow texels along the normal toward the sun so a surface never shadows
// itself.
// Light passed on by an occluder with transmittance `c.rgb` and card radius `c.a` to a
// receiver `d` metres behind it: the diffusely transmitted light's on-axis disc form
// factor a^2 / (a^2 + d^2) (near the leaf all of it, far behind little).
fn passed(c: vec4<f32>, d: f32) -> vec3<f32> {
    let a2 = c.a * c.a;
    return c.rgb * (a2 / max(a2 + d * d, 1e-12));
}

fn sun_transmittance(p: vec3<f32>, n_l: vec3<f32>) -> vec3<f32> {
    let q = p + n_l * (1.5 * g.shadow.y);
    let c = g.light_view_proj * vec4<f32>(q, 1.0);
    let ndc = c.xyz / c.w;
    let size = i32(g.shadow.x);
    let tc = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * g.shadow.x;
    let base = vec2<i32>(floor(tc));
    // Outside the map (and in front of it) nothing casts a shadow.
    if any(tc < vec2<f32>(0.0)) || any(tc >= vec2<f32>(g.shadow.x)) || ndc.z < 0.0 {
        return vec3<f32>(1.0);
    }
    // Depth tolerance: two shadow texels along the light, in depth units.
    let bias = 2.0 * g.shadow.y / g.shadow.z;
    var acc = vec3<f32>(0.0);
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let t = clamp(base + vec2<i32>(dx, dy), vec2<i32>(0), vec2<i32>(size - 1));
            let d1 = textureLoad(shadow_d1, t, 0);
            let d2 = textureLoad(shadow_d2, t, 0);
            var v = vec3<f32>(1.0);
            if ndc.z > d1 + bias {
                let c1 = textureLoad(shadow_c1, t, 0);
                if ndc.z > d2 + bias {
                    // Through two leaves: the second passes on what reached it from the first.
                    let c2 = textureLoad(shadow_c2, t, 0);
                    v = passed(c1, (d2 - d1) * g.shadow.z) * passed(c2, (ndc.z - d2) * g.shadow.z);
                } else {
                    v = passed(c1, (ndc.z - d1) * g.shadow.z);
                }
            }
            acc += v;
        }
    }
    return acc / 9.0;
}

// The cube face (0..5: +x -x +y -y +z -z) that direction `w` from a light falls on
// (Rust: projection::cube_lookup, whose test checks it against the faces' matrices).
fn cube_face(w: vec3<f32>) -> u32 {
    let a = abs(w);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, w.x >= 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, w.y >= 0.0);
    }
    return select(5u, 4u, w.z >= 0.0);
}

// The texel of a cube face of side `size` that direction `w` from the light falls on
// (face `f`: forward axis, up = +z for the y faces and +y otherwise, right = forward x up).
fn cube_texel(w: vec3<f32>, f: u32, size: f32) -> vec2<i32> {
    var fwd = vec3<f32>(0.0);
    fwd[f / 2u] = select(-1.0, 1.0, (f & 1u) == 0u);
    let up = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), f / 2u == 1u);
    let z = dot(w, fwd);
    let x = dot(w, cross(fwd, up)) / z;
    let y = dot(w, up) / z;
    let tc = vec2<f32>(x * 0.5 + 0.5, 0.5 - y * 0.5) * size;
    return clamp(vec2<i32>(floor(tc)), vec2<i32>(0), vec2<i32>(i32(size) - 1));
}

// The light (per RGB channel) passed to depth `z` at texel `t` of the two-layer map in
// array layers `l` and `l + 1` of local_d / local_c: through none, one or two leaves (as
// `sun_transmittance`); `range` metres per unit of depth, `bias` the depth tolerance.
fn local_layers(t: vec2<i32>, l: i32, z: f32, bias: f32, range: f32) -> vec3<f32> {
    let d1 = textureLoad(local_d, t, l, 0);
    if z <= d1 + bias {
        return vec3<f32>(1.0);
    }
    let c1 = textureLoad(local_c, t, l, 0);
    let d2 = textureLoad(local_d, t, l + 1, 0);
    if z <= d2 + bias {
        return passed(c1, (z - d1) * range);
    }
    let c2 = textureLoad(local_c, t, l + 1, 0);
    return passed(c1, (d2 - d1) * range) * passed(c2, (z - d2) * range);
}

// One tap of a cube: the light passed to normalised distance `dr` along direction `w`;
// `base` the cube's first array layer, `range` its range (m).
fn cube_tap(base: i32, w: vec3<f32>, dr: f32, bias: f32, range: f32) -> vec3<f32> {
    let f = cube_face(w);
    return local_layers(cube_texel(w, f, g.shadow.w), base + 2 * i32(f), dr, bias, range);
}

// Fraction of a further sun's light (per RGB channel, through leaves) reaching `p` with
// unit normal `n_l` on the sun's side, from its orthographic two-layer map (first layer
// `li.color.w`), which frames the casters' sphere as `light_matrix` (projection.rs) does:
// the eye 2 r toward the sun from the centre, up +z when the sun is within 8° of the
// zenith or nadir and +y otherwise. 3x3 percentage-closer filtered, offset 1.5 texels
// along the normal, as the first sun's.
fn sun_map_transmittance(li: Light, p: vec3<f32>, n_l: vec3<f32>) -> vec3<f32> {
    let base = i32(li.color.w);
    if base < 0 {
        return vec3<f32>(1.0);
    }
    let d = normalize(li.pos.xyz);
    let r = g.casters.w;
    let tile = g.shadow.w;
    let n = i32(li.v.w);
    let size = tile * f32(n);
    let texel = 2.0 * r / size;
    let e = p + n_l * (1.5 * texel) - (g.casters.xyz + d * (2.0 * r));
    let f = -d;
    let up = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), abs(d.y) > 0.99);
    let sx = normalize(cross(f, up));
    let sy = cross(sx, f);
    let tc = vec2<f32>(dot(e, sx) / r * 0.5 + 0.5, 0.5 - dot(e, sy) / r * 0.5) * size;
    let z = (dot(e, f) - r) / (2.0 * r);
    if any(tc < vec2<f32>(0.0)) || any(tc >= vec2<f32>(size)) || z < 0.0 {
        return vec3<f32>(1.0);
    }
    let bias = texel / r;
    let t0 = vec2<i32>(floor(tc));
    var acc = vec3<f32>(0.0);
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let t = clamp(t0 + vec2<i32>(dx, dy), vec2<i32>(0), vec2<i32>(i32(size) - 1));
            let k = t / i32(tile);
            let l = base + 2 * (k.y * n + k.x);
            acc += local_layers(t - k * i32(tile), l, z, bias, 2.0 * r);
        }
    }
    return acc / 9.0;
}

// Tap k of n on a Vogel disc of unit radius turned by `turn` (radians).
fn vogel(k: i32, n: i32, turn: f32) -> vec2<f32> {
    let r = sqrt((f32(k) + 0.5) / f32(n));
    let phi = f32(k) * 2.39996323 + turn;
    return r * vec2<f32>(cos(phi), sin(phi));
}

const CUBE_TAPS: i32 = 16;

// Fraction of a local light's light (per RGB channel, through leaves) reaching world point
// `p` with unit normal `n_l` on the light's side, from the light's cube (first layer
// `li.color.w`, range `li.u.w`) centred at `center`; `radius` the light's size (0 for a
// point light). Percentage-closer filtering over 16 taps of a Vogel disc, turned per pixel
// (`pix`, interleaved gradient noise) so that its pattern averages out; for a light with a
// size, percentage-closer soft shadows: a blocker search over the directions whose
// occluders can hide part of the light, then a filter as wide as the penumbra
// radius (d_r - d_b) / (d_r d_b) (radians), d_b the blockers' mean distance. The point is
// offset 1.5 texels along the normal, as for the sun.
fn local_transmittance(li: Light, center: vec3<f32>, radius: f32, p: vec3<f32>, n_l: vec3<f32>, pix: vec2<f32>) -> vec3<f32> {
    let base = i32(li.color.w);
    if base < 0 {
        return vec3<f32>(1.0);
    }
    let range = li.u.w;
    // A texel's angle (rad) at a face's centre.
    let texel = 2.0 / g.shadow.w;
    let q = p + n_l * (1.5 * texel * length(p - center));
    let w = q - center;
    let dq = max(length(w), 1e-6);
    let dr = dq / range;
    let bias = 2.0 * texel * dr;
    let wn = w / dq;
    let a = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), abs(wn.y) > 0.9);
    let t1 = normalize(cross(wn, a));
    let t2 = cross(wn, t1);
    let turn = 6.2831853 * fract(52.9829189 * fract(dot(pix, vec2<f32>(0.06711056, 0.00583715))));
    // Up to 0.1 rad (6°) of penumbra, whatever the maps' resolution (a wider search and
    // filter measured worse against the offline renderer with 16 taps).
    let widest = max(0.1, 2.0 * texel);
    var width = 1.0 * texel;
    if radius > 0.0 {
        // Occluders at a third of the way or farther from the light hide part of it within
        // 2 R / d_r of the receiver's direction.
        let search = clamp(2.0 * radius / dq, 1.5 * texel, widest);
        var sum = 0.0;
        var found = 0.0;
        for (var k = 0; k < CUBE_TAPS; k++) {
            let o = vogel(k, CUBE_TAPS, turn) * search;
            let d = wn + t1 * o.x + t2 * o.y;
            let f = cube_face(d);
            let d1 = textureLoad(local_d, cube_texel(d, f, g.shadow.w), base + 2 * i32(f), 0);
            if dr > d1 + bias {
                sum += d1;
                found += 1.0;
            }
        }
        if found == 0.0 {
            return vec3<f32>(1.0);
        }
        let db = max(sum / found * range, 1e-6);
        width = clamp(radius * (dq - db) / (dq * db), texel, widest);
    }
    var acc = vec3<f32>(0.0);
    for (var k = 0; k < CUBE_TAPS; k++) {
        let o = vogel(k, CUBE_TAPS, turn) * width;
        acc += cube_tap(base, wn + t1 * o.x + t2 * o.y, dr, bias, range);
    }
    return acc / f32(CUBE_TAPS);
}

// Fraction of the sky (per RGB channel, through leaves) seen by the two faces of the
// surface at `p` with unit normal `n`: `.front` for the face `n` points to, `.back` for the
// other, each the cosine-weighted mean over the baked directions on its side of the
// visibility 1 / c1 / c1 c2 (one tap per direction; the normal offset as for the sun).
struct SkyVisibility {
    front: vec3<f32>,
    back: vec3<f32>,
}

fn sky_visibility(p: vec3<f32>, n: vec3<f32>) -> SkyVisibility {
    var out: SkyVisibility;
    let count = u32(skyvis.params.x);
    if count == 0u {
        out.front = vec3<f32>(1.0);
        out.back = vec3<f32>(1.0);
        return out;
    }
    let size = i32(skyvis.params.y);
    let bias = 2.0 * skyvis.params.z / skyvis.params.w;
    var front = vec3<f32>(0.0);
    var back = vec3<f32>(0.0);
    var wf = 0.0;
    var wb = 0.0;
    for (var k = 0u; k < count; k++) {
        let d = skyvis.dir[k].xyz;
        let c = dot(n, d);
        let side = select(-1.0, 1.0, c >= 0.0);
        let q = p + n * (side * 1.5 * skyvis.params.z);
        let h = skyvis.view_proj[k] * vec4<f32>(q, 1.0);
        let ndc = h.xyz / h.w;
        let tf = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * skyvis.params.y;
        let t = clamp(vec2<i32>(floor(tf)), vec2<i32>(0), vec2<i32>(size - 1));
        let inside = all(tf >= vec2<f32>(0.0)) && all(tf < vec2<f32>(skyvis.params.y)) && ndc.z >= 0.0;
        var v = vec3<f32>(1.0);
        let d1 = textureLoad(sky_d1, t, k, 0);
        if inside && ndc.z > d1 + bias {
            let c1 = textureLoad(sky_c1, t, k, 0);
            let d2 = textureLoad(sky_d2, t, k, 0);
            if ndc.z > d2 + bias {
                let c2 = textureLoad(sky_c2, t, k, 0);
                v = passed(c1, (d2 - d1) * skyvis.params.w) * passed(c2, (ndc.z - d2) * skyvis.params.w);
            } else {
                v = passed(c1, (ndc.z - d1) * skyvis.params.w);
            }
        }
        let w = abs(c);
        if c >= 0.0 {
            front += v * w;
            wf += w;
        } else {
            back += v * w;
            wb += w;
        }
    }
    out.front = select(vec3<f32>(1.0), front / wf, wf > 0.0);
    out.back = select(vec3<f32>(1.0), back / wb, wb > 0.0);
    return out;
}

// The interpolated normal `n0` (unit, adaxial side) perturbed by the tangent-space normal
// `m` (unit): the frame is x = dP/du made orthogonal to n0, y = n0 x t signed towards
// increasing v, z = n0, as lamina-render's shading_normal, with dP/du and dP/dv solved
// from the screen-space derivatives of position and uv (no vertex tangents: the glTF
// sample viewer's construction). `leaf`: y = n0 x t unsigned, LeafMaterial's frame (the
// same unless the uv mapping is mirrored against the adaxial side). n0 itself where the
// uv mapping is degenerate.
fn mapped_normal(
    n0: vec3<f32>,
    m: vec3<f32>,
    dpx: vec3<f32>,
    dpy: vec3<f32>,
    dux: vec2<f32>,
    duy: vec2<f32>,
    leaf: bool,
) -> vec3<f32> {
    let det = dux.x * duy.y - dux.y * duy.x;
    if abs(det) < 1e-20 {
        return n0;
    }
    let dpdu = (dpx * duy.y - dpy * dux.y) / det;
    let dpdv = (dpy * dux.x - dpx * duy.x) / det;
    let tt = dpdu - n0 * dot(n0, dpdu);
    if dot(tt, tt) < 1e-20 {
        return n0;
    }
    let t = normalize(tt);
    var b = cross(n0, t);
    if !leaf && dot(b, dpdv) < 0.0 {
        b = -b;
    }
    let mapped = t * m.x + b * m.y + n0 * m.z;
    if dot(mapped, mapped) < 1e-12 {
        return n0;
    }
    return normalize(mapped);
}

// The irradiance vector of a quad light of unit radiance at `x` (Lambert's polygon form
// factor in vector form, Arvo 1994: E = 1/2 sum_k theta_k Gamma_k over the edges, theta_k
// the angle an edge subtends and Gamma_k the unit normal of the plane through it and x):
// the irradiance on a surface of normal n is dot(n, E) while the quad is above its horizon.
// Zero behind a one-sided quad. Points toward the quad.
fn quad_irradiance(li: Light, x: vec3<f32>) -> vec3<f32> {
    let nq = cross(li.u.xyz, li.v.xyz);
    let c0 = li.pos.xyz - x;
    if li.pos.w < 2.5 && dot(c0, nq) >= 0.0 {
        return vec3<f32>(0.0);
    }
    var p = array<vec3<f32>, 4>(
        normalize(c0),
        normalize(c0 + li.u.xyz),
        normalize(c0 + li.u.xyz + li.v.xyz),
        normalize(c0 + li.v.xyz),
    );
    var e = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let a = p[k];
        let b = p[(k + 1u) % 4u];
        let c = cross(a, b);
        let len = length(c);
        if len > 1e-7 {
            e += acos(clamp(dot(a, b), -1.0, 1.0)) * c / len;
        }
    }
    e *= 0.5;
    return select(e, -e, dot(e, c0 + 0.5 * (li.u.xyz + li.v.xyz)) < 0.0);
}

// The camera's depth pre-pass: the nearest alpha-tested surface per pixel (the same
// alpha test as `fs_main`'s, on the same texture coordinates and derivatives), so that the
// shading pass runs `fs_main` once per pixel, not once per overlapping leaf. No colour.
@fragment
fn fs_depth(in: VOut) -> @location(0) vec4<f32> {
    if textureSample(t_front, s_map, map_uv(in.uv)).a < 0.5 {
        discard;
    }
    return vec4<f32>(0.0);
}

// Radiance toward the camera (linear RGB, W m^-2 sr^-1).
@fragment
fn fs_main(in: VOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let uv = map_uv(in.uv);
    let front = textureSample(t_front, s_map, uv);
    let back = textureSample(t_back, s_map, uv).rgb;
    let trans = textureSample(t_trans, s_map, uv).rgb;
    // Derivatives and the normal map before the discard (uniform control flow).
    let nm = textureSample(t_normal, s_map, uv).xyz * 2.0 - 1.0;
    let dpx = dpdx(in.world);
    let dpy = dpdy(in.world);
    let dux = dpdx(in.uv);
    let duy = dpdy(in.uv);
    if front.a < 0.5 {
        discard;
    }
    var s: Surface;
    s.v = normalize(g.camera_pos.xyz - in.world);
    let n0 = normalize(in.normal);
    // The seen side follows the unperturbed normal (lamina-render: sides are geometric).
    let flip = dot(n0, s.v) < 0.0;
    let ng = select(n0, -n0, flip);
    var n = ng;
    let leaf_bump = mat.shape.z > 0.5;
    if mat.shape.y > 0.5 {
        let m = mapped_normal(n0, normalize(nm), dpx, dpy, dux, duy, leaf_bump);
        // The bump or normal map's normal seen from the back is its negation (LeafBsdf
        // uses -n_s on the abaxial side).
        let nm_seen = select(m, -m, flip);
        // A leaf keeps its bump normal whatever the view (LeafBsdf has no fallback; a view
        // behind it only loses the specular lobe). A view the perturbed normal puts
        // behind another surface shades flat (as lamina-render's frame does).
        if leaf_bump || dot(nm_seen, s.v) > 0.0 {
            n = nm_seen;
        }
    }
    s.n = n;
    s.ng = select(n, ng, leaf_bump);
    s.mu_o = clamp(dot(s.ng, s.v), 1e-4, 1.0);
    s.adaxial = front_facing != (in.mirror < 0.0);
    s.refl = select(back, front.rgb, s.adaxial);
    s.trans = trans;

    var col = vec3<f32>(0.0);
    if g.sun_dir.w > 0.5 {
        let l = g.sun_dir.xyz;
        let n_l = select(-s.ng, s.ng, dot(s.ng, l) >= 0.0);
        col += bsdf_cos(s, l) * g.sun_irr.rgb * sun_transmittance(in.world, n_l);
    }
    for (var i = 0u; i < min(g.counts.x, MAX_LIGHTS); i++) {
        let li = g.lights[i];
        if li.pos.w < 0.5 {
            let l = normalize(li.pos.xyz);
            let n_l = select(-s.ng, s.ng, dot(s.ng, l) >= 0.0);
            col += bsdf_cos(s, l) * li.color.rgb * sun_map_transmittance(li, in.world, n_l);
        } else if li.pos.w < 1.5 {
            let d = li.pos.xyz - in.world;
            let r2 = max(dot(d, d), max(li.u.x * li.u.x, 1e-8));
            let l = normalize(d);
            let n_l = select(-s.ng, s.ng, dot(s.ng, l) >= 0.0);
            let vis = local_transmittance(li, li.pos.xyz, li.u.x, in.world, n_l, in.clip.xy);
            col += bsdf_cos(s, l) * li.color.rgb / r2 * vis;
        } else {
            // The quad's irradiance vector: its direction is where the light comes from on
            // average, its length the irradiance at normal incidence. Its shadow: from its
            // centre, soft as from the disc of its area.
            let e = quad_irradiance(li, in.world);
            let m = length(e);
            if m > 1e-12 {
                let l = e / m;
                let n_l = select(-s.ng, s.ng, dot(s.ng, l) >= 0.0);
                let c = li.pos.xyz + 0.5 * (li.u.xyz + li.v.xyz);
                let r = sqrt(length(cross(li.u.xyz, li.v.xyz)) / PI);
                let vis = local_transmittance(li, c, r, in.world, n_l, in.clip.xy);
                col += bsdf_cos(s, l) * li.color.rgb * m * vis;
            }
        }
    }
    // Sky: the diffuse lobes integrate the irradiance on each face with their white-sky
    // albedos (exactly what the maps mean), plus the specular reflection of the sky
    // approximated by the lobe's directional albedo times the irradiance around the mirror
    // direction (GGX shadowing keeps it small at grazing views, as on the CPU).
    // Both scale with the sky visibility of their face.
    let vis = sky_visibility(in.world, s.ng);
    let mu_s = clamp(dot(n, s.v), 1e-4, 1.0);
    let spec_alb = mat.spec.z * specular_albedo(mu_s, s.adaxial) + metal_albedo(mu_s);
    let spec_sky = spec_alb * sky_irradiance(reflect(-s.v, n));
    col += (vis.front * (s.refl * sky_irradiance(n) + spec_sky) + vis.back * s.trans * sky_irradiance(-n)) / PI;
    return vec4<f32>(col, 1.0);
}
