//! Sensor results as the CSV files the scene names.

use super::{Estimate, Measurement, SensorOutput};
use lamina_core::radiometry::SensorKind;
use std::fmt::Write;
use std::path::PathBuf;

/// The film's channel names: `R, G, B`, or the three bands of a band render.
pub fn channel_names() -> Vec<String> {
    ["R", "G", "B"].map(String::from).to_vec()
}

/// A CSV field: quoted when it holds a comma, a quote or a line break.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Channel `c` of `v`.
fn ch(v: glam::DVec3, c: usize) -> f64 {
    v.to_array()[c]
}

/// Appends the rows of one estimate: `prefix,value,std` for the one channel asked for, or
/// `prefix,channel,value,std` per channel.
fn rows(out: &mut String, prefix: &str, e: &Estimate, channel: Option<usize>, names: &[String]) {
    match channel {
        Some(c) => {
            let _ = writeln!(out, "{prefix},{:.6},{:.6}", ch(e.value, c), ch(e.std, c));
        }
        None => {
            for (c, name) in names.iter().enumerate().take(3) {
                let _ = writeln!(
                    out,
                    "{prefix},{},{:.6},{:.6}",
                    field(name),
                    ch(e.value, c),
                    ch(e.std, c)
                );
            }
        }
    }
}

/// The CSV files of a sensor's result (path, text), channels named `names`. A fisheye
/// sensor's image is not among them (it is an image, written with the film's settings).
pub fn csv_files(out: &SensorOutput, names: &[String]) -> Vec<(PathBuf, String)> {
    let channel = out.sensor.channel;
    let head = |cols: &str| match channel {
        Some(_) => format!("{cols}\n"),
        None => {
            let (a, b) = cols.split_once("|").unwrap_or((cols, ""));
            format!("{a}channel,{b}\n")
        }
    };
    match (&out.measurement, &out.sensor.kind) {
        (Measurement::Brf(r), SensorKind::Brf { sweeps, .. }) => sweeps
            .iter()
            .zip(&r.sweeps)
            .map(|(sweep, est)| {
                let mut text = head("sza,vza,raa,|brf,std").replace('|', "");
                for (d, e) in sweep.directions.iter().zip(est) {
                    let prefix = format!(
                        "{:.2},{:.2},{:.2}",
                        r.sun_zenith, d.zenith, d.relative_azimuth
                    );
                    rows(&mut text, &prefix, e, channel, names);
                }
                (sweep.file.clone(), text)
            })
            .collect(),
        (Measurement::Irradiance(r), SensorKind::Irradiance { file, .. }) => {
            let mut text =
                head("x_min,x_max,z_min,z_max,|down,down_std,up,up_std").replace('|', "");
            for c in &r.cells {
                let prefix = format!(
                    "{},{},{},{}",
                    c.rect.min.x, c.rect.max.x, c.rect.min.y, c.rect.max.y
                );
                let chans: Vec<usize> = match channel {
                    Some(k) => vec![k],
                    None => (0..names.len().min(3)).collect(),
                };
                for k in chans {
                    let name = if channel.is_some() {
                        String::new()
                    } else {
                        format!("{},", field(&names[k]))
                    };
                    let _ = writeln!(
                        text,
                        "{prefix},{name}{:.6},{:.6},{:.6},{:.6}",
                        ch(c.down.value, k),
                        ch(c.down.std, k),
                        ch(c.up.value, k),
                        ch(c.up.std, k)
                    );
                }
            }
            vec![(file.clone(), text)]
        }
        (Measurement::Absorbed(r), SensorKind::Absorbed { file, .. }) => {
            let mut text = head("measure,|value,std").replace('|', "");
            rows(&mut text, "albedo", &r.albedo, channel, names);
            rows(&mut text, "fabs", &r.fabs, channel, names);
            rows(&mut text, "ftran", &r.ftran, channel, names);
            rows(
                &mut text,
                "ftran_uncollided",
                &r.ftran_uncollided,
                channel,
                names,
            );
            rows(&mut text, "escaped", &r.escaped, channel, names);
            rows(&mut text, "incident", &r.incident, channel, names);
            for (name, e) in &r.materials {
                rows(
                    &mut text,
                    &field(&format!("absorbed:material:{name}")),
                    e,
                    channel,
                    names,
                );
            }
            for (name, e) in &r.objects {
                rows(
                    &mut text,
                    &field(&format!("absorbed:object:{name}")),
                    e,
                    channel,
                    names,
                );
            }
            vec![(file.clone(), text)]
        }
        (Measurement::Fisheye(r), SensorKind::Fisheye { gap_file, .. }) => gap_file
            .iter()
            .map(|f| {
                let mut text = String::from("zenith_min,zenith_max,gap_fraction,std\n");
                for (k, (g, s)) in r.gap.iter().enumerate() {
                    let z0 = k as f32 * super::fisheye::RING_DEG;
                    let _ = writeln!(text, "{z0},{},{g:.6},{s:.6}", z0 + super::fisheye::RING_DEG);
                }
                (f.clone(), text)
            })
            .collect(),
        _ => Vec::new(),
    }
}
