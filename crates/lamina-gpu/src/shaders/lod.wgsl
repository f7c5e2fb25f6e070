// Stochastic simplification of foliage, shared by scene.wgsl and cull.wgsl. The formulas
// and their meaning are documented in renderer/lod.rs (whose functions of the same names
// these mirror); LOD_BUCKETS and LOD_FADE are prepended from there when the shaders are
// compiled.

// The fade width at fraction kept f.
fn lod_fade_width(f: f32) -> f32 {
    return max(min(LOD_FADE * f, 2.0 * (1.0 - f)), 0.0);
}

// The largest rank drawn at fraction kept f.
fn lod_last_rank(f: f32) -> f32 {
    if (f >= 1.0) {
        return 1.0;
    }
    return f + 0.5 * lod_fade_width(f);
}

// The area factor w(r) / f of an element of rank r at fraction kept f (0: not drawn).
fn lod_area_factor(rank: f32, f: f32) -> f32 {
    if (f >= 1.0) {
        return 1.0;
    }
    let d = lod_fade_width(f);
    let u = lod_last_rank(f);
    var w = select(0.0, 1.0, rank < u);
    if (d > 0.0) {
        w = clamp((u - rank) / d, 0.0, 1.0);
    }
    return w / f;
}
