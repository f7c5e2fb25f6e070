//! Sensor results as the CSV files the scene names, for an RGB run (one result per sensor)
//! or a band run (one result per group of three bands, see [`crate::bands::band_groups`]).

use super::{Estimate, Measurement, SensorOutput};
use lamina_core::radiometry::SensorKind;
use std::fmt::Write;
use std::path::PathBuf;

/// The film's channel names of an RGB run.
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

/// `(value, std)` of each of `channels` channels of the estimate `get` picks from one
/// sensor's results: `outs[g]` holds the channels `groups[g]` (indices) in its R, G, B (an
/// RGB run: one output, group `[0, 1, 2]`; a band run: one output per group of three bands).
/// NaN for a channel no group holds.
pub fn gather(
    outs: &[&SensorOutput],
    groups: &[Vec<usize>],
    channels: usize,
    get: &dyn Fn(&SensorOutput) -> Option<Estimate>,
) -> Vec<(f64, f64)> {
    let mut v = vec![(f64::NAN, f64::NAN); channels];
    for (out, group) in outs.iter().zip(groups) {
        if let Some(e) = get(out) {
            for (k, &c) in group.iter().enumerate().take(3) {
                if let Some(slot) = v.get_mut(c) {
                    *slot = (e.value.to_array()[k], e.std.to_array()[k]);
                }
            }
        }
    }
    v
}

/// One sensor's results over all channels: per group of channels its result, and the
/// channels (indices into the names) each group holds in its R, G, B.
struct Runs<'a> {
    outs: &'a [&'a SensorOutput],
    groups: &'a [Vec<usize>],
    names: &'a [String],
}

impl Runs<'_> {
    /// `(value, std)` of every channel, in name order, of the estimate `get` picks.
    fn values(&self, get: &dyn Fn(&SensorOutput) -> Option<Estimate>) -> Vec<(f64, f64)> {
        gather(self.outs, self.groups, self.names.len(), get)
    }

    /// Appends the rows of one estimate: `prefix,value,std` for the one channel the sensor
    /// asks for, or `prefix,channel,value,std` per channel.
    fn rows(
        &self,
        out: &mut String,
        prefix: &str,
        get: &dyn Fn(&SensorOutput) -> Option<Estimate>,
    ) {
        let v = self.values(get);
        match self.outs[0].sensor.channel {
            Some(c) => {
                let (x, s) = v.get(c).copied().unwrap_or((f64::NAN, f64::NAN));
                let _ = writeln!(out, "{prefix},{x:.6},{s:.6}");
            }
            None => {
                for (name, (x, s)) in self.names.iter().zip(v) {
                    let _ = writeln!(out, "{prefix},{},{x:.6},{s:.6}", field(name));
                }
            }
        }
    }
}

/// The CSV files of a sensor's result in an RGB run (path, text), channels named `names`.
/// A fisheye sensor's image is not among them (it is an image, written with the film's
/// settings).
pub fn csv_files(out: &SensorOutput, names: &[String]) -> Vec<(PathBuf, String)> {
    csv_files_bands(&[out], &[vec![0, 1, 2]], names)
}

/// [`csv_files`] for a band run: `outs[g]` is the sensor's result for the bands `groups[g]`
/// (indices into `names`, the film's bands).
pub fn csv_files_bands(
    outs: &[&SensorOutput],
    groups: &[Vec<usize>],
    names: &[String],
) -> Vec<(PathBuf, String)> {
    let Some(first) = outs.first() else {
        return Vec::new();
    };
    let runs = Runs {
        outs,
        groups,
        names,
    };
    let head = |cols: &str| match first.sensor.channel {
        Some(_) => format!("{}\n", cols.replace('|', "")),
        None => {
            let (a, b) = cols.split_once('|').unwrap_or((cols, ""));
            format!("{a}channel,{b}\n")
        }
    };
    match (&first.measurement, &first.sensor.kind) {
        (Measurement::Brf(r), SensorKind::Brf { sweeps, .. }) => sweeps
            .iter()
            .enumerate()
            .map(|(si, sweep)| {
                let mut text = head("sza,vza,raa,|brf,std");
                for (di, d) in sweep.directions.iter().enumerate() {
                    let prefix = format!(
                        "{:.2},{:.2},{:.2}",
                        r.sun_zenith, d.zenith, d.relative_azimuth
                    );
                    runs.rows(&mut text, &prefix, &|o| match &o.measurement {
                        Measurement::Brf(b) => b.sweeps.get(si)?.get(di).copied(),
                        _ => None,
                    });
                }
                (sweep.file.clone(), text)
            })
            .collect(),
        (Measurement::Irradiance(r), SensorKind::Irradiance { file, .. }) => {
            let mut text = head("x_min,x_max,z_min,z_max,|down,down_std,up,up_std");
            for (k, c) in r.cells.iter().enumerate() {
                let prefix = format!(
                    "{},{},{},{}",
                    c.rect.min.x, c.rect.max.x, c.rect.min.y, c.rect.max.y
                );
                let cell = |o: &SensorOutput, up: bool| match &o.measurement {
                    Measurement::Irradiance(i) => {
                        i.cells.get(k).map(|c| if up { c.up } else { c.down })
                    }
                    _ => None,
                };
                let down = runs.values(&|o| cell(o, false));
                let up = runs.values(&|o| cell(o, true));
                let chans: Vec<usize> = match first.sensor.channel {
                    Some(c) => vec![c],
                    None => (0..names.len()).collect(),
                };
                for ci in chans {
                    let name = if first.sensor.channel.is_some() {
                        String::new()
                    } else {
                        format!("{},", field(&names[ci]))
                    };
                    let (d, u) = (down[ci], up[ci]);
                    let _ = writeln!(
                        text,
                        "{prefix},{name}{:.6},{:.6},{:.6},{:.6}",
                        d.0, d.1, u.0, u.1
                    );
                }
            }
            vec![(file.clone(), text)]
        }
        (Measurement::Absorbed(r), SensorKind::Absorbed { file, .. }) => {
            let mut text = head("measure,|value,std");
            for (name, pick) in super::absorbed::AbsorbedResult::MEASURES {
                runs.rows(&mut text, name, &|o| match &o.measurement {
                    Measurement::Absorbed(a) => Some(pick(a)),
                    _ => None,
                });
            }
            for (k, (name, _)) in r.materials.iter().enumerate() {
                runs.rows(
                    &mut text,
                    &field(&format!("absorbed:material:{name}")),
                    &|o| match &o.measurement {
                        Measurement::Absorbed(a) => a.materials.get(k).map(|m| m.1),
                        _ => None,
                    },
                );
            }
            for (k, (name, _)) in r.objects.iter().enumerate() {
                runs.rows(
                    &mut text,
                    &field(&format!("absorbed:object:{name}")),
                    &|o| match &o.measurement {
                        Measurement::Absorbed(a) => a.objects.get(k).map(|m| m.1),
                        _ => None,
                    },
                );
            }
            vec![(file.clone(), text)]
        }
        (Measurement::Fisheye(r), SensorKind::Fisheye { gap_file, .. }) => gap_file
            .iter()
            .map(|f| {
                // The gap fraction is geometric: the same in every band.
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
