//! Measured leaf spectra from text files: wavelength (nm), reflectance and, optionally,
//! transmittance, as laboratory spectrometers and spectral libraries export them.
//!
//! The format: one sample a line, columns separated by commas, semicolons, tabs or spaces;
//! `#` starts a comment line; one header line (any line whose fields are not all numbers)
//! may come before the first sample. Two columns are `wavelength_nm reflectance`, three
//! `wavelength_nm reflectance transmittance`; every line has the same number. Samples outside
//! 400-2500 nm (PROSPECT's range) are dropped and counted. Every rule that fails is an error
//! naming the file and the line: unsorted or duplicate wavelengths, NaN, values outside
//! `[0, 1]` (a hint where they look like percent), `R + T > 1`, a line with a missing
//! column, fewer than 10 samples in 400-2500 nm, wavelengths that look like micrometres.

use std::path::{Path, PathBuf};

/// Fewest samples inside 400-2500 nm a fit accepts.
pub const MIN_SAMPLES: usize = 10;

/// Largest spectrum file read, bytes (64 MiB: a 1 nm spectrum is about 60 kB).
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// A measured spectrum, samples inside 400-2500 nm, wavelengths strictly increasing.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredSpectrum {
    /// Wavelengths, nm.
    pub nm: Vec<f64>,
    /// Directional-hemispherical reflectance, `[0, 1]`.
    pub r: Vec<f64>,
    /// Transmittance, `[0, 1]`, where the file has a third column.
    pub t: Option<Vec<f64>>,
    /// Samples the file had outside 400-2500 nm (dropped).
    pub dropped: usize,
}

/// Why a spectrum file was refused.
#[derive(Debug, thiserror::Error)]
pub enum MeasuredError {
    /// The file could not be read.
    #[error("cannot read spectrum file '{path}': {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        #[source]
        source: std::io::Error,
    },
    /// One line is wrong.
    #[error("spectrum file '{path}', line {line}: {message}")]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong, in words.
        message: String,
    },
    /// The file as a whole is wrong (too few samples, no overlap).
    #[error("spectrum file '{path}': {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong, in words.
        message: String,
    },
}

/// The lines of a numeric table file that hold something: `(1-based line, trimmed text,
/// fields)`, fields separated by commas, semicolons or white space; blank lines, `#`
/// comments and a byte-order mark skipped. Shared by the spectrum and response-curve readers.
pub(crate) fn table_lines(text: &str) -> impl Iterator<Item = (usize, &str, Vec<&str>)> {
    text.lines().enumerate().filter_map(|(k, raw)| {
        let s = raw.trim().trim_start_matches('\u{feff}');
        if s.is_empty() || s.starts_with('#') {
            return None;
        }
        let fields = s
            .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        Some((k + 1, s, fields))
    })
}

impl MeasuredSpectrum {
    /// Reads and checks a spectrum file (see the module docs).
    pub fn read(path: &Path) -> Result<Self, MeasuredError> {
        let io = |source| MeasuredError::Io {
            path: path.to_owned(),
            source,
        };
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(io(std::io::Error::other("not a regular file")));
        }
        if meta.len() > MAX_FILE_BYTES {
            return Err(io(std::io::Error::other(format!(
                "{} bytes, more than the {MAX_FILE_BYTES} a spectrum file may have",
                meta.len()
            ))));
        }
        let bytes = std::fs::read(path).map_err(io)?;
        let text = String::from_utf8(bytes).map_err(|_| MeasuredError::File {
            path: path.to_owned(),
            message: "is not UTF-8 text".into(),
        })?;
        Self::parse(&text, path)
    }

    /// Parses and checks the text of a spectrum file; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, MeasuredError> {
        let line_err = |line: usize, message: String| MeasuredError::Line {
            path: path.to_owned(),
            line,
            message,
        };
        let mut columns: Option<(usize, usize)> = None; // (count, first data line)
        let mut seen_data_or_header = false;
        let mut rows: Vec<(usize, [f64; 3])> = Vec::new();
        for (line, _, fields) in table_lines(text) {
            let numbers: Vec<Option<f64>> = fields.iter().map(|f| f.parse::<f64>().ok()).collect();
            if numbers.iter().any(Option::is_none) {
                if !seen_data_or_header {
                    seen_data_or_header = true;
                    continue; // the header line
                }
                let bad = fields[numbers.iter().position(Option::is_none).unwrap_or(0)];
                return Err(line_err(
                    line,
                    format!("'{bad}' is not a number (only the first line may be a header)"),
                ));
            }
            seen_data_or_header = true;
            let n = numbers.len();
            match columns {
                None => {
                    if !(2..=3).contains(&n) {
                        return Err(line_err(
                            line,
                            format!(
                                "{n} column(s); expected 2 (wavelength_nm, reflectance) or 3 \
                                 (wavelength_nm, reflectance, transmittance)"
                            ),
                        ));
                    }
                    columns = Some((n, line));
                }
                Some((want, first)) if want != n => {
                    return Err(line_err(
                        line,
                        format!(
                            "{n} column(s), but line {first} has {want}: every line needs the same columns"
                        ),
                    ));
                }
                Some(_) => {}
            }
            let v: Vec<f64> = numbers.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect();
            let names = ["wavelength", "reflectance", "transmittance"];
            for (i, x) in v.iter().enumerate() {
                if !x.is_finite() {
                    return Err(line_err(
                        line,
                        format!("{} is {x}, not a finite number", names[i]),
                    ));
                }
            }
            for (i, x) in v.iter().enumerate().skip(1) {
                if !(0.0..=1.0).contains(x) {
                    let hint = if *x > 1.0 && *x <= 100.0 {
                        " (percent? give fractions: divide by 100)"
                    } else {
                        ""
                    };
                    return Err(line_err(
                        line,
                        format!("{} {x} is outside [0, 1]{hint}", names[i]),
                    ));
                }
            }
            if n == 3 && v[1] + v[2] > 1.0 + 1e-9 {
                return Err(line_err(
                    line,
                    format!(
                        "reflectance + transmittance = {} is above 1 (a leaf cannot give back more light than it gets)",
                        v[1] + v[2]
                    ),
                ));
            }
            if let Some((prev_line, prev)) = rows.last()
                && v[0] <= prev[0]
            {
                let what = if v[0] == prev[0] {
                    "repeats"
                } else {
                    "is below"
                };
                return Err(line_err(
                    line,
                    format!(
                        "wavelength {} nm {what} the one on line {prev_line} ({} nm): wavelengths must increase strictly",
                        v[0], prev[0]
                    ),
                ));
            }
            rows.push((line, [v[0], v[1], v.get(2).copied().unwrap_or(f64::NAN)]));
        }
        let file_err = |message: String| MeasuredError::File {
            path: path.to_owned(),
            message,
        };
        let Some((ncol, _)) = columns else {
            return Err(file_err("holds no samples".into()));
        };
        if rows.last().is_some_and(|r| r.1[0] < 10.0) {
            return Err(file_err(
                "the wavelengths are all below 10: they look like micrometres; give nanometres"
                    .into(),
            ));
        }
        let inside: Vec<&[f64; 3]> = rows
            .iter()
            .map(|r| &r.1)
            .filter(|v| (400.0..=2500.0).contains(&v[0]))
            .collect();
        if inside.is_empty() {
            return Err(file_err(format!(
                "none of its {} samples lies inside 400-2500 nm ({}-{} nm)",
                rows.len(),
                rows[0].1[0],
                rows[rows.len() - 1].1[0]
            )));
        }
        if inside.len() < MIN_SAMPLES {
            return Err(file_err(format!(
                "{} samples inside 400-2500 nm; at least {MIN_SAMPLES} are needed",
                inside.len()
            )));
        }
        Ok(MeasuredSpectrum {
            nm: inside.iter().map(|v| v[0]).collect(),
            r: inside.iter().map(|v| v[1]).collect(),
            t: (ncol == 3).then(|| inside.iter().map(|v| v[2]).collect()),
            dropped: rows.len() - inside.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<MeasuredSpectrum, String> {
        MeasuredSpectrum::parse(text, Path::new("leaf.csv")).map_err(|e| e.to_string())
    }

    fn rows(n: usize, f: impl Fn(usize) -> String) -> String {
        (0..n).map(f).collect::<Vec<_>>().join("\n")
    }

    #[test]
    fn reads_csv_and_whitespace_with_a_header() {
        let csv = format!(
            "# exported\nwavelength_nm,reflectance,transmittance\n{}",
            rows(20, |i| format!("{},0.1,0.2", 390 + 10 * i))
        );
        let s = parse(&csv).unwrap();
        assert_eq!((s.nm.len(), s.dropped), (19, 1));
        assert_eq!(s.t.as_ref().unwrap()[0], 0.2);
        let ws = rows(12, |i| format!("{}\t0.3", 400 + 100 * i));
        let s = parse(&ws).unwrap();
        assert!(s.t.is_none());
    }

    #[test]
    fn bad_files_name_the_line_and_the_rule() {
        let ok = |i: usize| format!("{},0.1,0.2", 400 + 10 * i);
        for (text, words) in [
            (
                format!("{}\n405,0.1,0.2", rows(12, ok)),
                vec!["line 13", "405", "below"],
            ),
            (
                format!("{}\n510,0.1,0.2", rows(12, ok)),
                vec!["line 13", "repeats"],
            ),
            (
                format!("{}\n600,NaN,0.2", rows(12, ok)),
                vec!["line 13", "reflectance", "NaN"],
            ),
            (
                format!("{}\n600,45,20", rows(12, ok)),
                vec!["line 13", "percent"],
            ),
            (
                format!("{}\n600,0.6,0.5", rows(12, ok)),
                vec!["line 13", "above 1"],
            ),
            (
                format!("{}\n600,0.1", rows(12, ok)),
                vec!["line 13", "2 column(s)", "line 1 has 3"],
            ),
            (
                format!("{}\n600,0.1,abc", rows(12, ok)),
                vec!["line 13", "abc"],
            ),
            (rows(5, ok), vec!["5 samples", "at least 10"]),
            (
                rows(12, |i| format!("{},0.1", 100 + i)),
                vec!["none", "400-2500"],
            ),
            (
                rows(12, |i| format!("{},0.1", 0.4 + 0.1 * i as f64)),
                vec!["micrometres"],
            ),
            ("1,2,3,4\n".to_string(), vec!["4 column(s)"]),
            ("wavelength,r\n".to_string(), vec!["no samples"]),
        ] {
            let e = parse(&text).unwrap_err();
            assert!(e.contains("leaf.csv"), "{e}");
            for w in words {
                assert!(e.contains(w), "expected '{w}' in: {e}");
            }
        }
    }
}
