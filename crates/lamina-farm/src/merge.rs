//! Merging parts into the image one render would have made.
//!
//! [`merge`] checks that the parts belong together (the same lamina, scene hash, seed,
//! sample count, image size, filter, exposure, tone map and channels), that no two hold
//! the same sample of the same pixel (overlapping sample ranges on overlapping crops, or
//! one file given twice), and that together they hold every sample of every pixel; it
//! names the missing parts, sample ranges and regions otherwise. It then adds each part's
//! f64 sums (recovered from the part's `C` and `lamina_lo.C` channels) per pixel and
//! turns the total into the pixel's f32 mean exactly as the renderer's film does
//! ([`crate::part::mean_f32`]).
//!
//! **Exactness.** A single render's pixel is `f32(S · (1/spp))` with `S` the f64 sum of
//! its samples' f32 radiances, added in sample order; the merge computes `S` with the
//! additions grouped by part. A sum of f32 values is exact in f64 as long as the values
//! span fewer than about 2²⁹ in magnitude (their bits then fit in 53), and each part's sum
//! travels exactly (see [`crate::part`]); so in that case, which is every pixel of ordinary
//! renders, the merged image is **bit-identical** to the single render. Otherwise the two
//! sums differ by at most `(spp + parts) · 2⁻⁵³` of the sum of the samples' magnitudes,
//! and each merged channel is within one unit in the last place of the single render's
//! (the f32 rounding, `2⁻²⁴`, dwarfs that). The tests check bit-identity on renders and
//! the bound on sums. Crops need no blending: each pixel's samples stay in that pixel (see
//! `lamina_render::render`), so stitched crops are the whole image.
//!
//! With `allow_missing`, a merge with missing parts writes each pixel as the mean of the
//! samples it has (a pixel with none is black) and says so in its report and header.

use crate::error::FarmError;
use crate::part::{Part, PartInfo};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::fmt::Write;
use std::path::PathBuf;

/// The merged image and what went into it.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The settings every part shares (the first part's info; its own ranges mean nothing
    /// here).
    pub info: PartInfo,
    /// Per channel (`info.channels`), the whole image's values, row-major, top row first.
    pub channels: Vec<Vec<f32>>,
    /// What the merge holds.
    pub summary: MergeSummary,
}

/// What a merge put together; written into the merged EXR's `lamina.merged` header.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MergeSummary {
    /// The lamina that merged.
    pub generator: String,
    /// The scene hash of the parts.
    pub scene_hash: String,
    /// The render's seed.
    pub seed: u64,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// Parts merged.
    pub parts: usize,
    /// Fewest samples any pixel got.
    pub spp_min: u32,
    /// Most samples any pixel got.
    pub spp_max: u32,
    /// Whether every pixel has every sample (the image equals the single render's).
    pub complete: bool,
    /// What is missing, in words (empty when complete).
    pub missing: String,
}

/// The attribute of a merged EXR that holds its [`MergeSummary`].
pub const MERGED_ATTRIBUTE: &str = "lamina.merged";

/// What the parts' descriptions say together, checked: the shared settings, each pixel's
/// sample count, and the summary. Made from headers alone, before any pixel is read.
#[derive(Clone, Debug)]
pub struct MergePlan {
    info: PartInfo,
    counts: Vec<u32>,
    summary: MergeSummary,
}

/// Checks that the parts described by `infos` (each with its file, for messages) belong
/// together, do not overlap and, unless `allow_missing`, hold the whole render. Errors:
/// no parts, a setting that differs (named, with both files), an overlap, missing parts
/// (named).
pub fn plan_merge(
    infos: &[(PathBuf, PartInfo)],
    allow_missing: bool,
) -> Result<MergePlan, FarmError> {
    let Some((first_path, reference)) = infos.first() else {
        return Err(FarmError::Mismatch("no parts to merge".into()));
    };
    for (path, info) in &infos[1..] {
        check_same(first_path, reference, path, info)?;
    }
    check_overlaps(infos)?;
    let w = reference.width as usize;
    let mut counts = vec![0u32; w * reference.height as usize];
    for (_, i) in infos {
        let [x0, y0, x1, _] = i.crop;
        let cw = (x1 - x0) as usize;
        for j in 0..cw * i.crop_size().1 as usize {
            counts[(y0 as usize + j / cw) * w + x0 as usize + j % cw] += i.sample_count();
        }
    }
    let spp_min = counts.iter().copied().min().unwrap_or(0);
    let spp_max = counts.iter().copied().max().unwrap_or(0);
    let complete = spp_min == reference.spp;
    let missing = if complete {
        String::new()
    } else {
        describe_missing(infos, reference, &counts)
    };
    if !complete && !allow_missing {
        return Err(FarmError::Missing(format!(
            "the parts do not hold the whole render ({} spp): {missing}; render the missing \
             parts, or pass --allow-missing to write the image from the samples present",
            reference.spp
        )));
    }
    Ok(MergePlan {
        info: reference.clone(),
        counts,
        summary: MergeSummary {
            generator: lamina_io::GENERATOR.into(),
            scene_hash: reference.scene_hash.clone(),
            seed: reference.seed,
            spp: reference.spp,
            parts: infos.len(),
            spp_min,
            spp_max,
            complete,
            missing,
        },
    })
}

impl MergePlan {
    /// Adds the parts one at a time (`part_at(k)` gives the k-th part of the plan) into the
    /// f64 sums and turns them into the image; only one part is held at a time.
    fn run<'a>(
        self,
        mut part_at: impl FnMut(usize) -> Result<Cow<'a, Part>, FarmError>,
    ) -> Result<Merged, FarmError> {
        let w = self.info.width as usize;
        let mut sums = vec![vec![0f64; self.counts.len()]; self.info.channels.len()];
        for k in 0..self.summary.parts {
            let part = part_at(k)?;
            let [x0, y0, x1, _] = part.info.crop;
            let cw = (x1 - x0) as usize;
            for (c, part_sums) in part.sums.iter().enumerate() {
                for (j, s) in part_sums.iter().enumerate() {
                    sums[c][(y0 as usize + j / cw) * w + x0 as usize + j % cw] += s;
                }
            }
        }
        let channels = sums
            .iter()
            .map(|s| {
                s.iter()
                    .zip(&self.counts)
                    .map(|(&s, &n)| crate::part::mean_f32(s, n))
                    .collect()
            })
            .collect();
        Ok(Merged {
            info: self.info,
            channels,
            summary: self.summary,
        })
    }
}

/// Merges parts held in memory (each with the file it came from, for messages); see
/// [`plan_merge`] for the checks.
pub fn merge(parts: &[(PathBuf, Part)], allow_missing: bool) -> Result<Merged, FarmError> {
    let infos: Vec<(PathBuf, PartInfo)> = parts
        .iter()
        .map(|(p, part)| (p.clone(), part.info.clone()))
        .collect();
    let plan = plan_merge(&infos, allow_missing)?;
    plan.run(|k| Ok(Cow::Borrowed(&parts[k].1)))
}

/// Merges part files: checks every file's header first ([`plan_merge`]), then reads and
/// adds them one at a time, so memory holds the f64 sums of one image and one part, however
/// many parts there are. A file that changed between the two reads is an error.
pub fn merge_files(paths: &[PathBuf], allow_missing: bool) -> Result<Merged, FarmError> {
    let infos = paths
        .iter()
        .map(|p| Ok((p.clone(), crate::part::read_part_info(p)?)))
        .collect::<Result<Vec<_>, FarmError>>()?;
    let plan = plan_merge(&infos, allow_missing)?;
    plan.run(|k| {
        let part = crate::part::read_part(&paths[k])?;
        if part.info != infos[k].1 {
            return Err(FarmError::BadPart {
                path: paths[k].clone(),
                why: "it changed while the merge read it".into(),
            });
        }
        Ok(Cow::Owned(part))
    })
}

/// The settings a part must share with the first one, each compared with its name.
fn check_same(
    first_path: &std::path::Path,
    a: &PartInfo,
    path: &std::path::Path,
    b: &PartInfo,
) -> Result<(), FarmError> {
    let fields: [(&str, String, String, &str); 10] = [
        (
            "lamina version",
            a.generator.clone(),
            b.generator.clone(),
            "",
        ),
        (
            "scene hash",
            a.scene_hash.clone(),
            b.scene_hash.clone(),
            " (parts of different scenes, or the scene or its files changed between parts)",
        ),
        ("seed", a.seed.to_string(), b.seed.to_string(), ""),
        (
            "samples per pixel",
            a.spp.to_string(),
            b.spp.to_string(),
            "",
        ),
        (
            "image size",
            format!("{}x{}", a.width, a.height),
            format!("{}x{}", b.width, b.height),
            "",
        ),
        ("pixel filter", a.filter.clone(), b.filter.clone(), ""),
        (
            "exposure",
            a.exposure.to_string(),
            b.exposure.to_string(),
            "",
        ),
        ("tone map", a.tonemap.clone(), b.tonemap.clone(), ""),
        ("channels", a.channels.join(","), b.channels.join(","), ""),
        (
            "PNG channels",
            a.false_color.join(","),
            b.false_color.join(","),
            "",
        ),
    ];
    for (what, x, y, hint) in fields {
        if x != y {
            return Err(FarmError::Mismatch(format!(
                "'{}' does not belong with '{}': its {what} is {y}, not {x}{hint}",
                path.display(),
                first_path.display()
            )));
        }
    }
    Ok(())
}

/// No two parts may hold the same sample of the same pixel.
fn check_overlaps(parts: &[(PathBuf, PartInfo)]) -> Result<(), FarmError> {
    for (i, (pa, a)) in parts.iter().enumerate() {
        for (pb, b) in &parts[i + 1..] {
            let crops = a.crop[0] < b.crop[2]
                && b.crop[0] < a.crop[2]
                && a.crop[1] < b.crop[3]
                && b.crop[1] < a.crop[3];
            let samples = a.samples[0] < b.samples[1] && b.samples[0] < a.samples[1];
            if crops && samples {
                let same = std::fs::canonicalize(pa).ok() == std::fs::canonicalize(pb).ok();
                return Err(FarmError::Mismatch(format!(
                    "'{}' and '{}' overlap: both hold samples {}..{} of pixels {}..{} x {}..{}{}",
                    pa.display(),
                    pb.display(),
                    a.samples[0].max(b.samples[0]),
                    a.samples[1].min(b.samples[1]),
                    a.crop[0].max(b.crop[0]),
                    a.crop[2].min(b.crop[2]),
                    a.crop[1].max(b.crop[1]),
                    a.crop[3].min(b.crop[3]),
                    if same {
                        " (the same file given twice)"
                    } else {
                        ""
                    }
                )));
            }
        }
    }
    Ok(())
}

/// Says what is missing: per crop of the parts, the sample ranges no part holds (and the
/// `--part k/n` that would hold them), parts stopped early, and pixels no part covers.
fn describe_missing(parts: &[(PathBuf, PartInfo)], reference: &PartInfo, counts: &[u32]) -> String {
    let mut crops: Vec<[u32; 4]> = parts.iter().map(|(_, p)| p.crop).collect();
    crops.sort_unstable();
    crops.dedup();
    let mut out = Vec::new();
    for crop in &crops {
        let mut held: Vec<(u32, u32, &PartInfo, &PathBuf)> = parts
            .iter()
            .filter(|(_, p)| p.crop == *crop)
            .map(|(f, p)| (p.samples[0], p.samples[1], p, f))
            .collect();
        held.sort_by_key(|h| h.0);
        let mut gaps = Vec::new();
        let mut at = 0;
        for &(s0, s1, _, _) in &held {
            if s0 > at {
                gaps.push((at, s0));
            }
            at = at.max(s1);
        }
        if at < reference.spp {
            gaps.push((at, reference.spp));
        }
        if gaps.is_empty() {
            continue;
        }
        let whole = *crop == [0, 0, reference.width, reference.height];
        let mut line = String::new();
        if !whole {
            let _ = write!(
                line,
                "in region {},{},{},{}: ",
                crop[0], crop[1], crop[2], crop[3]
            );
        }
        let n_parts: Vec<u32> = held.iter().filter_map(|h| h.2.part.map(|p| p[1])).collect();
        let names: Vec<String> = gaps
            .iter()
            .map(|&(g0, g1)| {
                let mut s = format!("samples {g0}..{g1}");
                if let Some(&n) = n_parts
                    .first()
                    .filter(|_| n_parts.iter().all(|&m| m == n_parts[0]))
                {
                    let ks: Vec<String> = (0..n)
                        .filter(|&k| {
                            let r = part_range(k, n, reference.spp);
                            r.0 < g1 && g0 < r.1
                        })
                        .map(|k| format!("{k}/{n}"))
                        .collect();
                    if !ks.is_empty() {
                        let _ = write!(s, " (--part {})", ks.join(", "));
                    }
                }
                s
            })
            .collect();
        line.push_str(&names.join(", "));
        for (s0, s1, info, f) in &held {
            if info.samples_requested[1] > *s1 {
                let _ = write!(
                    line,
                    "; '{}' stopped early at sample {s1} of {}..{}",
                    f.display(),
                    s0,
                    info.samples_requested[1]
                );
            }
        }
        out.push(line);
    }
    let uncovered: Vec<usize> = counts
        .iter()
        .enumerate()
        .filter(|(_, c)| **c == 0)
        .map(|(i, _)| i)
        .collect();
    if !uncovered.is_empty() {
        let w = reference.width as usize;
        let xs = uncovered.iter().map(|i| i % w);
        let (x0, x1) = (xs.clone().min().unwrap_or(0), xs.max().unwrap_or(0) + 1);
        let (y0, y1) = (uncovered[0] / w, uncovered[uncovered.len() - 1] / w + 1);
        out.push(format!(
            "{} pixels no part covers (within {x0},{y0},{x1},{y1})",
            uncovered.len()
        ));
    }
    out.join("; ")
}

/// The [`MergeSummary`] in a merged EXR's header; `None` for a file that is not a merged
/// image lamina wrote (or cannot be read).
pub fn read_merge_summary(path: &std::path::Path) -> Option<MergeSummary> {
    let meta = exr::meta::MetaData::read_from_file(path, false).ok()?;
    let key = exr::prelude::Text::from(MERGED_ATTRIBUTE);
    meta.headers
        .iter()
        .find_map(|h| match h.own_attributes.other.get(&key) {
            Some(exr::prelude::AttributeValue::Text(t)) => {
                serde_json::from_str(&t.to_string()).ok()
            }
            _ => None,
        })
}

/// Writes the merged image to `path`, by extension: `.exr` (every channel, linear float,
/// with the [`MergeSummary`] in the `lamina.merged` header) or `.png` (the three PNG
/// channels under the film's exposure and tone map, as `lamina render` writes it).
/// Atomic, with lamina's mark.
pub fn write_merged(path: &std::path::Path, merged: &Merged) -> Result<(), FarmError> {
    let info = &merged.info;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let encode = |why: String| FarmError::Encode {
        path: path.to_owned(),
        why,
    };
    match ext.as_str() {
        "exr" => {
            let json = serde_json::to_string(&merged.summary).map_err(|e| encode(e.to_string()))?;
            let channels: Vec<(String, Vec<f32>)> = info
                .channels
                .iter()
                .cloned()
                .zip(merged.channels.iter().cloned())
                .collect();
            let layout = lamina_io::image_out::ExrLayout {
                attributes: vec![(MERGED_ATTRIBUTE.into(), json)],
                ..Default::default()
            };
            let bytes = lamina_io::image_out::encode_named_channels(
                info.width,
                info.height,
                &channels,
                &layout,
            )
            .map_err(encode)?;
            lamina_io::write_bytes(path, &bytes).map_err(|e| FarmError::Write {
                path: path.to_owned(),
                cause: e,
            })
        }
        "png" => {
            let pick = |name: &String| {
                let i = info.channels.iter().position(|c| c == name).unwrap_or(0);
                &merged.channels[i]
            };
            let [r, g, b] = [
                pick(&info.false_color[0]),
                pick(&info.false_color[1]),
                pick(&info.false_color[2]),
            ];
            let image = lamina_image::Image {
                width: info.width,
                height: info.height,
                pixels: (0..r.len())
                    .map(|i| glam::Vec3::new(r[i], g[i], b[i]))
                    .collect(),
            };
            let mut film = lamina_core::Film::new(info.width, info.height, info.spp);
            film.exposure = info.exposure;
            film.tonemap = match info.tonemap.as_str() {
                "Clamp" => lamina_core::ToneMap::Clamp,
                "Reinhard" => lamina_core::ToneMap::Reinhard,
                _ => lamina_core::ToneMap::Aces,
            };
            lamina_image::write_image(path, &image, &film).map_err(|e| encode(e.to_string()))
        }
        _ => Err(encode("use .exr or .png".into())),
    }
}

/// `[⌊k·spp/n⌋, ⌊(k+1)·spp/n⌋)`: the samples of `--part k/n` (as `lamina_render::SampleRange::part`).
pub fn part_range(k: u32, n: u32, spp: u32) -> (u32, u32) {
    let at = |i: u32| (i as u64 * spp as u64 / n.max(1) as u64) as u32;
    (at(k), at(k + 1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::part::tests::info;

    fn part(crop: [u32; 4], samples: [u32; 2], k: Option<u32>, value: f64) -> Part {
        let mut i = info(crop, samples);
        i.part = k.map(|k| [k, 2]);
        let n = (crop[2] - crop[0]) as usize * (crop[3] - crop[1]) as usize;
        let sum = value * (samples[1] - samples[0]) as f64;
        Part {
            info: i,
            sums: vec![vec![sum; n]; 3],
        }
    }

    fn named(parts: Vec<Part>) -> Vec<(PathBuf, Part)> {
        parts
            .into_iter()
            .enumerate()
            .map(|(i, p)| (PathBuf::from(format!("p{i}.exr")), p))
            .collect()
    }

    #[test]
    fn weights_by_samples_and_stitches_crops() {
        // Samples 0..5 at 1.0 and 5..10 at 2.0 on the left; the right half whole at 4.0.
        let parts = named(vec![
            part([0, 0, 3, 4], [0, 5], Some(0), 1.0),
            part([0, 0, 3, 4], [5, 10], Some(1), 2.0),
            part([3, 0, 6, 4], [0, 10], None, 4.0),
        ]);
        let m = merge(&parts, false).unwrap();
        assert!(m.summary.complete);
        assert_eq!((m.summary.spp_min, m.summary.spp_max), (10, 10));
        assert_eq!(m.channels[0][0], 1.5);
        assert_eq!(m.channels[2][5], 4.0);
    }

    #[test]
    fn missing_parts_are_named_or_merged_when_allowed() {
        let parts = named(vec![part([0, 0, 6, 4], [0, 5], Some(0), 1.0)]);
        let e = merge(&parts, false).unwrap_err().to_string();
        assert!(e.contains("samples 5..10 (--part 1/2)"), "{e}");
        assert!(e.contains("--allow-missing"), "{e}");
        let m = merge(&parts, true).unwrap();
        assert!(!m.summary.complete);
        assert_eq!(m.summary.spp_min, 5);
        assert_eq!(m.channels[1][7], 1.0);

        let parts = named(vec![part([0, 0, 3, 4], [0, 10], None, 1.0)]);
        let e = merge(&parts, false).unwrap_err().to_string();
        assert!(
            e.contains("12 pixels no part covers (within 3,0,6,4)"),
            "{e}"
        );
        let m = merge(&parts, true).unwrap();
        assert_eq!((m.channels[0][0], m.channels[0][5]), (1.0, 0.0));

        let mut early = part([0, 0, 6, 4], [5, 8], Some(1), 1.0);
        early.info.samples_requested = [5, 10];
        let parts = named(vec![part([0, 0, 6, 4], [0, 5], Some(0), 1.0), early]);
        let e = merge(&parts, false).unwrap_err().to_string();
        assert!(e.contains("stopped early at sample 8"), "{e}");
    }

    /// The bound where f64 sums are not exact: samples spanning 2⁴⁰ in magnitude, summed
    /// whole (as the renderer does) or as parts carried through the part file's hi/lo
    /// channels, give f32 means within one unit in the last place.
    #[test]
    fn inexact_sums_stay_within_one_ulp() {
        let mut worst = 0;
        for seed in 0..200u32 {
            let samples: Vec<f32> = (0..64u32)
                .map(|i| {
                    let h = (i.wrapping_mul(2_654_435_761) ^ seed.wrapping_mul(40_503)) % 1000;
                    if h < 20 {
                        1.0e9 + h as f32 * 7.0
                    } else {
                        1.0e-3 * (1.0 + h as f32 / 997.0)
                    }
                })
                .collect();
            let whole: f64 = samples.iter().map(|&x| x as f64).sum();
            let single = crate::part::mean_f32(whole, 64);
            for n in [2usize, 3, 7] {
                let mut merged = 0f64;
                for k in 0..n {
                    let part = &samples[k * 64 / n..(k + 1) * 64 / n];
                    let sum: f64 = part.iter().map(|&x| x as f64).sum();
                    let count = part.len() as u32;
                    // What the part file carries and the merge reads back.
                    let hi = crate::part::mean_f32(sum, count);
                    let lo = (sum - count as f64 * hi as f64) as f32;
                    merged += count as f64 * hi as f64 + lo as f64;
                }
                let m = crate::part::mean_f32(merged, 64);
                let ulps = (m.to_bits() as i64 - single.to_bits() as i64).unsigned_abs();
                assert!(ulps <= 1, "seed {seed}, {n} parts: {m} vs {single}");
                worst = worst.max(ulps);
            }
        }
        assert!(worst <= 1);
    }

    #[test]
    fn mismatched_and_overlapping_parts_are_refused() {
        let mut other = part([0, 0, 6, 4], [5, 10], Some(1), 1.0);
        other.info.scene_hash = "ffffffffffffffff".into();
        let parts = named(vec![part([0, 0, 6, 4], [0, 5], Some(0), 1.0), other]);
        let e = merge(&parts, false).unwrap_err().to_string();
        assert!(e.contains("'p1.exr'") && e.contains("scene hash"), "{e}");
        let mut other = part([0, 0, 6, 4], [5, 10], Some(1), 1.0);
        other.info.seed = 4;
        let e = merge(
            &named(vec![part([0, 0, 6, 4], [0, 5], None, 1.0), other]),
            false,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("seed is 4, not 3"), "{e}");
        let parts = named(vec![
            part([0, 0, 6, 4], [0, 6], None, 1.0),
            part([2, 1, 6, 4], [5, 10], None, 1.0),
        ]);
        let e = merge(&parts, false).unwrap_err().to_string();
        assert!(e.contains("overlap") && e.contains("samples 5..6"), "{e}");
        assert!(merge(&[], true).is_err());
    }
}
