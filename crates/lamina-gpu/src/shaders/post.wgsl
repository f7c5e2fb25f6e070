// lamina-gpu post passes for windows and screenshots: the tone map (exposure, operator,
// then the sRGB curve done by the sRGB render target) and the text overlay.

struct Post {
    // x: exposure scale 2^exposure; y: operator (0 clamp, 1 ACES fit, 2 Reinhard).
    params: vec4<f32>,
    // Overlay rectangle in pixels: x0, y0, width, height.
    rect: vec4<f32>,
}

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<uniform> post: Post;
@group(0) @binding(2) var overlay: texture_2d<f32>;

struct FsIn {
    @builtin(position) pos: vec4<f32>,
}

// One triangle covering the screen.
@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> FsIn {
    var o: FsIn;
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    o.pos = vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
    return o;
}

// The same operators as lamina_image::output::tonemap.
fn tonemap(x: f32) -> f32 {
    let v = max(x, 0.0);
    let op = u32(post.params.y);
    if op == 0u {
        return min(v, 1.0);
    } else if op == 1u {
        return clamp((v * (2.51 * v + 0.03)) / (v * (2.43 * v + 0.59) + 0.14), 0.0, 1.0);
    }
    return v / (1.0 + v);
}

// Tone-mapped linear value; the sRGB target applies the sRGB curve on store.
@fragment
fn fs_tonemap(in: FsIn) -> @location(0) vec4<f32> {
    let c = textureLoad(hdr, vec2<i32>(in.pos.xy), 0).rgb * post.params.x;
    var rgb = vec3<f32>(tonemap(c.r), tonemap(c.g), tonemap(c.b));
    // The overlay: white text with a dark box behind it (alpha from the overlay texture).
    let p = in.pos.xy - post.rect.xy;
    if p.x >= 0.0 && p.y >= 0.0 && p.x < post.rect.z && p.y < post.rect.w {
        let o = textureLoad(overlay, vec2<i32>(p), 0);
        rgb = mix(rgb * 0.35, vec3<f32>(1.0), o.r);
    }
    return vec4<f32>(rgb, 1.0);
}
