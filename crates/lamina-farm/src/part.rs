//! Part files: one part of a render (a sample range of a crop of the image) as an OpenEXR
//! file that says what it holds.
//!
//! A part file is a normal EXR that any viewer opens: its channels (`R`, `G`, `B`, or the
//! spectral bands' names) hold the mean radiance of the part's samples (exactly the image
//! `lamina render` would write for those samples), its data window is the crop and its
//! display window the whole image (the usual EXR convention for a region). Beside each
//! channel `C` is `lamina_lo.C = f32(S − n·C)`, the remainder of the pixel's f64 sum `S`
//! of its `n` samples, so that a merge recovers `S = n·C + lamina_lo.C`: exactly whenever
//! the remainder fits an f32's 24 bits, which it does unless the pixel's samples span more
//! than about 2²⁴/n in magnitude (and to `2⁻²⁴` of the remainder otherwise; see
//! [`crate::merge`]). The header attribute `lamina.part` holds a [`PartInfo`] as JSON: the
//! scene hash, seed, full sample count, the samples and pixels held, film settings and the
//! lamina version.

use crate::error::FarmError;
use exr::prelude::{AttributeValue, FlatSamples, ReadChannels, ReadLayers, Text, read};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The name of the header attribute that holds a part's [`PartInfo`].
pub const PART_ATTRIBUTE: &str = "lamina.part";
/// The layer of the f32 remainders of the sums (`lamina_lo.C`).
pub const LO_LAYER: &str = "lamina_lo";

/// What a part file holds and what it must agree on with the other parts of its render.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartInfo {
    /// The lamina that wrote it (`lamina 0.1.0`): parts of one render come from one version.
    pub generator: String,
    /// The scene file's name, for messages (not compared: nodes may mount it elsewhere).
    pub scene: String,
    /// [`crate::hash`] of the loaded scene.
    pub scene_hash: String,
    /// The render's seed.
    pub seed: u64,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// The sample indices `[start, end)` this part holds (fewer than asked when it was
    /// stopped early).
    pub samples: [u32; 2],
    /// The sample indices it was asked to render.
    pub samples_requested: [u32; 2],
    /// `[k, n]` for `--part k/n`, if the samples were split that way.
    pub part: Option<[u32; 2]>,
    /// The whole image's width in pixels.
    pub width: u32,
    /// The whole image's height in pixels.
    pub height: u32,
    /// The pixels this part holds, `[x0, y0, x1, y1]` (half-open, from the top-left).
    pub crop: [u32; 4],
    /// The pixel filter (its `Debug` text).
    pub filter: String,
    /// The film's exposure in stops (for PNG output of the merge).
    pub exposure: f32,
    /// The film's tone map (`Clamp`, `Aces`, `Reinhard`).
    pub tonemap: String,
    /// The channels, in order: `R`, `G`, `B` or the spectral bands' names.
    pub channels: Vec<String>,
    /// The three channels a PNG shows as red, green and blue.
    pub false_color: [String; 3],
}

impl PartInfo {
    /// Samples per pixel held.
    pub fn sample_count(&self) -> u32 {
        self.samples[1].saturating_sub(self.samples[0])
    }

    /// Pixels held: crop width and height.
    pub fn crop_size(&self) -> (u32, u32) {
        (
            self.crop[2].saturating_sub(self.crop[0]),
            self.crop[3].saturating_sub(self.crop[1]),
        )
    }

    /// The info's own consistency: ranges inside the image and the render's samples,
    /// channels named, the three PNG channels among them.
    pub fn validate(&self) -> Result<(), String> {
        let [s0, s1] = self.samples;
        let [r0, r1] = self.samples_requested;
        if !(r0 < r1 && r1 <= self.spp && s0 == r0 && s1 <= r1) {
            return Err(format!(
                "samples {s0}..{s1} (asked {r0}..{r1}) do not fit 0..{}",
                self.spp
            ));
        }
        if let Some([k, n]) = self.part
            && k >= n
        {
            return Err(format!("part {k}/{n}: k must be below n"));
        }
        let [x0, y0, x1, y1] = self.crop;
        if !(x0 < x1 && y0 < y1 && x1 <= self.width && y1 <= self.height) {
            return Err(format!(
                "crop {x0},{y0},{x1},{y1} is not a rectangle inside the {}x{} image",
                self.width, self.height
            ));
        }
        if self.channels.is_empty() {
            return Err("no channels".into());
        }
        for c in &self.false_color {
            if !self.channels.contains(c) {
                return Err(format!("PNG channel '{c}' is not one of the channels"));
            }
        }
        Ok(())
    }
}

/// A part: its info and, per channel, the f64 sum of its samples' radiance per pixel of
/// the crop (row-major, top row first).
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// What the part holds.
    pub info: PartInfo,
    /// `info.channels[i]`'s sums over the part's `info.sample_count()` samples,
    /// `crop width x crop height` values.
    pub sums: Vec<Vec<f64>>,
}

/// The f32 mean of `n` samples whose f64 sum is `sum`, computed as the renderer's film
/// does (`lamina_render::film::Accumulator::mean`: the sum times the f64 reciprocal of
/// `n`), so that equal sums give bit-identical images; 0 when `n` is 0.
pub fn mean_f32(sum: f64, n: u32) -> f32 {
    let inv = if n == 0 { 0.0 } else { 1.0 / n as f64 };
    (sum * inv) as f32
}

/// The EXR bytes of `part` (see the module docs): deterministic, lossless, lamina's mark in
/// `software`.
pub fn encode_part(part: &Part) -> Result<Vec<u8>, String> {
    let info = &part.info;
    info.validate()?;
    let (w, h) = info.crop_size();
    let n = w as usize * h as usize;
    if part.sums.len() != info.channels.len() || part.sums.iter().any(|m| m.len() != n) {
        return Err(format!(
            "{} channels of {} values expected for a {w}x{h} crop",
            info.channels.len(),
            n
        ));
    }
    let json = serde_json::to_string(info).map_err(|e| e.to_string())?;
    let count = info.sample_count();
    let mut channels = Vec::with_capacity(2 * info.channels.len());
    for (name, sums) in info.channels.iter().zip(&part.sums) {
        let hi: Vec<f32> = sums.iter().map(|&s| mean_f32(s, count)).collect();
        let lo: Vec<f32> = sums
            .iter()
            .zip(&hi)
            .map(|(&s, &hi)| {
                if hi.is_finite() {
                    (s - count as f64 * hi as f64) as f32
                } else {
                    0.0
                }
            })
            .collect();
        channels.push((name.clone(), hi));
        channels.push((format!("{LO_LAYER}.{name}"), lo));
    }
    let layout = lamina_io::image_out::ExrLayout {
        position: (info.crop[0] as i32, info.crop[1] as i32),
        display: Some((info.width, info.height)),
        attributes: vec![(PART_ATTRIBUTE.into(), json)],
    };
    lamina_io::image_out::encode_named_channels(w, h, &channels, &layout)
}

/// Writes `part` to `path` atomically (a temporary file, then a rename).
pub fn write_part(path: &Path, part: &Part) -> Result<(), FarmError> {
    let bytes = encode_part(part).map_err(|why| FarmError::Encode {
        path: path.to_owned(),
        why,
    })?;
    lamina_io::write_bytes(path, &bytes).map_err(|e| FarmError::Write {
        path: path.to_owned(),
        cause: e,
    })
}

/// The header of a part file as the reader sees it: the `lamina.part` text, and the data
/// window (size, position) and display window size.
struct Header {
    json: Option<String>,
    size: (usize, usize),
    position: (i32, i32),
    display: (usize, usize),
}

/// Checks a part file's header: a `lamina.part` description that is consistent and names
/// the file's own data and display windows.
fn check_header(path: &Path, h: Header) -> Result<PartInfo, FarmError> {
    let bad = |why: String| FarmError::BadPart {
        path: path.to_owned(),
        why,
    };
    let Some(json) = h.json else {
        return Err(bad(format!(
            "an EXR without a `{PART_ATTRIBUTE}` header: not a part written by `lamina \
             render --part` or `--crop`"
        )));
    };
    let info: PartInfo =
        serde_json::from_str(&json).map_err(|e| bad(format!("its `{PART_ATTRIBUTE}`: {e}")))?;
    info.validate().map_err(bad)?;
    let (w, h_) = info.crop_size();
    if h.size != (w as usize, h_ as usize)
        || h.position != (info.crop[0] as i32, info.crop[1] as i32)
    {
        return Err(bad(format!(
            "its pixels ({}x{} at {},{}) are not the crop its header names ({w}x{h_} at {},{})",
            h.size.0, h.size.1, h.position.0, h.position.1, info.crop[0], info.crop[1]
        )));
    }
    if h.display != (info.width as usize, info.height as usize) {
        return Err(bad(format!(
            "its display window {}x{} is not the image size {}x{} its header names",
            h.display.0, h.display.1, info.width, info.height
        )));
    }
    Ok(info)
}

/// An exr error as ours, naming the file.
fn exr_error(path: &Path, e: exr::error::Error) -> FarmError {
    match e {
        exr::error::Error::Io(cause) => FarmError::Read {
            path: path.to_owned(),
            cause,
        },
        other => FarmError::BadPart {
            path: path.to_owned(),
            why: format!("not a readable OpenEXR file ({other})"),
        },
    }
}

/// Reads only a part file's header: its [`PartInfo`], checked as [`read_part`] checks it,
/// without decoding pixels (a merge checks every part this way before it reads any).
pub fn read_part_info(path: &Path) -> Result<PartInfo, FarmError> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| exr_error(path, e))?;
    let Some(header) = meta.headers.first() else {
        return Err(FarmError::BadPart {
            path: path.to_owned(),
            why: "an EXR without layers".into(),
        });
    };
    let key = Text::from(PART_ATTRIBUTE);
    let json = match header.own_attributes.other.get(&key) {
        Some(AttributeValue::Text(t)) => Some(t.to_string()),
        _ => match header.shared_attributes.other.get(&key) {
            Some(AttributeValue::Text(t)) => Some(t.to_string()),
            _ => None,
        },
    };
    let pos = header.own_attributes.layer_position;
    let display = header.shared_attributes.display_window.size;
    check_header(
        path,
        Header {
            json,
            size: (header.layer_size.0, header.layer_size.1),
            position: (pos.0, pos.1),
            display: (display.0, display.1),
        },
    )
}

/// Reads a part file: its info (checked for consistency) and its channels, checked against
/// the info (names, crop size and position, display window). Any other EXR, a truncated or
/// corrupt file, is an error naming the file.
pub fn read_part(path: &Path) -> Result<Part, FarmError> {
    let bad = |why: String| FarmError::BadPart {
        path: path.to_owned(),
        why,
    };
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| exr_error(path, e))?;
    // A single-layer file's header is one list; the reader puts unknown attributes with
    // the layer.
    let key = Text::from(PART_ATTRIBUTE);
    let found =
        (image.attributes.other.get(&key)).or_else(|| image.layer_data.attributes.other.get(&key));
    let layer = &image.layer_data;
    let info = check_header(
        path,
        Header {
            json: match found {
                Some(AttributeValue::Text(t)) => Some(t.to_string()),
                _ => None,
            },
            size: (layer.size.0, layer.size.1),
            position: (
                layer.attributes.layer_position.0,
                layer.attributes.layer_position.1,
            ),
            display: (
                image.attributes.display_window.size.0,
                image.attributes.display_window.size.1,
            ),
        },
    )?;
    let find = |name: &str| -> Result<Vec<f32>, FarmError> {
        let ch = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .ok_or_else(|| bad(format!("channel '{name}' is missing")))?;
        match &ch.sample_data {
            FlatSamples::F32(v) => Ok(v.clone()),
            _ => Err(bad(format!("channel '{name}' is not 32-bit float"))),
        }
    };
    let count = info.sample_count() as f64;
    let mut sums = Vec::with_capacity(info.channels.len());
    for name in &info.channels {
        let hi = find(name)?;
        let lo = find(&format!("{LO_LAYER}.{name}"))?;
        sums.push(
            hi.iter()
                .zip(&lo)
                .map(|(&a, &b)| count * a as f64 + b as f64)
                .collect(),
        );
    }
    Ok(Part { info, sums })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn info(crop: [u32; 4], samples: [u32; 2]) -> PartInfo {
        PartInfo {
            generator: lamina_io::GENERATOR.into(),
            scene: "t.toml".into(),
            scene_hash: "0123456789abcdef".into(),
            seed: 3,
            spp: 10,
            samples,
            samples_requested: samples,
            part: None,
            width: 6,
            height: 4,
            crop,
            filter: "Box".into(),
            exposure: 0.0,
            tonemap: "Aces".into(),
            channels: vec!["R".into(), "G".into(), "B".into()],
            false_color: ["R".into(), "G".into(), "B".into()],
        }
    }

    #[test]
    fn parts_round_trip_sums_of_f32_samples_exactly() {
        let info = info([1, 1, 5, 4], [2, 7]);
        let n = 12;
        // Sums of 5 f32 samples (what the renderer adds), one with a sample 2¹⁵ times
        // smaller than the others.
        let sums: Vec<Vec<f64>> = (0..3)
            .map(|c| {
                (0..n)
                    .map(|i| {
                        (0..5)
                            .map(|k| {
                                let v = ((i * 5 + k) as f32 * 0.37 + c as f32).sqrt() / 3.0;
                                (if i == 3 && k == 0 { v / 32768.0 } else { v }) as f64
                            })
                            .sum()
                    })
                    .collect()
            })
            .collect();
        let part = Part {
            info: info.clone(),
            sums: sums.clone(),
        };
        let dir = std::env::temp_dir().join(format!("lamina-farm-part-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.exr");
        write_part(&path, &part).unwrap();
        let back = read_part(&path).unwrap();
        assert_eq!(back.info, info);
        assert_eq!(read_part_info(&path).unwrap(), info);
        assert_eq!(back.sums, sums);
        // Not a part: a plain EXR, a text file, a truncated part.
        std::fs::write(dir.join("t.exr"), b"hello").unwrap();
        let e = read_part(&dir.join("t.exr")).unwrap_err().to_string();
        assert!(e.contains("t.exr") && e.contains("OpenEXR"), "{e}");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(dir.join("cut.exr"), &bytes[..bytes.len() / 2]).unwrap();
        let e = read_part(&dir.join("cut.exr")).unwrap_err().to_string();
        assert!(e.contains("cut.exr"), "{e}");
        let e = read_part_info(&dir.join("t.exr")).unwrap_err().to_string();
        assert!(e.contains("t.exr") && e.contains("OpenEXR"), "{e}");
        exr::prelude::write_rgb_file(dir.join("plain.exr"), 2, 2, |_, _| (0.5f32, 0.5f32, 0.5f32))
            .unwrap();
        let e = read_part(&dir.join("plain.exr")).unwrap_err().to_string();
        assert!(e.contains("lamina.part"), "{e}");
        let e = read_part_info(&dir.join("plain.exr"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("lamina.part"), "{e}");
        let e = read_part(&dir.join("none.exr")).unwrap_err().to_string();
        assert!(e.contains("none.exr"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn inconsistent_infos_are_refused() {
        let mut i = info([0, 0, 6, 4], [0, 10]);
        assert!(i.validate().is_ok());
        i.samples = [0, 11];
        assert!(i.validate().unwrap_err().contains("samples"));
        let mut i = info([0, 0, 7, 4], [0, 10]);
        assert!(i.validate().unwrap_err().contains("crop"));
        i.crop = [0, 0, 6, 4];
        i.part = Some([4, 4]);
        assert!(i.validate().unwrap_err().contains("part"));
        i.part = None;
        i.false_color[0] = "NIR".into();
        assert!(i.validate().unwrap_err().contains("NIR"));
    }
}
