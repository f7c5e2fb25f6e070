// The camera's depth pyramid for occlusion culling (Rust: renderer/hiz.rs): level 0 is at
// least half the depth target's size (a power of two per axis), each texel the farthest
// depth of the 2x2 pixels it covers (pixels past the edge clamped to it); each further
// level halves the one before. So texel (x, y) of level m holds the farthest depth of the pixels
// [2^(m+1) x, 2^(m+1) (x + 1)) per axis: a conservative bound for whatever lies behind.

@group(0) @binding(0) var depth: texture_depth_2d;
@group(0) @binding(1) var first_out: texture_storage_2d<r32float, write>;

@group(0) @binding(2) var below: texture_2d<f32>;
@group(0) @binding(3) var down_out: texture_storage_2d<r32float, write>;

@compute @workgroup_size(8, 8)
fn first(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(first_out);
    if (id.x >= size.x || id.y >= size.y) {
        return;
    }
    let last = vec2<i32>(textureDimensions(depth)) - 1;
    let b = vec2<i32>(id.xy) * 2;
    let z = max(
        max(textureLoad(depth, min(b, last), 0), textureLoad(depth, min(b + vec2<i32>(1, 0), last), 0)),
        max(textureLoad(depth, min(b + vec2<i32>(0, 1), last), 0), textureLoad(depth, min(b + vec2<i32>(1, 1), last), 0)),
    );
    textureStore(first_out, vec2<i32>(id.xy), vec4<f32>(z, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn down(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(down_out);
    if (id.x >= size.x || id.y >= size.y) {
        return;
    }
    let last = vec2<i32>(textureDimensions(below)) - 1;
    let b = vec2<i32>(id.xy) * 2;
    let z = max(
        max(textureLoad(below, min(b, last), 0).r, textureLoad(below, min(b + vec2<i32>(1, 0), last), 0).r),
        max(textureLoad(below, min(b + vec2<i32>(0, 1), last), 0).r, textureLoad(below, min(b + vec2<i32>(1, 1), last), 0).r),
    );
    textureStore(down_out, vec2<i32>(id.xy), vec4<f32>(z, 0.0, 0.0, 1.0));
}
