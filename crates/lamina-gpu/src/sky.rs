//! The sky as irradiance: nine spherical-harmonic coefficients (bands 0-2) of the sky's
//! radiance, turned into the irradiance `E(n)` (W m⁻²) on a surface facing `n` with the
//! clamped-cosine convolution of Ramamoorthi & Hanrahan (2001). A constant sky is exact
//! (`E = pi L`); an equirectangular sky keeps its low-frequency shape (bright zenith, sun
//! side), which is what diffuse leaf lobes see. How much of this sky a surface sees past
//! the scene is the renderer's sky-visibility maps (`renderer::sky_visibility`), which
//! scale this irradiance in the camera pass.

use glam::Vec3;
use lamina_scene::Sky;
use std::f32::consts::PI;

/// Real SH basis (bands 0-2) at unit direction `d`, in the order of [`sky_irradiance_sh`].
fn sh_basis(d: Vec3) -> [f32; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// Cosine-lobe convolution factors per band (`A_l`): irradiance = sum A_l L_lm Y_lm.
const A_BAND: [f32; 9] = [
    PI,
    2.0 * PI / 3.0,
    2.0 * PI / 3.0,
    2.0 * PI / 3.0,
    PI / 4.0,
    PI / 4.0,
    PI / 4.0,
    PI / 4.0,
    PI / 4.0,
];

/// Irradiance SH coefficients (linear RGB, W m⁻²) of the sky: `E(n) = sum_k c_k Y_k(n)`.
/// `None` sky gives zeros. The equirect map follows lamina-render's convention: azimuth
/// `phi = atan2(d.x, -d.z)` with `u = 0` at `phi = -pi`, `theta = acos(d.y)` from the top
/// row, rotated by `rotation_deg` about `+y`, radiance times `scale`.
pub fn sky_irradiance_sh(sky: Option<&Sky>) -> [Vec3; 9] {
    let mut l = [Vec3::ZERO; 9];
    match sky {
        None => {}
        Some(Sky::Constant(c)) => l[0] = *c * (4.0 * PI).sqrt(),
        Some(Sky::Image {
            map,
            scale,
            rotation_deg,
            ..
        }) => {
            let (w, h) = (map.width() as usize, map.height() as usize);
            let rot = glam::Quat::from_rotation_y(rotation_deg.to_radians());
            let t = map.texels();
            for y in 0..h {
                let theta = PI * (y as f32 + 0.5) / h as f32;
                let d_omega = (2.0 * PI / w as f32) * (PI / h as f32) * theta.sin();
                for x in 0..w {
                    let phi = 2.0 * PI * (x as f32 + 0.5) / w as f32 - PI;
                    let d_map = Vec3::new(
                        theta.sin() * phi.sin(),
                        theta.cos(),
                        -theta.sin() * phi.cos(),
                    );
                    let d = rot * d_map;
                    let radiance = t[y * w + x].truncate() * *scale;
                    for (lk, b) in l.iter_mut().zip(sh_basis(d)) {
                        *lk += radiance * (b * d_omega);
                    }
                }
            }
        }
    }
    let mut e = [Vec3::ZERO; 9];
    for k in 0..9 {
        e[k] = l[k] * A_BAND[k];
    }
    e
}

/// Evaluates the irradiance `E(n)` from [`sky_irradiance_sh`] coefficients (the same sum
/// the shader computes).
pub fn eval_irradiance(c: &[Vec3; 9], n: Vec3) -> Vec3 {
    c.iter()
        .zip(sh_basis(n))
        .fold(Vec3::ZERO, |acc, (ck, b)| acc + *ck * b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_sky_gives_pi_l_everywhere() {
        let c = sky_irradiance_sh(Some(&Sky::Constant(Vec3::new(0.1, 0.2, 0.3))));
        for n in [Vec3::X, Vec3::Y, -Vec3::Z] {
            let e = eval_irradiance(&c, n);
            assert!(
                (e - Vec3::new(0.1, 0.2, 0.3) * PI).abs().max_element() < 1e-4,
                "{e}"
            );
        }
    }

    #[test]
    fn image_sky_bright_above_is_brighter_on_upward_faces() {
        // Upper half 1, lower half 0: E(up) = pi, E(down) = 0 exactly; SH-2 gets
        // about 0.94 pi and 0.06 pi... within 0.2 pi.
        let (w, h) = (32, 16);
        let texels = (0..w * h)
            .map(|i| {
                if i / w < h / 2 {
                    glam::Vec4::ONE
                } else {
                    glam::Vec4::ZERO
                }
            })
            .collect();
        let map = lamina_leaf::Texture::from_texels(
            w as u32,
            h as u32,
            texels,
            lamina_leaf::Wrap::Repeat,
        );
        let c = sky_irradiance_sh(Some(&Sky::Image {
            map,
            scale: 1.0,
            rotation_deg: 0.0,
            spectral: None,
        }));
        let up = eval_irradiance(&c, Vec3::Y).x;
        let down = eval_irradiance(&c, -Vec3::Y).x;
        let side = eval_irradiance(&c, Vec3::X).x;
        assert!(
            (up - PI).abs() < 0.2 * PI && down.abs() < 0.2 * PI,
            "{up} {down}"
        );
        assert!((side - 0.5 * PI).abs() < 0.05 * PI, "{side}");
    }
}
