// Culling and level of detail, once per frame before the light-view and camera passes
// (Rust: renderer/culling.rs). One workgroup per group of instances (a prototype with its
// instances, or a world mesh with its one): each instance gets the fraction of its leaves
// kept (lod.wgsl) and a bucket, and goes into three draw lists: the shadow list (every
// instance drawn), the camera list (those whose bounding sphere meets the view frustum)
// and the late camera list. Each list is ordered by bucket, instance order kept within
// one, so frames are deterministic; then the indirect draw arguments of the group's
// meshes are written per list and bucket.
//
// Occlusion culling, two-phase (after Hill & Collin 2011 and GPU-driven pipelines since):
// phase 0 puts every instance in view into the camera list (single images, light views);
// phase 1 only those that were visible last frame (the shadow list as in phase 0); the
// camera pass draws them, a max-depth pyramid is built from its depth (hiz.wgsl), and
// phase 2 tests every instance in view against the pyramid: those not hidden and not
// drawn in phase 1 go into the late camera list, drawn on top, and every instance's
// visibility is kept for the next frame. Nothing in view is ever missed: what phase 1
// did not draw is tested against depth that only holds nearer surfaces drawn this frame.

struct Params {
    // World -> clip of the camera (depth 0..1).
    view_proj: mat4x4<f32>,
    // xyz: camera position (m); w: the camera's focal length in pixels.
    cam: vec4<f32>,
    // x: projected element area (px^2) below which leaves thin out, 0 = no LOD;
    // y: 1 = frustum culling of the camera list; z: the smallest fraction kept;
    // w: pixels per metre of an orthographic view (0: perspective, from cam.w).
    lod: vec4<f32>,
    // x: groups; y: instance slots (the shadow list starts there, the late camera list at
    // twice that); z: workgroups per row.
    counts: vec4<u32>,
    // x: phase (0, 1, 2, see above); y, z: the camera's depth target (pixels); w: levels
    // of the depth pyramid.
    occl: vec4<f32>,
}

struct Group {
    // Object-space bounding sphere of its meshes: centre, radius (m).
    sphere: vec4<f32>,
    // x: mean element area (m^2, object space), 0 = no LOD; y: 1 when its instances are
    // the elements (instance-level LOD); z: largest element radius (m).
    shape: vec4<f32>,
    // x: first instance slot, y: instances, z: first mesh, w: meshes.
    range: vec4<u32>,
}

// Object -> world: three linear columns and the translation (w unused).
struct Instance {
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    m3: vec4<f32>,
}

struct DrawArgs {
    index_count: u32,
    instance_count: u32,
    first_index: u32,
    base_vertex: i32,
    first_instance: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> groups: array<Group>;
@group(0) @binding(2) var<storage, read> instances: array<Instance>;
// Per mesh, LOD_BUCKETS index counts: the prefix each bucket draws.
@group(0) @binding(3) var<storage, read> bucket_counts: array<u32>;
// Per instance: fraction kept, own scale (instance-level LOD).
@group(0) @binding(4) var<storage, read_write> inst_lod: array<vec2<f32>>;
// Camera list (slots 0..counts.y), then shadow list.
@group(0) @binding(5) var<storage, read_write> draw_list: array<u32>;
// Per mesh: camera list buckets, shadow list buckets, late camera list buckets.
@group(0) @binding(6) var<storage, read_write> args: array<DrawArgs>;
// Per instance slot: 1 when the camera saw it (not hidden) in the last frame.
@group(0) @binding(7) var<storage, read_write> visible: array<u32>;
// The depth pyramid: level m texel (x, y) is the farthest depth of the camera's pixels
// [2^(m+1) x, 2^(m+1) (x + 1)) per axis (hiz.wgsl).
@group(1) @binding(0) var hiz: texture_2d<f32>;

const THREADS: u32 = 64u;
// List and bucket slots: camera list buckets 0..LOD_BUCKETS, then the shadow list's, then
// the late camera list's.
const SLOTS: u32 = 3u * LOD_BUCKETS;
// counts[t * SLOTS + s]: thread t's instances in slot s; after the scan, their offset.
var<workgroup> counts: array<u32, THREADS * SLOTS>;
// Per slot: instances in the group, and where the slot starts in the group's region.
var<workgroup> total: array<u32, SLOTS>;
var<workgroup> base: array<u32, SLOTS>;

struct State {
    f: f32,
    scale: f32,
    bucket: u32,
    // Drawn at all (the shadow list in phases 0 and 1), in the camera list, in the late
    // camera list (phase 2).
    drawn: bool,
    seen: bool,
    late: bool,
    // Phase 2: in view and not hidden (kept in `visible`).
    visible: bool,
}

// A uniform number in (0, 1) from an integer (PCG hash).
fn hash01(x: u32) -> f32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    h = (h >> 22u) ^ h;
    return (f32(h >> 8u) + 0.5) / 16777216.0;
}

// Whether the sphere (c, r) meets the camera's view volume (planes of view_proj).
fn in_frustum(c: vec3<f32>, r: f32) -> bool {
    let m = p.view_proj;
    let r0 = vec4<f32>(m[0].x, m[1].x, m[2].x, m[3].x);
    let r1 = vec4<f32>(m[0].y, m[1].y, m[2].y, m[3].y);
    let r2 = vec4<f32>(m[0].z, m[1].z, m[2].z, m[3].z);
    let r3 = vec4<f32>(m[0].w, m[1].w, m[2].w, m[3].w);
    var planes = array<vec4<f32>, 6>(r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2);
    for (var k = 0; k < 6; k++) {
        let pl = planes[k];
        if (dot(pl.xyz, c) + pl.w < -r * length(pl.xyz)) {
            return false;
        }
    }
    return true;
}

// Whether the sphere (c, r), in front of the camera, lies behind the depth pyramid
// everywhere it covers: the nearest depth of its bounding box against the farthest depth
// of the pyramid texels under its footprint (a level where that is at most 2x2 texels).
fn hidden(c: vec3<f32>, r: f32) -> bool {
    var lo = vec3<f32>(1e30);
    var hi = vec2<f32>(-1e30);
    for (var k = 0u; k < 8u; k++) {
        let o = vec3<f32>(f32(k & 1u), f32((k >> 1u) & 1u), f32((k >> 2u) & 1u)) * 2.0 - 1.0;
        let h = p.view_proj * vec4<f32>(c + o * r, 1.0);
        if (h.w <= 1e-6) {
            return false;
        }
        let n = h.xyz / h.w;
        lo = min(lo, n);
        hi = max(hi, n.xy);
    }
    if (lo.z <= 0.0) {
        return false;
    }
    let size = p.occl.yz;
    // Pixels, y down; clamped to the target.
    let a = clamp(vec2<f32>(lo.x * 0.5 + 0.5, 0.5 - hi.y * 0.5) * size, vec2<f32>(0.0), size - 1.0);
    let b = clamp(vec2<f32>(hi.x * 0.5 + 0.5, 0.5 - lo.y * 0.5) * size, vec2<f32>(0.0), size - 1.0);
    let extent = max(b.x - a.x, b.y - a.y);
    let levels = i32(p.occl.w);
    let m = clamp(i32(ceil(log2(max(extent, 1.0)))) - 1, 0, levels - 1);
    let texel = exp2(f32(m + 1));
    let dims = vec2<i32>(textureDimensions(hiz, m)) - 1;
    let t0 = min(vec2<i32>(floor(a / texel)), dims);
    let t1 = min(vec2<i32>(floor(b / texel)), dims);
    var far = 0.0;
    for (var y = t0.y; y <= t1.y; y++) {
        for (var x = t0.x; x <= t1.x; x++) {
            far = max(far, textureLoad(hiz, vec2<i32>(x, y), m).r);
        }
    }
    return lo.z > far;
}

fn state(i: u32, gr: Group) -> State {
    let x = instances[i];
    let s = gr.sphere;
    let c = x.m0.xyz * s.x + x.m1.xyz * s.y + x.m2.xyz * s.z + x.m3.xyz;
    let smax = max(length(x.m0.xyz), max(length(x.m1.xyz), length(x.m2.xyz)));
    var st = State(1.0, 1.0, 0u, true, true, false, false);
    var grow = 0.0;
    if (p.lod.x > 0.0 && gr.shape.x > 0.0) {
        let d = max(distance(c, p.cam.xyz), 1e-4);
        let det = abs(dot(x.m0.xyz, cross(x.m1.xyz, x.m2.xyz)));
        let px = select(p.cam.w / d, p.lod.w, p.lod.w > 0.0);
        let area_px = gr.shape.x * pow(det, 2.0 / 3.0) * px * px;
        st.f = clamp(area_px / p.lod.x, p.lod.z, 1.0);
        if (gr.shape.y > 0.5) {
            let a = lod_area_factor(hash01(i - gr.range.x), st.f);
            st.drawn = a > 0.0;
            st.scale = sqrt(a);
        } else {
            st.bucket = min(u32(max(floor(-2.0 * log2(st.f)), 0.0)), LOD_BUCKETS - 1u);
            grow = inverseSqrt(st.f) - 1.0;
        }
    }
    let r = smax * (s.w * max(st.scale, 1.0) + gr.shape.z * grow);
    let in_view = st.drawn && (p.lod.y < 0.5 || in_frustum(c, r));
    let phase = u32(p.occl.x);
    st.seen = in_view && (phase == 0u || (phase == 1u && visible[i] != 0u));
    if (phase == 2u) {
        st.visible = in_view && !hidden(c, r);
        st.late = st.visible && visible[i] == 0u;
        st.seen = false;
        st.drawn = false;
    }
    return st;
}

@compute @workgroup_size(64)
fn cull(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let gi = wg.x + wg.y * p.counts.z;
    if (gi >= p.counts.x) {
        return;
    }
    let gr = groups[gi];
    let first = gr.range.x;
    let end = first + gr.range.y;
    let chunk = (gr.range.y + THREADS - 1u) / THREADS;
    let lo = min(first + t * chunk, end);
    let hi = min(lo + chunk, end);
    for (var s = 0u; s < SLOTS; s++) {
        counts[t * SLOTS + s] = 0u;
    }
    for (var i = lo; i < hi; i++) {
        let st = state(i, gr);
        inst_lod[i] = vec2<f32>(st.f, st.scale);
        if (st.seen) {
            counts[t * SLOTS + st.bucket] += 1u;
        }
        if (st.drawn) {
            counts[t * SLOTS + LOD_BUCKETS + st.bucket] += 1u;
        }
        if (st.late) {
            counts[t * SLOTS + 2u * LOD_BUCKETS + st.bucket] += 1u;
        }
    }
    workgroupBarrier();
    // Each slot's column: exclusive offsets per thread, and the slot's total.
    if (t < SLOTS) {
        var sum = 0u;
        for (var k = 0u; k < THREADS; k++) {
            let c = counts[k * SLOTS + t];
            counts[k * SLOTS + t] = sum;
            sum += c;
        }
        total[t] = sum;
    }
    workgroupBarrier();
    // Where each bucket starts in its list's region of the group.
    if (t < 3u) {
        var sum = 0u;
        for (var b = 0u; b < LOD_BUCKETS; b++) {
            base[t * LOD_BUCKETS + b] = sum;
            sum += total[t * LOD_BUCKETS + b];
        }
    }
    workgroupBarrier();
    // The lists this phase writes: phase 0 all three (the late one empty), phase 1 the
    // camera and shadow lists, phase 2 the late one.
    let phase = u32(p.occl.x);
    let cells = gr.range.w * SLOTS;
    for (var c = t; c < cells; c += THREADS) {
        let m = gr.range.z + c / SLOTS;
        let s = c % SLOTS;
        let late = s >= 2u * LOD_BUCKETS;
        if ((phase == 1u && late) || (phase == 2u && !late)) {
            continue;
        }
        var a: DrawArgs;
        a.instance_count = total[s];
        a.index_count = select(0u, bucket_counts[m * LOD_BUCKETS + s % LOD_BUCKETS], total[s] > 0u);
        a.first_index = 0u;
        a.base_vertex = 0;
        a.first_instance = (s / LOD_BUCKETS) * p.counts.y + first + base[s];
        args[m * SLOTS + s] = a;
    }
    // Each thread writes its own chunk's instances, in order, at its offsets.
    for (var i = lo; i < hi; i++) {
        let st = state(i, gr);
        // What the camera saw (phase 2; phase 0 when it is the camera's view, not a
        // light's), read above (state) before it is written: each instance by its own
        // thread.
        if (phase == 2u || (phase == 0u && p.lod.y > 0.5)) {
            visible[i] = select(0u, 1u, select(st.seen, st.visible, phase == 2u));
        }
        if (st.late) {
            let s = 2u * LOD_BUCKETS + st.bucket;
            let k = t * SLOTS + s;
            draw_list[2u * p.counts.y + first + base[s] + counts[k]] = i;
            counts[k] += 1u;
        }
        if (st.seen) {
            let k = t * SLOTS + st.bucket;
            draw_list[first + base[st.bucket] + counts[k]] = i;
            counts[k] += 1u;
        }
        if (st.drawn) {
            let s = LOD_BUCKETS + st.bucket;
            let k = t * SLOTS + s;
            draw_list[p.counts.y + first + base[s] + counts[k]] = i;
            counts[k] += 1u;
        }
    }
}
